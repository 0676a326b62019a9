"""Geo-referencing of the grid: cells <-> local metres <-> latitude/longitude, and
compass bearings in the local frame.

Planning happens in the local grid frame; positions become latitude and
longitude only at the edge, when we talk MAVLink. The origin is the
north-west corner of cell (0, 0); rows grow southwards, columns eastwards.
A local equirectangular projection is exact enough for areas of a few
kilometres. Bearings are compass degrees: north 0, east 90, clockwise.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from core.cells import Cell

EARTH_RADIUS_M = 6_378_137.0


def cell_centre_local(cell: Cell, cell_size_m: float) -> tuple[float, float]:
    """North and east metres of a cell's centre from the north-west corner of cell (0, 0)
    (rows grow southwards, so north is negative)."""
    return (-(cell[0] + 0.5) * cell_size_m, (cell[1] + 0.5) * cell_size_m)


@dataclass(frozen=True)
class GeoFrame:
    """Where the grid lies on Earth: the latitude, longitude and altitude of the
    north-west corner of cell (0, 0), and the side of a cell in metres."""

    lat_deg: float
    lon_deg: float
    alt_m: float
    cell_size_m: float

    @property
    def _m_per_deg_lat(self) -> float:
        return math.pi * EARTH_RADIUS_M / 180.0

    @property
    def _m_per_deg_lon(self) -> float:
        return self._m_per_deg_lat * math.cos(math.radians(self.lat_deg))

    def local_to_geo(self, north_m: float, east_m: float) -> tuple[float, float]:
        """Latitude and longitude of a point ``north_m``/``east_m`` from the origin."""
        return (
            self.lat_deg + north_m / self._m_per_deg_lat,
            self.lon_deg + east_m / self._m_per_deg_lon,
        )

    def geo_to_local(self, lat_deg: float, lon_deg: float) -> tuple[float, float]:
        """North and east metres of a latitude/longitude from the origin."""
        return (
            (lat_deg - self.lat_deg) * self._m_per_deg_lat,
            (lon_deg - self.lon_deg) * self._m_per_deg_lon,
        )

    def cell_centre_local(self, cell: Cell) -> tuple[float, float]:
        """North and east metres of a cell's centre from the origin."""
        return cell_centre_local(cell, self.cell_size_m)

    def cell_centre(self, cell: Cell) -> tuple[float, float]:
        """Latitude and longitude of a cell's centre."""
        return self.local_to_geo(*self.cell_centre_local(cell))

    def local_to_cell(self, north_m: float, east_m: float) -> Cell:
        """The cell that contains a point ``north_m``/``east_m`` from the origin."""
        return (math.floor(-north_m / self.cell_size_m), math.floor(east_m / self.cell_size_m))

    def geo_to_cell(self, lat_deg: float, lon_deg: float) -> Cell:
        """The cell that contains a latitude/longitude."""
        return self.local_to_cell(*self.geo_to_local(lat_deg, lon_deg))


DEFAULT_ORIGIN = GeoFrame(lat_deg=47.397742, lon_deg=8.545594, alt_m=488.0, cell_size_m=1.0)


def bearing_deg(d_north: float, d_east: float) -> float:
    """Compass bearing, in [0, 360), of a step ``d_north``/``d_east`` metres."""
    return math.degrees(math.atan2(d_east, d_north)) % 360.0


def wrap_deg(angle_deg: float) -> float:
    """``angle_deg`` as a signed turn in [-180, 180): the same direction, the short way."""
    return (angle_deg + 180.0) % 360.0 - 180.0
