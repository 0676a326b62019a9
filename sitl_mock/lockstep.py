"""The ground-truth world for offline runs: agents move cell by cell in lockstep.

It answers sensing from the true map, moves agents (refusing moves through
walls or into another agent, except on the charging pad, which is a depot
with room for the whole fleet), drains batteries with distance and charges
them on the pad, a limited number at a time.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from types import MappingProxyType

import numpy as np

from core.cells import NEIGHBOURS, Cell, CellState, Direction, manhattan
from sitl_mock.gridmap import GridMap


class WorldError(RuntimeError):
    """A move the physical world does not allow (a bug in whoever commanded it)."""


@dataclass(frozen=True)
class Body:
    """An agent's physics: battery percent used per metre driven, and gained per
    iteration on the pad (None: the world's rate)."""

    id: int
    energy_per_m_pct: float
    charge_pct_per_step: float | None = None


class LockstepWorld:
    def __init__(
        self,
        grid: GridMap,
        bodies: Sequence[Body],
        cell_size_m: float = 1.0,
        charge_pct_per_step: float | None = None,
        charging_slots: int | None = None,
    ) -> None:
        self.grid = grid
        self.cell_size_m = cell_size_m
        self.charge_pct_per_step = charge_pct_per_step
        self.charging_slots = charging_slots
        self._bodies = {b.id: b for b in bodies}
        self._charger = grid.charger
        #: Battery percent each agent uses per move.
        self._move_cost = {b.id: b.energy_per_m_pct * cell_size_m for b in bodies}
        self.position: dict[int, Cell] = {b.id: grid.charger for b in bodies}
        self._held: dict[Cell, int] = {}  # cell -> agent on it, off the pad
        self.battery: dict[int, float] = {b.id: 100.0 for b in bodies}
        self.dead: set[int] = set()
        self._queue: list[int] = []  # charging requests, first come first served
        self._requested: set[int] = set()
        # Free cells as bytes with an obstacle border: sensing is 8 look-ups.
        self._stride = grid.shape[1] + 2
        self._free = np.pad(~grid.obstacle, 1, constant_values=False).tobytes()
        self._offsets = [(d, d.value[0] * self._stride + d.value[1]) for d in NEIGHBOURS]
        #: Readings by the 3x3 block of free bytes around a cell: at most 512 of them,
        #: handed out read-only (shared by every cell with the same block).
        self._readings: dict[bytes, Mapping[Direction, CellState]] = {}

    def sense(self, cell: Cell) -> Mapping[Direction, CellState]:
        """The 8 neighbours of ``cell``: free or obstacle (the paper's eq. 2)."""
        s = self._stride
        i = (cell[0] + 1) * s + cell[1] + 1
        free = self._free
        block = free[i - s - 1 : i - s + 2] + free[i - 1 : i + 2] + free[i + s - 1 : i + s + 2]
        readings = self._readings.get(block)
        if readings is None:
            readings = self._readings[block] = MappingProxyType(
                {d: CellState.FREE if free[i + k] else CellState.OBSTACLE for d, k in self._offsets}
            )
        return readings

    def move(self, agent: int, to: Cell) -> None:
        if agent in self.dead:
            raise WorldError(f"agent {agent} is dead and cannot move")
        here = self.position[agent]
        if manhattan(here, to) != 1:
            raise WorldError(f"agent {agent}: {here} -> {to} is not a move to a neighbour")
        # A neighbour of a cell on the map is on the map or on its border (not free).
        if not self._free[(to[0] + 1) * self._stride + to[1] + 1]:
            raise WorldError(f"agent {agent}: {to} is an obstacle")
        other = self._held.get(to, agent)
        if other != agent:
            raise WorldError(f"agent {agent}: {to} is held by agent {other}")
        if self._held.get(here) == agent:
            del self._held[here]
        if to != self._charger:
            self._held[to] = agent
        self.position[agent] = to
        self.battery[agent] -= self._move_cost[agent]
        if self.battery[agent] <= 0:
            self.battery[agent] = 0.0
            self.dead.add(agent)
        if self._queue:
            self._leave_queue(agent)

    def request_charge(self, agent: int) -> None:
        """The agent stays on the pad and wants charge this iteration."""
        if self.position[agent] != self._charger:
            raise WorldError(f"agent {agent} asked to charge away from the pad")
        self._requested.add(agent)
        if agent not in self._queue:
            self._queue.append(agent)

    def end_iteration(self) -> list[int]:
        """Charge the agents that asked, at most ``charging_slots`` of them; those
        charged (the only batteries that change but by a move)."""
        if not self._queue:  # nobody charging: most iterations
            self._requested.clear()
            return []
        slots = len(self._queue) if self.charging_slots is None else self.charging_slots
        charged = []
        for agent in self._queue[:slots]:
            if agent not in self._requested:
                continue
            charged.append(agent)
            rate = self._bodies[agent].charge_pct_per_step or self.charge_pct_per_step
            if rate is None:
                self.battery[agent] = 100.0
            else:
                self.battery[agent] = min(100.0, self.battery[agent] + rate)
        for agent in [
            a for a in self._queue if self.battery[a] >= 100.0 or a not in self._requested
        ]:
            self._leave_queue(agent)
        self._requested.clear()
        return charged

    def _leave_queue(self, agent: int) -> None:
        if agent in self._queue:
            self._queue.remove(agent)
