"""Checks on a mission before it starts, from the operator's map.

The planner never sees the map of a ``range`` mission; the ground station
does, and warns before launch about cells no vehicle can reach and come back
from on a full battery, so they are never silently skipped.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from core.cells import Cell
from gcs.mission import Mission


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
    """Moves from the charger to every free cell over the true map (-1: unreachable).

    Breadth-first, one whole distance level at a time over flat indices of the
    map with an obstacle border, so that a million cells take a fraction of a second.
    """
    grid = mission.map
    rows, cols = grid.shape
    stride = cols + 2
    free = np.pad(~grid.obstacle, 1, constant_values=False).ravel()
    dist = np.full(free.size, -1, dtype=np.int64)
    steps = np.array([-stride, stride, 1, -1])
    level = np.array([(mission.charger[0] + 1) * stride + mission.charger[1] + 1])
    if not free[level[0]]:
        level = level[:0]
    moves = 0
    while level.size:
        dist[level] = moves
        ahead = (level[:, None] + steps).ravel()
        level = np.unique(ahead[free[ahead] & (dist[ahead] < 0)])
        moves += 1
    return dist.reshape(rows + 2, stride)[1:-1, 1:-1].copy()


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
