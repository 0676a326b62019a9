"""Offline simulation: the planner against the ground-truth world, in lockstep iterations.

An iteration gives every agent one decision (at most one move each), as the
paper counts them. With ``SimOptions.timed`` an iteration is instead a tick of
mission time: each vehicle decides once per cell at its own speed and charges
at its own rate, as the live fleet does, so the plan predicts a live run.
The planner only ever sees what the world's sensing answers at the cells its
agents stand on; the truth stays in ``sitl_mock``.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from gcs.mission import Mission
from gcs.mission_log import MissionLog
from gcs.result import AgentTrace, BtpLog, RunResult
from planner.agent import ActionKind, AgentMode, EventKind, PlannerEvent
from planner.coordinator import Coordinator
from planner.grid import Cell, CellState
from planner.settings import AgentSpec, PathPlannerKind, PlannerSettings
from sitl_mock.lockstep import Body, LockstepWorld

Progress = Callable[[int, int, int], None]
"""Called after each iteration with (iteration, covered cells, free cells)."""

#: Planner events an operator sees in the log's timeline.
LOGGED_EVENTS = frozenset(
    {
        EventKind.RETURN,
        EventKind.CHARGED,
        EventKind.SAFETY_NET,
        EventKind.COVERAGE_COMPLETE,
        EventKind.CUT_OFF,
        EventKind.LOST,
    }
)
#: Events after which the BTP stacks may have changed.
BTP_EVENTS = frozenset({EventKind.BTP_DETECTED, EventKind.BTP_COVERED, EventKind.TARGET})
#: Iterations between two map snapshots in the log.
LOG_MAP_EVERY = 25


@dataclass(frozen=True)
class SimOptions:
    seed: int = 0
    max_iterations: int | None = None
    #: Planner settings to use instead of the ones the mission gives.
    settings: PlannerSettings | None = None
    #: Model each vehicle's speed and charge rate in mission seconds (see the module doc).
    timed: bool = False


@dataclass(frozen=True)
class Pace:
    """How often the agents act: every ``step[i]`` mission seconds, in ticks of ``tick_s``."""

    tick_s: float
    step: dict[int, float]
    bodies: list[Body]

    @classmethod
    def of(cls, mission: Mission, timed: bool) -> Pace:
        if not timed:
            bodies = [Body(v.sysid, v.energy_per_m_pct) for v in mission.fleet]
            return cls(1.0, {v.sysid: 1.0 for v in mission.fleet}, bodies)
        step = {v.sysid: mission.cell_size_m / v.speed_m_s for v in mission.fleet}
        tick = min(step.values())
        bodies = [
            Body(v.sysid, v.energy_per_m_pct, v.charge_rate_pct_s * tick) for v in mission.fleet
        ]
        return cls(tick, step, bodies)


def planner_settings(mission: Mission, seed: int = 0, **strategy: object) -> PlannerSettings:
    """The planner settings a mission asks for; ``strategy`` overrides the rest."""
    spec = mission.planner
    settings: dict[str, object] = {
        "cell_size_m": mission.cell_size_m,
        "reserve_pct": spec.reserve_pct,
        "charge_pct_per_step": spec.charge_pct_per_step,
        "charging_slots": spec.charging_slots,
        "path_planner": PathPlannerKind(spec.path_planner),
        "far_transit_recheck": spec.far_transit_recheck or 0,
        "charge_at_end": spec.charge_at_end,
        "seed": seed,
    }
    if spec.top_up_ratio is not None:  # null: the planner's default
        settings["top_up_ratio"] = spec.top_up_ratio
    return PlannerSettings(**(settings | strategy))  # type: ignore[arg-type]


def prior_map(mission: Mission) -> np.ndarray | None:
    """The known map handed to the planner when the fleet takes the map as known."""
    if not mission.fleet or any(v.sensing != "map" for v in mission.fleet):
        return None
    obstacle = mission.map.obstacle
    return (obstacle * int(CellState.OBSTACLE) + (~obstacle) * int(CellState.FREE)).astype("int8")


def simulate(
    mission: Mission,
    options: SimOptions | None = None,
    progress: Progress | None = None,
    events: list[tuple[int, PlannerEvent]] | None = None,
    log: MissionLog | None = None,
) -> RunResult:
    """Run the mission's fleet over its map until coverage is complete and all are home.

    ``events``, if given, receives every planner event with its iteration.
    ``log``, if given, records the run (mission time = iteration) and is closed at the end.
    """
    options = options or SimOptions()
    grid = mission.map
    if grid.pads[:1] != (mission.charger,):
        grid = replace(grid, pads=(mission.charger,))
    ids = [v.sysid for v in mission.fleet]
    pace = Pace.of(mission, options.timed)
    world = LockstepWorld(
        grid,
        pace.bodies,
        cell_size_m=mission.cell_size_m,
        charge_pct_per_step=mission.planner.charge_pct_per_step,
        charging_slots=mission.planner.charging_slots,
    )
    reachable = grid.reachable()
    free_cells = int(reachable.sum())
    limit = options.max_iterations or mission.planner.max_iterations or 40 * free_cells + 1000
    if options.timed and not options.max_iterations:
        limit = round(limit * max(pace.step.values()) / pace.tick_s)
    ready_at = dict.fromkeys(ids, 0.0)

    t0 = time.perf_counter()
    planner_s = 0.0
    tick = time.perf_counter()
    coordinator = Coordinator(
        grid.shape,
        grid.charger,
        [AgentSpec(v.sysid, v.energy_per_m_pct) for v in mission.fleet],
        options.settings or planner_settings(mission, options.seed),
        prior=prior_map(mission),
    )
    for i in ids:
        coordinator.observe(i, grid.charger, world.sense(grid.charger), world.battery[i])
    planner_s += time.perf_counter() - tick

    tracks: dict[int, list[Cell]] = {i: [grid.charger] for i in ids}
    batteries: dict[int, list[float]] = {i: [100.0] for i in ids}
    path_moves = dict.fromkeys(ids, 0)
    homing_moves = dict.fromkeys(ids, 0)
    covered_series = [coordinator.belief.covered_count]
    btps = BtpLog()
    coverage_iterations: int | None = None

    def log_state(iteration: int) -> None:
        assert log is not None
        for i in ids:
            mode = coordinator.mode(i)
            log.agent_state(iteration, i, world.position[i], world.battery[i], mode.value)

    def record(iteration: int) -> None:
        btps_changed = False
        for event in coordinator.drain_events():
            if events is not None:
                events.append((iteration, event))
            if log is not None:
                btps_changed = btps_changed or event.kind in BTP_EVENTS
                if event.kind in LOGGED_EVENTS:
                    where = f" at {event.cell}" if event.cell is not None else ""
                    text = f"{event.kind.value}: vehicle {event.agent}{where}"
                    level = "error" if event.kind == EventKind.LOST else "info"
                    log.event(iteration, text, level, event.agent)
            btps.note(event, iteration)
        if btps_changed:
            assert log is not None
            log.btps(iteration, coordinator.btps())

    record(0)
    iteration = 0
    # Looked up once: in Python 3.11 each look-up of an enum member on its class
    # costs about 80 ns, and the loop below makes three per agent-step.
    move, charge, homing_mode = ActionKind.MOVE, ActionKind.CHARGE, AgentMode.HOMING
    if log is not None:
        log_state(0)
        log.coverage(0, coordinator.belief.state_grid(), coordinator.belief.covered_grid())
    while iteration < limit and not coordinator.finished:
        iteration += 1
        now = (iteration - 1) * pace.tick_s
        for i in ids:
            if i in world.dead or ready_at[i] > now + 1e-9:
                continue
            tick = time.perf_counter()
            homing = coordinator.mode(i) == homing_mode or coordinator.homeward
            action = coordinator.decide(i)
            planner_s += time.perf_counter() - tick
            if action.kind == move:
                assert action.to is not None
                world.move(i, action.to)
                if homing:
                    homing_moves[i] += 1
                else:
                    path_moves[i] += 1
                tick = time.perf_counter()
                if i in world.dead:
                    coordinator.mark_lost(i)
                else:
                    coordinator.observe(i, action.to, world.sense(action.to), world.battery[i])
                planner_s += time.perf_counter() - tick
            if action.kind == charge:
                world.request_charge(i)
                ready_at[i] = now + pace.tick_s
            else:
                ready_at[i] = max(ready_at[i] + pace.step[i], now + pace.tick_s)
        world.end_iteration()
        tick = time.perf_counter()
        for i in ids:
            if i not in world.dead:
                coordinator.update_battery(i, world.battery[i])
        planner_s += time.perf_counter() - tick
        for i in ids:
            tracks[i].append(world.position[i])
            batteries[i].append(world.battery[i])
        covered_series.append(coordinator.belief.covered_count)
        # Ask before recording: the first time it holds, the planner emits the
        # coverage-complete event, which belongs to this iteration.
        if coverage_iterations is None and coordinator.coverage_complete:
            coverage_iterations = iteration
        record(iteration)
        if log is not None:
            log_state(iteration)
            if iteration % LOG_MAP_EVERY == 0:
                belief = coordinator.belief
                log.coverage(iteration, belief.state_grid(), belief.covered_grid())
        if progress is not None:
            progress(iteration, coordinator.belief.covered_count, free_cells)

    cell_m = mission.cell_size_m
    agents = tuple(
        AgentTrace(
            id=i,
            track=tuple(tracks[i]),
            battery_pct=tuple(batteries[i]),
            path_m=path_moves[i] * cell_m,
            homing_m=homing_moves[i] * cell_m,
            charges=coordinator.charges(i),
            min_battery_pct=min(batteries[i]),
            lost=i in world.dead or coordinator.mode(i) == AgentMode.LOST,
        )
        for i in ids
    )
    covered = coordinator.belief.covered_grid()
    result = RunResult(
        mission=mission.name,
        shape=grid.shape,
        cell_size_m=cell_m,
        charger=grid.charger,
        reserve_pct=mission.planner.reserve_pct,
        belief=coordinator.belief.state_grid(),
        covered=covered,
        agents=agents,
        btps=btps.records(),
        covered_per_iteration=tuple(covered_series),
        iterations=coverage_iterations if coverage_iterations is not None else iteration,
        free_cells=free_cells,
        covered_cells=int((covered & reachable).sum()),
        out_of_range_cells=len(coordinator.out_of_range_cells()),
        safety_net_fires=coordinator.safety_net_fires,
        wall_s=time.perf_counter() - t0,
        planner_s=planner_s,
        extra={
            "btps_detected": coordinator.btps_detected,
            "cut_off_cells": coordinator.cut_off_cells,
            "total_iterations": iteration,
            **(
                {
                    "mission_s": round(iteration * pace.tick_s, 3),
                    "coverage_s": round((coverage_iterations or iteration) * pace.tick_s, 3),
                }
                if options.timed
                else {}
            ),
        },
    )
    if log is not None:
        log.coverage(iteration, result.belief, covered)
        log.result(iteration, result)
        log.close()
    return result
