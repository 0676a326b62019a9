"""What a finished run produced: the values that reports, figures and logs are made of."""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from core.cells import Cell
from planner.agent import EventKind, PlannerEvent


@dataclass(frozen=True)
class BtpRecord:
    """One backtracking point: where, who found it, when, and who covered it."""

    cell: Cell
    detected_by: int
    detected_at: int
    covered_by: int | None = None
    covered_at: int | None = None


class BtpLog:
    """The BTP records of a run, kept from the planner's events as they come."""

    def __init__(self) -> None:
        self._records: dict[Cell, BtpRecord] = {}

    def note(self, event: PlannerEvent, at: int) -> None:
        """Take a planner event; ``at`` is when (an iteration, or an arrival count)."""
        if event.cell is None:
            return
        if event.kind == EventKind.BTP_DETECTED and event.cell not in self._records:
            self._records[event.cell] = BtpRecord(event.cell, event.agent, at)
        elif event.kind == EventKind.BTP_COVERED and event.cell in self._records:
            self._records[event.cell] = replace(
                self._records[event.cell], covered_by=event.agent, covered_at=at
            )

    def records(self) -> tuple[BtpRecord, ...]:
        return tuple(self._records.values())


@dataclass(frozen=True)
class AgentTrace:
    """One agent's run. ``track[k]`` and ``battery_pct[k]`` are its cell and
    battery after iteration ``k`` (index 0 is the start)."""

    id: int
    track: tuple[Cell, ...]
    battery_pct: tuple[float, ...]
    path_m: float
    homing_m: float
    charges: int
    min_battery_pct: float
    lost: bool = False


@dataclass(frozen=True)
class RunResult:
    """Everything a run reports. Map arrays are the planner's final belief
    (``belief`` holds ``CellState`` values), never the ground truth."""

    mission: str
    shape: tuple[int, int]
    cell_size_m: float
    charger: Cell
    reserve_pct: float
    belief: np.ndarray
    covered: np.ndarray
    agents: tuple[AgentTrace, ...]
    btps: tuple[BtpRecord, ...]
    covered_per_iteration: tuple[int, ...]
    iterations: int
    free_cells: int
    covered_cells: int
    out_of_range_cells: int
    safety_net_fires: int
    wall_s: float
    planner_s: float
    extra: dict[str, float | int | str] = field(default_factory=dict)

    @property
    def interrupted(self) -> bool:
        """Rebuilt from a log that ends (or is damaged) before the run's result."""
        return bool(self.extra.get("log_truncated"))

    @property
    def complete(self) -> bool:
        """Every free cell covered and nobody lost, as the run's own result says: a log
        without its result proves neither."""
        return (
            self.covered_cells >= self.free_cells and not self.lost_agents and not self.interrupted
        )

    @property
    def coverage_pct(self) -> float:
        return 100.0 * self.covered_cells / self.free_cells if self.free_cells else 100.0

    @property
    def total_path_m(self) -> float:
        return sum(a.path_m for a in self.agents)

    @property
    def makespan_m(self) -> float:
        """The longest agent coverage path: the mission's length in metres driven."""
        return max((a.path_m for a in self.agents), default=0.0)

    @property
    def lost_agents(self) -> int:
        return sum(1 for a in self.agents if a.lost)
