"""The shared ground truth of a mock fleet: the map, where it is on Earth, who stands where.

Every mock vehicle holds exactly one cell, the one its centre is in. No two
vehicles may hold the same cell, except a charging pad, which is a depot
where any number may stand (the whole fleet starts there).
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

from core.cells import Cell
from core.geo import GeoFrame
from sitl_mock.gridmap import GridMap
from sitl_mock.ranging import ray_distance_m


class BlockReason(Enum):
    OUTSIDE = "outside the map"
    OBSTACLE = "an obstacle"
    VEHICLE = "held by another vehicle"


@dataclass(frozen=True)
class Blocker:
    """Why a cell may not be entered; ``vehicle_id`` is set for ``VEHICLE``."""

    cell: Cell
    reason: BlockReason
    vehicle_id: int | None = None

    def describe(self) -> str:
        where = f"cell ({self.cell[0]}, {self.cell[1]})"
        if self.reason is BlockReason.VEHICLE:
            return f"{where} held by vehicle {self.vehicle_id}"
        return f"{where} is {self.reason.value}"


class World:
    """Ground-truth map, geo frame and the registry of which vehicle holds which cell."""

    def __init__(self, grid_map: GridMap, geo: GeoFrame) -> None:
        self.map = grid_map
        self.geo = geo
        self._cell_of: dict[int, Cell] = {}
        self._holder: dict[Cell, int] = {}

    @property
    def cell_size_m(self) -> float:
        return self.geo.cell_size_m

    def is_depot(self, cell: Cell) -> bool:
        return cell in self.map.pads

    def holder(self, cell: Cell) -> int | None:
        """The vehicle holding a non-depot cell, if any."""
        return self._holder.get(cell)

    def cell_of(self, vehicle_id: int) -> Cell:
        return self._cell_of[vehicle_id]

    def vehicles_in(self, cell: Cell) -> list[int]:
        return sorted(v for v, c in self._cell_of.items() if c == cell)

    def blocker(self, vehicle_id: int, cell: Cell) -> Blocker | None:
        """Why ``vehicle_id`` may not enter ``cell``, or None when it may."""
        if not self.map.inside(cell):
            return Blocker(cell, BlockReason.OUTSIDE)
        if not self.map.is_free(cell):
            return Blocker(cell, BlockReason.OBSTACLE)
        other = self._holder.get(cell)
        if other is not None and other != vehicle_id:
            return Blocker(cell, BlockReason.VEHICLE, other)
        return None

    def place(self, vehicle_id: int, cell: Cell) -> None:
        """Put a vehicle on its start cell."""
        if vehicle_id in self._cell_of:
            raise ValueError(f"vehicle {vehicle_id} is already in the world")
        blocker = self.blocker(vehicle_id, cell)
        if blocker is not None:
            raise ValueError(f"vehicle {vehicle_id} cannot start in {blocker.describe()}")
        self._cell_of[vehicle_id] = cell
        if not self.is_depot(cell):
            self._holder[cell] = vehicle_id

    def move(self, vehicle_id: int, to: Cell) -> Blocker | None:
        """Move a vehicle's hold to ``to``; returns the blocker and moves nothing if refused."""
        blocker = self.blocker(vehicle_id, to)
        if blocker is not None:
            return blocker
        here = self._cell_of[vehicle_id]
        if self._holder.get(here) == vehicle_id:
            del self._holder[here]
        self._cell_of[vehicle_id] = to
        if not self.is_depot(to):
            self._holder[to] = vehicle_id
        return None

    def range_m(self, north_m: float, east_m: float, bearing_deg: float, max_m: float) -> float:
        """Distance to the first wall from a point along a compass bearing (static map only)."""
        return ray_distance_m(self.map, self.cell_size_m, north_m, east_m, bearing_deg, max_m)
