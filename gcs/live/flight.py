"""The live mission's flight, once every vehicle is ready: the planner with one agent
per vehicle (each with its own energy estimate), every agent task at once until the
fleet is home, the time limit or an abort (then the planner brings every vehicle home,
and one not home in time is sent on its own or held), and the ``RunResult``."""

from __future__ import annotations

import asyncio
import time
from dataclasses import dataclass, field

from gcs.live.agent import Agent, announce, send_home
from gcs.live.energy import EnergyEstimator, model_prior
from gcs.live.pilot import Pilot
from gcs.live.record import MissionRecord
from gcs.live.resume import ResumePoint, resumed_text
from gcs.live.run import LiveOptions, LiveRun
from gcs.live.shared import Level, Notify, Phase, SharedPlanner
from gcs.live.status import StatusWatch
from gcs.log.mission_log import MissionLog, NullLog
from gcs.mission import Mission
from gcs.outcome.result import RunResult
from gcs.percentile import percentile
from gcs.planning import planner_settings, prior_map
from planner.coordinator import Coordinator
from planner.settings import AgentSpec
from vehicles.link import VehicleLink
from vehicles.modes import VehicleKind

#: Real seconds between two looks at how late the event loop runs.
LOOP_PROBE_S = 0.05


async def _probe_loop_lag(samples: list[float]) -> None:
    """Sample how late the event loop wakes a timer: the ground station falls
    behind its vehicles when this grows."""
    loop = asyncio.get_running_loop()
    while True:
        due = loop.time() + LOOP_PROBE_S
        await asyncio.sleep(LOOP_PROBE_S)
        samples.append(max(0.0, loop.time() - due))


def _percentile_ms(values_s: list[float], q: float) -> float:
    """Percentile ``q`` (0-100) in milliseconds; 0 when nothing was measured."""
    return round(1000.0 * percentile(values_s, q), 3) if values_s else 0.0


def load_figures(
    latency_s: list[float], messages: int, cpu_s: float, wall_s: float, loop_lag_s: list[float]
) -> dict[str, float]:
    """How hard the ground station worked: decision latency percentiles (ms), event
    loop lateness, messages read per second, and CPU seconds (this process, the mock
    fleet included with --sim) per wall second."""
    return {
        "decisions_timed": len(latency_s),
        "decision_latency_ms_p50": _percentile_ms(latency_s, 50),
        "decision_latency_ms_p99": _percentile_ms(latency_s, 99),
        "decision_latency_ms_max": _percentile_ms(latency_s, 100),
        "loop_lag_ms_p99": _percentile_ms(loop_lag_s, 99),
        "messages_in_per_s": round(messages / wall_s, 1) if wall_s > 0 else 0.0,
        "cpu_s_per_s": round(cpu_s / wall_s, 3) if wall_s > 0 else 0.0,
    }


@dataclass
class _LoadMeter:
    """How hard the station works from the start of the flight: wall and CPU time,
    messages read, and the event loop's lateness sampled all along."""

    links: dict[int, VehicleLink]
    wall0: float = field(default_factory=time.perf_counter)
    cpu0: float = field(default_factory=time.process_time)
    messages0: int = 0
    loop_lag_s: list[float] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.messages0 = self._messages()
        self.probe = asyncio.ensure_future(_probe_loop_lag(self.loop_lag_s))

    def _messages(self) -> int:
        return sum(link.messages_in for link in self.links.values())

    def wall_s(self) -> float:
        return time.perf_counter() - self.wall0

    def figures(self, latency_s: list[float]) -> dict[str, float]:
        return load_figures(
            latency_s,
            self._messages() - self.messages0,
            time.process_time() - self.cpu0,
            self.wall_s(),
            self.loop_lag_s,
        )


def _planner(
    mission: Mission, options: LiveOptions, estimators: dict[int, EnergyEstimator]
) -> tuple[Coordinator, int]:
    """The planner with one agent per vehicle, carried on from the resumed log if any;
    returns it with the cells the log had covered."""
    coordinator = Coordinator(
        mission.map.shape,
        mission.charger,
        [AgentSpec(v.sysid, estimators[v.sysid].estimate_pct_per_m) for v in mission.fleet],
        planner_settings(mission, options.seed),
        prior=prior_map(mission),
    )
    resume = options.resume
    if resume is None:
        return coordinator, 0
    coordinator.restore(resume.known, resume.covered, resume.btps)
    return coordinator, coordinator.belief.covered_count


def _record(
    mission: Mission,
    resume: ResumePoint | None,
    restored: int,
    links: dict[int, VehicleLink],
    pilots: dict[int, Pilot],
) -> MissionRecord:
    """What the flight will report, each vehicle starting where its telemetry puts it."""
    reachable = mission.map.reachable(mission.charger)
    record = MissionRecord(
        mission=mission.name,
        shape=mission.map.shape,
        cell_size_m=mission.cell_size_m,
        charger=mission.charger,
        reserve_pct=mission.planner.reserve_pct,
        free_cells=int(reachable.sum()),
        reachable=reachable,
        covered_before=None if resume is None else resume.covered,
        covered_at_start=restored,
    )
    for v in mission.fleet:
        position = links[v.sysid].telemetry.position
        record.add_agent(
            v.sysid,
            links[v.sysid].telemetry.battery.remaining_pct or 100.0,
            mission.charger if position is None else pilots[v.sysid].cell_of(position),
        )
    return record


async def fly(
    mission: Mission,
    options: LiveOptions,
    run: LiveRun,
    pilots: dict[int, Pilot],
    mission_log: MissionLog,
    notify: Notify,
    abort: asyncio.Event,
    t0: float,
) -> RunResult:
    """Fly the ready fleet (``run.links``) to the mission's end and report it; ``t0``
    is the log's time zero."""
    links = run.links
    meter = _LoadMeter(links)
    estimators = {
        v.sysid: EnergyEstimator(model_prior(VehicleKind(v.type.value)), options.energy)
        for v in mission.fleet
    }
    coordinator, restored = _planner(mission, options, estimators)
    record = _record(mission, options.resume, restored, links, pilots)
    planner = SharedPlanner(coordinator, record, run.clock, mission_log, notify, run.views)
    planner.t0 = t0
    run.planner = planner
    run.started_at = run.clock.now()
    watch = StatusWatch(run)
    statuses = asyncio.ensure_future(
        asyncio.sleep(0) if isinstance(mission_log, NullLog) else watch.keep_writing(mission_log)
    )
    agents = _agents(run, pilots, planner, estimators, options)
    # Every event from here is shown and logged by ``announce``: the two never differ.
    count = f"{len(agents)} vehicle{'' if len(agents) == 1 else 's'}"
    announce(planner, f"mission {mission.name} starts with {count}")
    if options.resume is not None:
        announce(planner, resumed_text(options.resume, restored))
    interrupted, late = await _run_agents(agents, run, options, abort, meter)
    await _send_late_home([a for a in late if not record.agents[a.id].lost], run, options)
    meter.probe.cancel()
    statuses.cancel()
    await asyncio.gather(meter.probe, statuses, return_exceptions=True)
    await watch.write(mission_log)
    planner.write_coverage()
    result = record.result(
        coordinator,
        wall_s=meter.wall_s(),
        planner_s=planner.planner_s,
        mission_s=planner.t_s,
        extra=_extra(run, options, interrupted, restored, len(record.swept_again), meter),
    )
    mission_log.result(planner.t_s, result)
    return result


def _agents(
    run: LiveRun,
    pilots: dict[int, Pilot],
    planner: SharedPlanner,
    estimators: dict[int, EnergyEstimator],
    options: LiveOptions,
) -> dict[int, Agent]:
    """One agent per vehicle, each with its link, pilot, energy estimate and view."""
    return {
        v.sysid: Agent(
            v,
            run.links[v.sysid],
            pilots[v.sysid],
            planner,
            estimators[v.sysid],
            run.views[v.sysid],
            run.mission.map,
            options.agent,
        )
        for v in run.mission.fleet
    }


async def _run_agents(
    agents: dict[int, Agent],
    run: LiveRun,
    options: LiveOptions,
    abort: asyncio.Event,
    meter: _LoadMeter,
) -> tuple[bool, list[Agent]]:
    """Every agent task at once until all are done, the time limit or an abort; then
    the planner recalls the fleet for ``abort_return_s``. Returns whether the mission
    was cut short, and the agents still out when their tasks were stopped."""
    tasks = {sysid: asyncio.ensure_future(agent.run()) for sysid, agent in agents.items()}
    stop = asyncio.ensure_future(abort.wait())
    limit = None if options.time_limit_s is None else run.clock.to_real(options.time_limit_s)
    interrupted = False
    try:
        done, _ = await asyncio.wait(
            [*tasks.values(), stop], timeout=limit, return_when=asyncio.FIRST_COMPLETED
        )
        while stop not in done and not all(t.done() for t in tasks.values()):
            remaining = None if limit is None else limit - meter.wall_s()
            if remaining is not None and remaining <= 0:
                break
            done, _ = await asyncio.wait(
                [*(t for t in tasks.values() if not t.done()), stop],
                timeout=remaining,
                return_when=asyncio.FIRST_COMPLETED,
            )
        interrupted = not all(t.done() for t in tasks.values())
        if interrupted:
            await _recall(tasks, run, options, abort)
    finally:
        late = [agents[sysid] for sysid, task in tasks.items() if not task.done()]
        for task in (*tasks.values(), stop):
            task.cancel()
        await asyncio.gather(*tasks.values(), stop, return_exceptions=True)
    return interrupted, late


async def _recall(
    tasks: dict[int, asyncio.Task[None]],
    run: LiveRun,
    options: LiveOptions,
    abort: asyncio.Event,
) -> None:
    """Home under the planner, which keeps the vehicles out of each other's way, as at
    the end of a mission; whoever is not home in time is sent directly."""
    assert run.planner is not None
    run.aborted = True
    why = (
        "aborted by the operator"
        if abort.is_set()
        else f"time limit reached ({options.time_limit_s:g} s after the start)"
    )
    announce(run.planner, f"mission {why}: every vehicle goes home", Level.WARNING)
    await run.planner.recall()
    await asyncio.wait(
        [t for t in tasks.values() if not t.done()],
        timeout=run.clock.to_real(options.abort_return_s),
    )


async def _send_late_home(going: list[Agent], run: LiveRun, options: LiveOptions) -> None:
    """Each vehicle still out after the recall sent to charge on its own, or held."""
    if not going:
        return
    planner = run.planner
    assert planner is not None
    announce(
        planner,
        f"{len(going)} vehicle(s) not home {options.abort_return_s:g} s after the abort: "
        "each is sent to charge on its own, or held",
        Level.WARNING,
    )
    outcomes = await asyncio.gather(
        *(send_home(agent, options.abort_return_s) for agent in going),
        return_exceptions=True,
    )
    for agent, outcome in zip(going, outcomes, strict=True):
        run.views[agent.id].phase = Phase.ABORTED
        announce(planner, f"vehicle {agent.id}: {outcome}", Level.INFO, agent.id)


def _extra(
    run: LiveRun,
    options: LiveOptions,
    interrupted: bool,
    restored: int,
    swept_again: int,
    meter: _LoadMeter,
) -> dict[str, float | int | str]:
    """The live run's figures beyond the plan's: abort, resume, links and load."""
    planner, resume = run.planner, options.resume
    assert planner is not None
    resumed: dict[str, float | int | str] = (
        {}
        if resume is None
        else {
            "resumed_logged_cells": resume.covered_cells,
            "resumed_covered_cells": restored,
            "resumed_swept_again_cells": swept_again,
            "resumed_at_s": resume.last_t_s,
        }
    )
    return {
        "aborted": int(interrupted),
        **resumed,
        "speedup": options.speedup,
        "moves_held_back": planner.held_back,
        "waits": planner.waits,
        **run.rejected.report_fields(),
        "forward_refused": 0 if run.network is None else run.network.forward_refused,
        **meter.figures(planner.decision_latency_s),
    }
