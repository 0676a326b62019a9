"""What a live mission did, kept as it happens and turned into a ``RunResult`` at the end.

A live mission has no iterations: each vehicle moves at its own pace. A
vehicle's track and battery series get one entry per arrival (and per
charge), and "iterations" are arrivals: the fleet's arrival count orders the
coverage series and the BTP records, and ``iterations`` is the number of
moves of the busiest vehicle until coverage was complete (what a lockstep
run would count). Mission times are in ``extra``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from core.cells import Cell, manhattan
from gcs.outcome.result import AgentTrace, BtpLog, RunResult
from planner.agent import EventKind, PlannerEvent
from planner.coordinator import Coordinator


@dataclass
class AgentLog:
    track: list[Cell]
    battery_pct: list[float]
    moves: int = 0
    path_moves: int = 0
    homing_moves: int = 0
    odometer_m: float = 0.0
    lost: bool = False
    #: Set when the current move was decided while homing (coverage complete).
    homing: bool = False
    moves_at_coverage: int | None = None


@dataclass
class MissionRecord:
    mission: str
    shape: tuple[int, int]
    cell_size_m: float
    charger: Cell
    reserve_pct: float
    free_cells: int
    reachable: np.ndarray
    agents: dict[int, AgentLog] = field(default_factory=dict)
    covered_series: list[int] = field(default_factory=list)
    btps: BtpLog = field(default_factory=BtpLog)
    arrivals: int = 0
    coverage_arrivals: int | None = None
    coverage_s: float | None = None
    #: A resumed mission: the cells its log recorded as covered, and those of them this
    #: run covered again (not those it only went over on its way back to work).
    covered_before: np.ndarray | None = None
    swept_again: set[Cell] = field(default_factory=set)
    #: Cells the planner had covered before the first arrival (restored from a log).
    covered_at_start: int = 0

    def add_agent(self, agent: int, battery_pct: float, cell: Cell | None = None) -> None:
        """An agent starting on ``cell`` (the charger unless a mission is resumed)."""
        start = self.charger if cell is None else cell
        self.agents[agent] = AgentLog(track=[start], battery_pct=[battery_pct])

    def arrived(self, agent: int, cell: Cell, battery_pct: float, covered: int) -> None:
        before = self.covered_series[-1] if self.covered_series else self.covered_at_start
        newly = covered > before
        if newly and self.covered_before is not None and self.covered_before[cell]:
            self.swept_again.add(cell)
        log = self.agents[agent]
        moves = manhattan(log.track[-1], cell)
        log.moves += moves
        if log.homing:
            log.homing_moves += moves
        else:
            log.path_moves += moves
        log.track.append(cell)
        log.battery_pct.append(battery_pct)
        self.arrivals += 1
        self.covered_series.append(covered)

    def battery(self, agent: int, cell: Cell, battery_pct: float) -> None:
        """A battery sample without a move (on the charger)."""
        log = self.agents[agent]
        log.track.append(cell)
        log.battery_pct.append(battery_pct)

    def planner_events(self, events: list[PlannerEvent], t_s: float) -> None:
        for event in events:
            self.btps.note(event, self.arrivals)
            if event.kind == EventKind.COVERAGE_COMPLETE and self.coverage_arrivals is None:
                self.coverage_arrivals = self.arrivals
                self.coverage_s = t_s
                for log in self.agents.values():
                    log.moves_at_coverage = log.moves

    def result(
        self,
        coordinator: Coordinator,
        wall_s: float,
        planner_s: float,
        mission_s: float,
        extra: dict[str, float | int | str] | None = None,
    ) -> RunResult:
        covered = coordinator.belief.covered_grid()
        agents = tuple(
            AgentTrace(
                id=i,
                track=tuple(log.track),
                battery_pct=tuple(log.battery_pct),
                path_m=log.path_moves * self.cell_size_m,
                homing_m=log.homing_moves * self.cell_size_m,
                charges=coordinator.charges(i),
                min_battery_pct=min(log.battery_pct),
                lost=log.lost,
            )
            for i, log in self.agents.items()
        )
        iterations = max(
            (
                log.moves_at_coverage if log.moves_at_coverage is not None else log.moves
                for log in self.agents.values()
            ),
            default=0,
        )
        return RunResult(
            mission=self.mission,
            shape=self.shape,
            cell_size_m=self.cell_size_m,
            charger=self.charger,
            reserve_pct=self.reserve_pct,
            belief=coordinator.belief.state_grid(),
            covered=covered,
            agents=agents,
            btps=self.btps.records(),
            covered_per_iteration=tuple(self.covered_series),
            iterations=iterations,
            free_cells=self.free_cells,
            covered_cells=int((covered & self.reachable).sum()),
            out_of_range_cells=len(coordinator.out_of_range_cells()),
            safety_net_fires=coordinator.safety_net_fires,
            wall_s=wall_s,
            planner_s=planner_s,
            extra={
                "live": 1,
                "mission_s": round(mission_s, 2),
                "coverage_s": round(self.coverage_s, 2) if self.coverage_s is not None else -1,
                "arrivals": self.arrivals,
                "btps_detected": coordinator.btps_detected,
                "cut_off_cells": coordinator.cut_off_cells,
                **{f"odometer_m_{i}": round(log.odometer_m, 2) for i, log in self.agents.items()},
                **(extra or {}),
            },
        )
