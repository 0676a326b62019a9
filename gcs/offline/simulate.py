"""Offline simulation: the planner against the ground-truth world, in lockstep iterations.

An iteration gives every agent one decision (at most one move each). The run
also counts iterations the other way the paper may count them
(``PathSteps``): a sweep step is one, and so is a whole planned path to a
target or to the charger. With ``SimOptions.timed`` an iteration is instead a tick of
mission time: each vehicle decides once per cell at its own speed and charges
at its own rate, as the live fleet does, so the plan predicts a live run.
The planner only ever sees what the world's sensing answers at the cells its
agents stand on; the truth stays in ``sitl_mock``.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, replace

from core.cells import Cell
from gcs.log.mission_log import FleetStep, MissionLog
from gcs.mission import Mission
from gcs.outcome.result import AgentTrace, BtpLog, RunResult
from gcs.planning import planner_settings, prior_map
from planner.agent import Action, ActionKind, AgentMode, EventKind, PlannerEvent
from planner.coordinator import Coordinator
from planner.settings import AgentSpec, PlannerSettings
from planner.speed.compiled_search import warm_up
from planner.turns import acting
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
#: Iterations between two map (and BTP) snapshots in the log: at least ``LOG_MAP_EVERY``, and
#: later in a long run ``LOG_MAP_SHARE`` of the iterations so far (each snapshot is the
#: whole map: a million cells on the largest maps, so their count must grow with the
#: logarithm of the run's length, not with the length itself).
LOG_MAP_EVERY = 25
LOG_MAP_SHARE = 0.05


class PathSteps:
    """Each agent's moves with every planned path counted once: a move counts unless
    it goes on along the path of the agent's previous move (the same target, or the
    charger). The run's count is the busiest agent's, until coverage is complete."""

    def __init__(self, ids: list[int]) -> None:
        self.steps = dict.fromkeys(ids, 0)
        self._going_to: dict[int, Cell | None] = dict.fromkeys(ids)
        self.at_coverage: int | None = None

    def moved(self, agent: int, going_to: Cell | None) -> None:
        """The agent moved; ``going_to``: the end of the path it moves along, if any."""
        if going_to is None or going_to != self._going_to[agent]:
            self.steps[agent] += 1
        self._going_to[agent] = going_to

    def coverage_complete(self) -> None:
        self.at_coverage = self.busiest

    @property
    def busiest(self) -> int:
        return max(self.steps.values(), default=0)


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
    The search's kernels are compiled (or loaded from numba's cache) first, outside the
    run's timings.
    """
    warm_up()
    run = _LockstepRun(mission, options or SimOptions(), events, log)
    iteration = run.fly(progress)
    result = run.result(iteration)
    if log is not None:
        run.log_end(iteration, result)
    return result


def _iteration_limit(mission: Mission, options: SimOptions, pace: Pace, free_cells: int) -> int:
    """The iterations (ticks, when timed) after which the run stops unfinished."""
    limit = options.max_iterations or mission.planner.max_iterations or 40 * free_cells + 1000
    if options.timed and not options.max_iterations:
        limit = round(limit * max(pace.step.values()) / pace.tick_s)
    return limit


class _LockstepRun:
    """One offline run: the truth, the planner, and what is kept of each iteration for
    the result (tracks, batteries, moves, coverage, BTPs) and the log."""

    def __init__(
        self,
        mission: Mission,
        options: SimOptions,
        events: list[tuple[int, PlannerEvent]] | None,
        log: MissionLog | None,
    ) -> None:
        self.mission, self.options, self.events, self.log = mission, options, events, log
        grid = mission.map
        if grid.pads[:1] != (mission.charger,):
            grid = replace(grid, pads=(mission.charger,))
        self.grid = grid
        self.ids = ids = [v.sysid for v in mission.fleet]
        #: The iteration of the log's next map snapshot, and whether the BTPs changed
        #: since the last one.
        self.next_map = LOG_MAP_EVERY
        self.btps_changed = False
        self.pace = Pace.of(mission, options.timed)
        self.world = LockstepWorld(
            grid,
            self.pace.bodies,
            cell_size_m=mission.cell_size_m,
            charge_pct_per_step=mission.planner.charge_pct_per_step,
            charging_slots=mission.planner.charging_slots,
        )
        self.reachable = grid.reachable()
        self.free_cells = int(self.reachable.sum())
        self.limit = _iteration_limit(mission, options, self.pace, self.free_cells)
        self.ready_at = dict.fromkeys(ids, 0.0)
        self.t0 = time.perf_counter()
        self.planner_s = 0.0
        self.coordinator = self._start_planner()
        assert list(self.world.position) == ids and list(self.world.battery) == ids
        self.cell_rows: list[tuple[Cell, ...]] = [(grid.charger,) * len(ids)]
        self.battery_rows: list[tuple[float, ...]] = [(100.0,) * len(ids)]
        self.lowest_battery = dict.fromkeys(ids, 100.0)
        self.path_moves = dict.fromkeys(ids, 0)
        self.homing_moves = dict.fromkeys(ids, 0)
        self.path_steps = PathSteps(ids)
        self.covered_series = [self.coordinator.belief.covered_count]
        self.btps = BtpLog()
        self.coverage_iterations: int | None = None

    def _start_planner(self) -> Coordinator:
        """The planner, with every agent's first readings on the charger."""
        mission, grid, world = self.mission, self.grid, self.world
        tick = time.perf_counter()
        coordinator = Coordinator(
            grid.shape,
            grid.charger,
            [AgentSpec(v.sysid, v.energy_per_m_pct) for v in mission.fleet],
            self.options.settings or planner_settings(mission, self.options.seed),
            prior=prior_map(mission),
        )
        for i in self.ids:
            coordinator.observe(i, grid.charger, world.sense(grid.charger), world.battery[i])
        self.planner_s += time.perf_counter() - tick
        return coordinator

    def fly(self, progress: Progress | None) -> int:
        """Iterate until the planner is finished or the limit; returns the last iteration."""
        coordinator, log = self.coordinator, self.log
        self._record(0)
        if log is not None:
            self._log_state(0)
            log.coverage(0, coordinator.belief.state_grid(), coordinator.belief.covered_grid())
        iteration = 0
        while iteration < self.limit and not coordinator.finished:
            iteration += 1
            self._act((iteration - 1) * self.pace.tick_s)
            self._end_iteration(iteration)
            if progress is not None:
                progress(iteration, coordinator.belief.covered_count, self.free_cells)
        return iteration

    def _act(self, now: float) -> None:
        """Every agent whose turn it is decides once, and the world carries it out.

        Most agent-steps of a crowd are waits, so the loop does as little as it can
        for one: in lockstep every agent's turn comes each iteration, and the
        planner decides the waits of a whole run of agents in one call; the clock
        is read around the world's work on a move, not around every decision, and
        the planner's time is the loop's less that."""
        world = self.world
        start = time.perf_counter()
        outside = 0.0
        if not self.options.timed:
            move = ActionKind.MOVE
            for i, action in acting(self.coordinator, self.ids, world.dead):
                if action.kind == move:
                    outside += self._move(i, action)
                else:
                    world.request_charge(i)
        else:
            outside = self._act_timed(now)
        self.planner_s += time.perf_counter() - start - outside

    def _act_timed(self, now: float) -> float:
        """``_act`` when each vehicle decides at its own pace: those whose turn it is.
        Returns the seconds spent in the world."""
        coordinator, world, ready_at, pace = self.coordinator, self.world, self.ready_at, self.pace
        decide, dead, step_s = coordinator.decide, world.dead, pace.step
        move, charge = ActionKind.MOVE, ActionKind.CHARGE
        due, next_tick = now + 1e-9, now + pace.tick_s
        outside = 0.0
        for i in self.ids:
            if ready_at[i] > due or i in dead:
                continue
            action = decide(i)
            kind = action.kind
            if kind == move:
                outside += self._move(i, action)
            elif kind == charge:
                world.request_charge(i)
                ready_at[i] = next_tick
                continue
            ready_at[i] = max(ready_at[i] + step_s[i], next_tick)
        return outside

    def _move(self, i: int, action: Action) -> float:
        """The world carries out agent ``i``'s move and the planner hears what it
        sensed; returns the seconds the world took (not the planner's)."""
        coordinator, world = self.coordinator, self.world
        to = action.to
        assert to is not None
        tick = time.perf_counter()
        world.move(i, to)
        # Homing: on the way home at the mission's end (a trip to charge is path).
        if coordinator.mode(i) == AgentMode.HOMING or coordinator.homeward:
            self.homing_moves[i] += 1
        else:
            self.path_moves[i] += 1
        self.path_steps.moved(i, coordinator.heading_for(i))
        dead = i in world.dead
        sensed = None if dead else world.sense(to)
        battery = world.battery[i]
        if battery < self.lowest_battery[i]:  # a battery falls only by a move
            self.lowest_battery[i] = battery
        outside = time.perf_counter() - tick
        if sensed is None:
            coordinator.mark_lost(i)
        else:
            coordinator.observe(i, to, sensed, battery)
        return outside

    def _end_iteration(self, iteration: int) -> None:
        """Batteries told to the planner; tracks, coverage, events and the log kept."""
        coordinator, world = self.coordinator, self.world
        battery = world.battery
        # A battery changes by a move, which the planner observed with it, or by a charge.
        charged = world.end_iteration()
        tick = time.perf_counter()
        for i in charged:
            coordinator.update_battery(i, battery[i])
        self.planner_s += time.perf_counter() - tick
        # Every agent's cell and battery, as a row per iteration (the world keeps them
        # in the order of ``ids``): turned into each agent's track at the end.
        self.cell_rows.append(tuple(world.position.values()))
        self.battery_rows.append(tuple(battery.values()))
        self.covered_series.append(coordinator.belief.covered_count)
        # Ask before recording: the first time it holds, the planner emits the
        # coverage-complete event, which belongs to this iteration.
        if self.coverage_iterations is None and coordinator.coverage_complete:
            self.coverage_iterations = iteration
            self.path_steps.coverage_complete()
        self._record(iteration)
        if self.log is not None:
            self._log_state(iteration)
            if iteration >= self.next_map:
                self.next_map = iteration + max(LOG_MAP_EVERY, int(LOG_MAP_SHARE * iteration))
                self._log_map(iteration)

    def log_end(self, iteration: int, result: RunResult) -> None:
        """The last map, BTPs and the result; the log closed."""
        assert self.log is not None
        self.log.coverage(iteration, result.belief, result.covered)
        if self.btps_changed:
            self.log.btps(iteration, self.coordinator.btps())
        self.log.result(iteration, result)
        self.log.close()

    def _log_map(self, iteration: int) -> None:
        """The map and, if they changed, the BTPs: snapshots, on the same schedule."""
        assert self.log is not None
        belief = self.coordinator.belief
        self.log.coverage(iteration, belief.state_grid(), belief.covered_grid())
        if self.btps_changed:
            self.btps_changed = False
            self.log.btps(iteration, self.coordinator.btps())

    def _log_state(self, iteration: int) -> None:
        assert self.log is not None
        ids, mode = self.ids, self.coordinator.mode
        step = FleetStep(
            sysids=ids,
            cells=self.cell_rows[-1],
            battery_pct=self.battery_rows[-1],
            modes=[mode(i).value for i in ids],
        )
        self.log.fleet_step(iteration, step)

    def _record(self, iteration: int) -> None:
        """The planner's events of this iteration: to ``events``, the log and the BTP log."""
        log = self.log
        for event in self.coordinator.drain_events():
            if self.events is not None:
                self.events.append((iteration, event))
            if log is not None:
                self.btps_changed = self.btps_changed or event.kind in BTP_EVENTS
                if event.kind in LOGGED_EVENTS:
                    where = f" at {event.cell}" if event.cell is not None else ""
                    text = f"{event.kind.value}: vehicle {event.agent}{where}"
                    level = "error" if event.kind == EventKind.LOST else "info"
                    log.event(iteration, text, level, event.agent)
            self.btps.note(event, iteration)

    def _agents(self) -> tuple[AgentTrace, ...]:
        cell_m, coordinator = self.mission.cell_size_m, self.coordinator
        tracks = zip(*self.cell_rows, strict=True)
        batteries = zip(*self.battery_rows, strict=True)
        return tuple(
            AgentTrace(
                id=i,
                track=track,
                battery_pct=battery,
                path_m=self.path_moves[i] * cell_m,
                homing_m=self.homing_moves[i] * cell_m,
                charges=coordinator.charges(i),
                min_battery_pct=self.lowest_battery[i],
                lost=i in self.world.dead or coordinator.mode(i) == AgentMode.LOST,
            )
            for i, track, battery in zip(self.ids, tracks, batteries, strict=True)
        )

    def _extra(self, iteration: int) -> dict[str, float | int | str]:
        coordinator, tick_s = self.coordinator, self.pace.tick_s
        extra: dict[str, float | int | str] = {
            "btps_detected": coordinator.btps_detected,
            "cut_off_cells": coordinator.cut_off_cells,
            "total_iterations": iteration,
        }
        if not self.options.timed:  # a count of steps, not of ticks
            steps = self.path_steps
            extra["path_iterations"] = (
                steps.at_coverage if steps.at_coverage is not None else steps.busiest
            )
        if self.options.timed:
            extra["mission_s"] = round(iteration * tick_s, 3)
            extra["coverage_s"] = round((self.coverage_iterations or iteration) * tick_s, 3)
        return extra

    def result(self, iteration: int) -> RunResult:
        mission, grid, coordinator = self.mission, self.grid, self.coordinator
        covered = coordinator.belief.covered_grid()
        return RunResult(
            mission=mission.name,
            shape=grid.shape,
            cell_size_m=mission.cell_size_m,
            charger=grid.charger,
            reserve_pct=mission.planner.reserve_pct,
            belief=coordinator.belief.state_grid(),
            covered=covered,
            agents=self._agents(),
            btps=self.btps.records(),
            covered_per_iteration=tuple(self.covered_series),
            iterations=(
                self.coverage_iterations if self.coverage_iterations is not None else iteration
            ),
            free_cells=self.free_cells,
            covered_cells=int((covered & self.reachable).sum()),
            out_of_range_cells=len(coordinator.out_of_range_cells()),
            safety_net_fires=coordinator.safety_net_fires,
            wall_s=time.perf_counter() - self.t0,
            planner_s=self.planner_s,
            extra=self._extra(iteration),
        )
