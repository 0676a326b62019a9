"""Checks on a mission before it starts, from the operator's map.

The planner never sees the map of a ``range`` mission; the ground station
does, and warns before launch about cells no vehicle can reach and come back
from on a full battery, so they are never silently skipped.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np

from gcs.mission import Mission
from planner.grid import MOVES, Cell


@dataclass(frozen=True)
class RangeCheck:
    free_cells: int
    out_of_range: tuple[Cell, ...]
    farthest_moves: int
    max_round_trip_moves: float  # inf without a battery limit

    def message(self) -> str:
        cells = len(self.out_of_range)
        return (
            f"{cells} free cell{'s' if cells != 1 else ''} out of range: a full battery takes "
            f"the best vehicle {self.max_round_trip_moves:.0f} moves out and back, the "
            f"farthest cell needs {2 * self.farthest_moves} (e.g. cell {self.out_of_range[0]})"
        )


def charger_distances(mission: Mission) -> np.ndarray:
    """Moves from the charger to every free cell over the true map (-1: unreachable)."""
    grid = mission.map
    dist = np.full(grid.shape, -1, dtype=np.int64)
    dist[mission.charger] = 0
    queue: deque[Cell] = deque([mission.charger])
    while queue:
        cell = queue.popleft()
        for d in MOVES:
            nxt = d.of(cell)
            if grid.is_free(nxt) and dist[nxt] < 0:
                dist[nxt] = dist[cell] + 1
                queue.append(nxt)
    return dist


def check_range(mission: Mission, resume_pct: float = 100.0) -> RangeCheck:
    dist = charger_distances(mission)
    budget = resume_pct - mission.planner.reserve_pct
    best = min((v.energy_per_m_pct for v in mission.fleet), default=0.0) * mission.cell_size_m
    max_trip = float("inf") if best <= 0 else budget / best
    far = np.argwhere(2 * dist > max_trip)
    return RangeCheck(
        free_cells=int((dist >= 0).sum()),
        out_of_range=tuple((int(r), int(c)) for r, c in far),
        farthest_moves=int(dist.max()),
        max_round_trip_moves=max_trip,
    )
