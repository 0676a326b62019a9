"""A geofence as ArduPilot keeps one: inclusion polygons uploaded with the mission protocol
(MAV_MISSION_TYPE_FENCE), switched on and told what to do by parameters.

FENCE_ENABLE turns it on, FENCE_TYPE must include the polygon bit (4), and
FENCE_ACTION says what a breach does: 0 report only; 1 RTL; 2 Hold (Rover) or
Land (Copter); other values as 2 here. An armed vehicle outside any inclusion
polygon has breached: it says "Fence Breached" once and acts; back inside, the
breach clears. The polygon items are MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION,
param1 the polygon's vertex count, consecutive items one polygon.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass, field
from enum import IntEnum

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from vehicles.mission_items import MissionItem

#: FENCE_TYPE's polygon bit.
POLYGON_TYPE = 4
LatLon = tuple[float, float]


class FenceAction(IntEnum):
    """ArduPilot's FENCE_ACTION values the mock tells apart."""

    REPORT = 0
    RTL = 1
    HOLD_OR_LAND = 2


@dataclass
class Fence:
    items: tuple[MissionItem, ...] = ()
    enable: float = 0.0
    kind: float = 7.0  # FENCE_TYPE: ArduPilot's default (altitude, circle, polygon)
    action: float = float(FenceAction.HOLD_OR_LAND)
    breached: bool = False
    _polygons: list[list[LatLon]] = field(default_factory=list)

    def replace(self, items: Sequence[MissionItem]) -> None:
        # Kept as ArduPilot keeps them: the vertices only (autocontinue reads back 0).
        self.items = tuple(dataclasses.replace(item, autocontinue=0) for item in items)
        self._polygons = inclusion_polygons(self.items)
        self.breached = False

    @property
    def active(self) -> bool:
        return bool(self.enable) and int(self.kind) & POLYGON_TYPE != 0 and bool(self._polygons)

    def contains(self, lat_deg: float, lon_deg: float) -> bool:
        """Inside every inclusion polygon (ArduPilot: the vehicle must be inside all)."""
        return all(_inside(lat_deg, lon_deg, polygon) for polygon in self._polygons)


def inclusion_polygons(items: Sequence[MissionItem]) -> list[list[LatLon]]:
    """The inclusion polygons of a fence's items (other kinds are ignored)."""
    polygons: list[list[LatLon]] = []
    i = 0
    while i < len(items):
        item = items[i]
        count = int(item.param1)
        if item.command != mavlink.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION or count < 3:
            i += 1
            continue
        vertices = items[i : i + count]
        polygons.append([(v.lat_deg, v.lon_deg) for v in vertices])
        i += count
    return polygons


def _inside(lat: float, lon: float, polygon: list[LatLon]) -> bool:
    """Ray casting in the lat/lon plane (fences are small: the plane is good enough)."""
    inside = False
    j = len(polygon) - 1
    for i, (lat_i, lon_i) in enumerate(polygon):
        lat_j, lon_j = polygon[j]
        if (lon_i > lon) != (lon_j > lon):
            crossing = lat_i + (lon - lon_i) * (lat_j - lat_i) / (lon_j - lon_i)
            if lat < crossing:
                inside = not inside
        j = i
    return inside
