"""Invariant checks on a finished offline run, shared by every planner strategy.

They read the run's tracks and batteries (what the world did) against the
ground truth, not the planner's own account of itself.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from core.cells import Cell, manhattan
from gcs.log.mcap_log import LogSettings, LogSink, McapMissionLog
from gcs.mission import (
    Mission,
    Origin,
    PlannerSpec,
    Sensing,
    VehicleSpec,
    VehicleType,
    default_connection,
)
from gcs.outcome.result import RunResult
from gcs.preflight import charger_distances
from planner.agent import EventKind, PlannerEvent
from sitl_mock.gridmap import GridMap


def first_visits(result: RunResult) -> dict[Cell, int]:
    """Iteration at which each cell was first stood on."""
    seen: dict[Cell, int] = {}
    steps = len(result.agents[0].track)
    for k in range(steps):
        for agent in result.agents:
            seen.setdefault(agent.track[k], k)
    return seen


def check_run(
    result: RunResult,
    truth: GridMap,
    events: Sequence[tuple[int, PlannerEvent]] = (),
    *,
    expect_complete: bool = True,
) -> None:
    charger = truth.charger
    if expect_complete:
        assert result.complete, f"coverage {result.coverage_pct:.1f} %, lost {result.lost_agents}"
        assert result.covered_cells == result.free_cells
    steps = len(result.agents[0].track)
    for agent in result.agents:
        assert len(agent.track) == steps == len(agent.battery_pct)
        assert not agent.lost
        for k in range(1, steps):
            a, b = agent.track[k - 1], agent.track[k]
            assert manhattan(a, b) <= 1, f"agent {agent.id} jumped {a} -> {b} at {k}"
            assert truth.is_free(b), f"agent {agent.id} entered obstacle {b} at {k}"
            if b == charger and a != charger:
                assert agent.battery_pct[k] >= result.reserve_pct - 1e-6, (
                    f"agent {agent.id} arrived at the charger with {agent.battery_pct[k]:.2f} %"
                )
        assert min(agent.battery_pct) > 0, f"agent {agent.id} ran flat"
    for k in range(steps):
        cells = [a.track[k] for a in result.agents if a.track[k] != charger]
        assert len(cells) == len(set(cells)), f"two agents share a cell at iteration {k}"
        if k == 0:
            continue
        for x in result.agents:
            for y in result.agents:
                if x.id < y.id and x.track[k] != x.track[k - 1]:
                    swapped = x.track[k] == y.track[k - 1] and y.track[k] == x.track[k - 1]
                    assert not swapped, f"agents {x.id} and {y.id} swapped at iteration {k}"
    visits = first_visits(result)
    for iteration, event in events:
        if event.kind in (EventKind.TARGET, EventKind.SAFETY_NET):
            assert event.cell is not None
            assert truth.is_free(event.cell), f"target {event.cell} is an obstacle"
            assert visits.get(event.cell, steps) >= iteration, (
                f"target {event.cell} taken at {iteration} was covered at {visits[event.cell]}"
            )


def make_mission(
    grid: GridMap,
    agents: int,
    energy_per_m_pct: float = 0.0,
    *,
    charge_pct_per_step: float | None = None,
    charging_slots: int | None = None,
    reserve_pct: float = 20.0,
    name: str = "test",
) -> Mission:
    """A mission over ``grid`` with ``agents`` identical rovers."""
    fleet = tuple(
        VehicleSpec(
            sysid=i + 1,
            type=VehicleType.ROVER,
            sensing=Sensing.RANGE,
            connection=default_connection(i + 1),
            energy_per_m_pct=energy_per_m_pct,
            battery_capacity_mah=5000.0,
            speed_m_s=2.0,
            charge_rate_pct_s=1.0,
        )
        for i in range(agents)
    )
    return Mission(
        name=name,
        source=Path(f"{name}.yaml"),
        map=grid,
        charger=grid.charger,
        cell_size_m=1.0,
        origin=Origin(),
        fleet=fleet,
        planner=PlannerSpec(
            reserve_pct=reserve_pct,
            charge_pct_per_step=charge_pct_per_step,
            charging_slots=charging_slots,
        ),
    )


def energy_for_round_trips(grid: GridMap, trips: float, reserve_pct: float = 20.0) -> float:
    """An energy per metre with which the usable battery (above the reserve) makes
    ``trips`` round trips to the farthest cell (1.0: just one)."""
    far = int(charger_distances(make_mission(grid, 1)).max())
    return (100.0 - reserve_pct) / (2 * far * trips) if far else 1.0


def open_mission_log(
    path: Path,
    mission: Mission,
    started_unix_s: float | None = None,
    sinks: Sequence[LogSink] = (),
    **settings: Any,
) -> McapMissionLog:
    """A mission log of ``mission`` at ``path`` (``settings``: the log's own, ``LogSettings``)."""
    return McapMissionLog.for_mission(
        mission,
        path,
        settings=LogSettings(**settings),
        sinks=sinks,
        started_unix_s=started_unix_s,
    )
