"""The live mission: connect to the fleet, check it, run one task per vehicle, report.

With ``sim`` (a rehearsal) the simulated fleet the caller built, with its faults
(``gcs.mock_fleet``), is started in this process, on loopback, on the mirror side
of every vehicle's connection, with the same clock: everything else is exactly
what a real mission does, over real MAVLink on UDP or TCP.

Order of events:

0. compile the planner (``gcs.warm_up``; loaded from numba's cache after the
   first run) before any link opens, so that no first decision stalls a link;
1. open every vehicle's link, with the mock fleet started in between if asked
   (a ``udpin`` end listens before its vehicle sends; a ``tcp`` one connects
   to a vehicle already serving);
2. readiness, per vehicle and concurrently, each step shown to the operator:
   heartbeat, vehicle type, the telemetry we need (position, battery, range
   readings for ``range`` vehicles), a 3D GPS fix and a home position (the
   position estimate: before it ArduPilot reports 0, 0), then on the charger,
   GUIDED accepted (retried while the autopilot is not ready, as ArduPilot
   needs after boot), the vehicle's own driving limits read; the whole wait
   bounded by ``ready_timeout_s`` (``gcs.live.readiness``);
3. the planner with one agent per vehicle, each with its own energy estimate;
4. every agent task at once; the mission ends when every vehicle is home
   (or lost), on the time limit, or on an abort (Ctrl-C), after which the
   planner brings every vehicle home as at the end of a mission (the same
   ways that keep vehicles apart); one not home within ``abort_return_s`` is
   sent to charge on its own (or held);
5. a ``RunResult``, also written to the mission log (3 to 5: ``gcs.live.flight``).
"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import Awaitable, Callable
from typing import TypeVar

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from core.clocks import Clock, ScaledClock
from gcs.errors import EXIT_BAD_INPUT, EXIT_INTERRUPTED
from gcs.live.flight import fly
from gcs.live.pilot import Pilot
from gcs.live.readiness import get_ready, hear_everyone
from gcs.live.run import LiveOptions, LiveRun, MissionRefused, SimulatedFleet
from gcs.live.shared import Level, Notify, VehicleView
from gcs.log.mission_log import MissionLog
from gcs.mission import Mission, Steering, VehicleSpec
from gcs.outcome.result import RunResult
from gcs.warm_up import warm_up_planner
from vehicles.commands import CommandSettings
from vehicles.endpoints import Endpoint, EndpointKind, parse_endpoint
from vehicles.errors import LinkError
from vehicles.link import LinkSettings, VehicleLink
from vehicles.link_budget import fit_rates
from vehicles.mission_protocol import MissionSettings
from vehicles.modes import VehicleKind
from vehicles.network import MavlinkNetwork
from vehicles.parameters import ParameterSettings

#: Message rates we ask every vehicle for (Hz of vehicle time); 0 stops a stream we never read.
RATES_HZ: dict[int, float] = {
    mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT: 4.0,
    mavlink.MAVLINK_MSG_ID_SYS_STATUS: 1.0,
    mavlink.MAVLINK_MSG_ID_BATTERY_STATUS: 1.0,
    mavlink.MAVLINK_MSG_ID_MISSION_CURRENT: 2.0,
    # Ranges are also asked for on each arrival (MAV_CMD_REQUEST_MESSAGE).
    mavlink.MAVLINK_MSG_ID_DISTANCE_SENSOR: 1.0,
    mavlink.MAVLINK_MSG_ID_OBSTACLE_DISTANCE: 1.0,
    mavlink.MAVLINK_MSG_ID_ATTITUDE: 0.0,
    # The fix, for readiness; the guided target the vehicle steers to, to see it lost one.
    mavlink.MAVLINK_MSG_ID_GPS_RAW_INT: 1.0,
    mavlink.MAVLINK_MSG_ID_POSITION_TARGET_GLOBAL_INT: 2.0,
}


#: Our heartbeat period, mission seconds.
HEARTBEAT_PERIOD_S = 0.5


def link_settings(options: LiveOptions, clock: Clock, *, simulated: bool = False) -> LinkSettings:
    """Link timing: heartbeat loss in mission time; our heartbeat at 2 Hz of mission
    time (a vehicle's GCS failsafe counts in its own time: a real-time rate would trip
    it under a speed-up; twice the usual 1 Hz, so that a lossy link does not lose five
    seconds of them in a row and trip it), at most 50 Hz; on loopback with the mock,
    short command and mission timeouts (a lost packet must not cost minutes of mission
    time)."""
    lost_real = max(0.5, clock.to_real(options.link_lost_after_s))
    beat_real = min(HEARTBEAT_PERIOD_S, max(0.02, clock.to_real(HEARTBEAT_PERIOD_S)))
    if not simulated and options.speedup <= 1.0:
        return LinkSettings(
            heartbeat_period_s=beat_real,
            link_lost_after_s=lost_real,
            follow_address=options.follow_address,
        )
    return LinkSettings(
        heartbeat_period_s=beat_real,
        link_lost_after_s=lost_real,
        follow_address=options.follow_address,
        not_ready_retry_s=0.2,
        commands=CommandSettings(timeout_s=0.25, retries=6, in_progress_timeout_s=5.0),
        parameters=ParameterSettings(timeout_s=0.25, retries=8),
        mission=MissionSettings(
            timeout_s=0.4, item_timeout_s=0.15, retries=16, no_space_retry_s=0.5
        ),
    )


async def run_live(
    mission: Mission,
    options: LiveOptions,
    mission_log: MissionLog,
    notify: Notify,
    abort: asyncio.Event,
    on_start: Callable[[LiveRun], None] | None = None,
    sim: SimulatedFleet | None = None,
) -> RunResult:
    """Run the mission to its end (or abort) and return what happened. ``sim``: the
    rehearsal's simulated fleet, started here on the mission's clock."""
    clock: Clock = ScaledClock(options.speedup)
    views = {v.sysid: VehicleView(v.sysid, v.type.value) for v in mission.fleet}
    run = LiveRun(mission, clock, views, simulated=sim is not None)
    if on_start is not None:
        on_start(run)
    for view in views.values():
        view.detail = "the planner starts (it compiles once after an install)"
    # Before any link opens: compiling takes seconds after an install, and no link may
    # wait on it (numba caches what it compiled, so later runs load it at once).
    await asyncio.to_thread(warm_up_planner)
    t0 = clock.now()
    mission_log.start()  # the log's UTC stamps: the wall clock now, plus mission time

    def notice(text: str) -> None:  # a stranger on a link, a radio unplugged or back
        notify(text, Level.WARNING, None)
        mission_log.event(clock.now() - t0, text, "warning")

    network = run.network = MavlinkNetwork(
        link_settings(options, clock, simulated=run.simulated),
        allow_remote=options.allow_remote,
        on_notice=notice,
    )
    started: list[SimulatedFleet] = []
    try:
        await _open_links(run, network, options, sim, started)
        for spec in mission.fleet:
            _tap(run.links[spec.sysid], spec.sysid, mission_log, clock, t0)
        pilots = _pilots(mission, run.links, clock, options)
        await _check_ready(run, pilots, options, abort, telemetry_rates(mission, options, notice))
        return await fly(mission, options, run, pilots, mission_log, notify, abort, t0)
    finally:
        for link in run.links.values():
            await link.close()
        await network.close()
        for fleet in started:
            await fleet.stop()


async def _open_links(
    run: LiveRun,
    network: MavlinkNetwork,
    options: LiveOptions,
    sim: SimulatedFleet | None,
    started: list[SimulatedFleet],
) -> None:
    """Every vehicle's link into ``run.links``, and the copies for other stations; the
    simulated fleet (added to ``started``) between the links that listen and those that
    dial: a ``tcp`` vehicle serves and the ground station dials it, so the fleet must
    be up first; a ``udpin`` end listens, and is opened before its vehicle sends."""
    fleet = run.mission.fleet
    for spec in (s for s in fleet if not _dials(s.connection)):
        run.links[spec.sysid] = await _open_link(spec, network, options, run.views)
    for forward in options.forwards:
        try:
            await network.forward(forward, commands=options.forward_commands)
        except LinkError as exc:
            raise MissionRefused(f"--forward {forward}: {exc}", EXIT_BAD_INPUT) from exc
    if sim is not None:
        started.append(sim)
        await sim.start(run.clock)
    for spec in (s for s in fleet if _dials(s.connection)):
        run.links[spec.sysid] = await _open_link(spec, network, options, run.views)


def _pilots(
    mission: Mission, links: dict[int, VehicleLink], clock: Clock, options: LiveOptions
) -> dict[int, Pilot]:
    return {
        spec.sysid: Pilot(
            links[spec.sysid],
            VehicleKind(spec.type.value),
            mission.geo,
            clock,
            spec.speed_m_s,
            options.agent.pilot,
            car=spec.steering == Steering.CAR,
        )
        for spec in mission.fleet
    }


async def _check_ready(
    run: LiveRun,
    pilots: dict[int, Pilot],
    options: LiveOptions,
    abort: asyncio.Event,
    rates: dict[int, dict[int, float]],
) -> None:
    """Every vehicle heard, then each made ready at once (``gcs.live.readiness``)."""
    mission, links = run.mission, run.links
    await _unless_aborted(abort, hear_everyone(mission, links, options, simulated=run.simulated))
    ready = asyncio.gather(
        *(
            get_ready(
                spec,
                links[spec.sysid],
                pilots[spec.sysid],
                mission,
                options,
                run.views,
                rates[spec.sysid],
            )
            for spec in mission.fleet
        )
    )
    await _unless_aborted(abort, ready)


def telemetry_rates(
    mission: Mission, options: LiveOptions, notice: Callable[[str], None]
) -> dict[int, dict[int, float]]:
    """The rates each vehicle is asked for: ``RATES_HZ``, scaled down on a serial radio
    that the fleet sharing it would fill (the operator is told)."""
    rates = {spec.sysid: RATES_HZ for spec in mission.fleet}
    sharing: dict[Endpoint, list[int]] = {}
    for spec in mission.fleet:  # one device however it is spelt
        endpoint = parse_endpoint(spec.connection, allow_remote=True)
        sharing.setdefault(endpoint, []).append(spec.sysid)
    for endpoint, sysids in sharing.items():
        if endpoint.kind is not EndpointKind.SERIAL:
            continue
        signed = options.keys is not None and any(options.keys.signing(s) for s in sysids)
        fitted, budget = fit_rates(
            RATES_HZ, baud=endpoint.baud, vehicles=len(sysids), signed=signed
        )
        if budget.factor < 1.0:
            notice(f"{endpoint}: {len(sysids)} vehicle(s) on one radio: {budget}")
            rates.update(dict.fromkeys(sysids, fitted))
    return rates


def _dials(connection: str) -> bool:
    """Whether the ground station's side of ``connection`` connects to a server."""
    return connection.split(":", 1)[0].lower() in ("tcp", "tcpout")


async def _open_link(
    spec: VehicleSpec,
    network: MavlinkNetwork,
    options: LiveOptions,
    views: dict[int, VehicleView],
) -> VehicleLink:
    view = views[spec.sysid]

    def waiting(text: str) -> None:  # the autopilot refused something it is not ready for
        view.detail = text

    try:
        link = await network.link(
            spec.connection,
            spec.sysid,
            signing=None if options.keys is None else options.keys.signing(spec.sysid),
            on_wait=waiting,
        )
    except LinkError as exc:
        raise MissionRefused(f"vehicle {spec.sysid}: {exc}", EXIT_BAD_INPUT) from exc
    view.detail = "heartbeat"
    return link


def _tap(link: VehicleLink, sysid: int, mission_log: MissionLog, clock: Clock, t0: float) -> None:
    def tap(direction: str, frame: bytes, _msg: object) -> None:
        mission_log.raw(sysid, direction == "out", clock.now() - t0, frame)

    link.transport.add_tap(tap)


T = TypeVar("T")


async def _unless_aborted(abort: asyncio.Event, work: Awaitable[T]) -> T:
    """``work``, or, if the operator aborts first (Ctrl-C), a refusal with the exit status
    of an interrupt. Before the flight no vehicle is armed: each is left as it was."""
    task = asyncio.ensure_future(work)
    stop = asyncio.ensure_future(abort.wait())
    try:
        await asyncio.wait({task, stop}, return_when=asyncio.FIRST_COMPLETED)
    finally:
        stop.cancel()
    if not task.done():
        task.cancel()
        with contextlib.suppress(asyncio.CancelledError, MissionRefused, LinkError):
            await task
        raise MissionRefused("interrupted before the start: no vehicle was armed", EXIT_INTERRUPTED)
    return task.result()
