"""The live mission: connect to the fleet, check it, run one task per vehicle, report.

With ``sim`` the mission's own mock fleet (``sitl_mock``) is started in this
process first, on loopback, on the mirror side of every vehicle's connection,
with the same clock: everything else is exactly what a real mission does,
over real MAVLink on UDP or TCP.

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
   bounded by ``ready_timeout_s``;
3. the planner with one agent per vehicle, each with its own energy estimate;
4. every agent task at once; the mission ends when every vehicle is home
   (or lost), on the time limit, or on an abort (Ctrl-C), after which the
   planner brings every vehicle home as at the end of a mission (the same
   ways that keep vehicles apart); one not home within ``abort_return_s`` is
   sent to charge on its own (or held);
5. a ``RunResult``, also written to the mission log.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import time
from collections.abc import Awaitable, Callable
from dataclasses import dataclass, field
from typing import TypeVar

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from core.clocks import Clock, ScaledClock
from gcs.errors import EXIT_BAD_INPUT, EXIT_FAILED, EXIT_INTERRUPTED
from gcs.live.agent import Agent, AgentSettings, announce, send_home
from gcs.live.energy import EnergyEstimator, EnergySettings, model_prior
from gcs.live.pilot import Pilot
from gcs.live.record import MissionRecord
from gcs.live.resume import ResumePoint, resumed_text
from gcs.live.shared import Level, Notify, Phase, SharedPlanner, VehicleView
from gcs.live.status import StatusWatch
from gcs.mission import Mission, Sensing, Steering, VehicleSpec
from gcs.mission_log import MissionLog, NullLog
from gcs.mock_fleet import SimFaults, sim_configs
from gcs.percentile import percentile
from gcs.result import RunResult
from gcs.simulate import planner_settings, prior_map
from gcs.warm_up import warm_up_planner
from planner.coordinator import Coordinator
from planner.settings import AgentSpec
from sitl_mock.fleet import MockFleet
from vehicles.commands import CommandSettings
from vehicles.endpoints import Endpoint, EndpointKind, parse_endpoint
from vehicles.errors import LinkError
from vehicles.keyfile import KeyFile
from vehicles.link import LinkSettings, RejectedFrames, VehicleLink, rejected_frames
from vehicles.link_budget import fit_rates
from vehicles.mission_protocol import MissionSettings
from vehicles.modes import FlightMode, VehicleKind
from vehicles.network import MavlinkNetwork
from vehicles.parameters import ParameterSettings
from vehicles.telemetry import Position, Topic

log = logging.getLogger(__name__)

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


class MissionRefused(Exception):
    """The fleet is not fit to start; ``exit_code`` says whose fault (input or vehicles)."""

    def __init__(self, message: str, exit_code: int = EXIT_FAILED) -> None:
        super().__init__(message)
        self.exit_code = exit_code


@dataclass(frozen=True)
class LiveOptions:
    sim: bool = False
    #: Simulated seconds per real second of the vehicles' clock (the mock's, or a SITL's).
    speedup: float = 1.0
    seed: int = 0
    #: Real seconds to wait for every vehicle's first heartbeat.
    heartbeat_timeout_s: float = 30.0
    #: Mission seconds to wait for position, battery and range telemetry at the start.
    telemetry_timeout_s: float = 10.0
    #: Mission seconds a vehicle may take to be ready (GPS fix, position estimate, modes):
    #: ArduPilot SITL takes about 40 s after boot.
    ready_timeout_s: float = 180.0
    #: A link is "lost" after this many mission seconds without a heartbeat.
    link_lost_after_s: float = 3.0
    #: Stop (and send everyone home) after this many mission seconds; None: no limit.
    time_limit_s: float | None = None
    #: Mission seconds given to the fleet to get home under the planner after an
    #: abort (then as much again to a vehicle sent home on its own).
    abort_return_s: float = 300.0
    faults: SimFaults = field(default_factory=SimFaults)
    agent: AgentSettings = field(default_factory=AgentSettings)
    #: Carry on from an earlier run's log: its map, coverage and BTPs, the vehicles
    #: taken over wherever they are (``gcs run --resume``).
    resume: ResumePoint | None = None
    #: Connections to hosts other than this machine (loopback only by default).
    allow_remote: bool = False
    #: ``udpin``: follow a vehicle whose address changes, instead of staying with the
    #: address it first spoke from (``--follow-address``).
    follow_address: bool = False
    #: MAVLink 2 signing keys (``gcs run --keys``): a vehicle with a key is signed both
    #: ways and its unsigned frames are refused; with ``sim`` its mock does the same.
    keys: KeyFile | None = field(default=None, repr=False)
    #: Other ground stations that get a copy of every vehicle frame (``--forward``).
    forwards: tuple[str, ...] = ()
    #: Pass what those stations send on to the vehicles (``--forward-commands``).
    forward_commands: bool = False
    energy: EnergySettings = field(default_factory=EnergySettings)


@dataclass
class LiveRun:
    """What the display and the command look at while the mission runs."""

    mission: Mission
    clock: Clock
    views: dict[int, VehicleView]
    planner: SharedPlanner | None = None
    started_at: float | None = None
    aborted: bool = False
    #: The open links (the display shows what each one rejected).
    links: dict[int, VehicleLink] = field(default_factory=dict)
    #: The connections the links share (what each threw away is shown too).
    network: MavlinkNetwork | None = None

    @property
    def elapsed_s(self) -> float:
        return 0.0 if self.started_at is None else self.clock.now() - self.started_at

    @property
    def rejected(self) -> RejectedFrames:
        """Every frame thrown away: by the links, and by the connections they share."""
        total = rejected_frames(self.links.values())
        return total if self.network is None else total + self.network.rejected


#: The readiness wait in real seconds at least: it is made of protocol exchanges (rates,
#: parameters, the geofence) whose resends run on the network's time, not the mission's;
#: at a high speed-up the mission-time bound alone left a lossy link a few real seconds.
READY_MIN_REAL_S = 60.0

#: Our heartbeat period, mission seconds.
HEARTBEAT_PERIOD_S = 0.5


def link_settings(options: LiveOptions, clock: Clock) -> LinkSettings:
    """Link timing: heartbeat loss in mission time; our heartbeat at 2 Hz of mission
    time (a vehicle's GCS failsafe counts in its own time: a real-time rate would trip
    it under a speed-up; twice the usual 1 Hz, so that a lossy link does not lose five
    seconds of them in a row and trip it), at most 50 Hz; on loopback with the mock,
    short command and mission timeouts (a lost packet must not cost minutes of mission
    time)."""
    lost_real = max(0.5, clock.to_real(options.link_lost_after_s))
    beat_real = min(HEARTBEAT_PERIOD_S, max(0.02, clock.to_real(HEARTBEAT_PERIOD_S)))
    if not options.sim and options.speedup <= 1.0:
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
) -> RunResult:
    """Run the mission to its end (or abort) and return what happened."""
    clock: Clock = ScaledClock(options.speedup)
    views = {v.sysid: VehicleView(v.sysid, v.type.value) for v in mission.fleet}
    run = LiveRun(mission, clock, views)
    if on_start is not None:
        on_start(run)
    for view in views.values():
        view.detail = "the planner starts (it compiles once after an install)"
    # Before any link opens: compiling takes seconds after an install, and no link may
    # wait on it (numba caches what it compiled, so later runs load it at once).
    await asyncio.to_thread(warm_up_planner)
    links = run.links
    fleet: MockFleet | None = None
    t0 = clock.now()
    mission_log.start()  # the log's UTC stamps: the wall clock now, plus mission time

    def notice(text: str) -> None:  # a stranger on a link, a radio unplugged or back
        notify(text, Level.WARNING, None)
        mission_log.event(clock.now() - t0, text, "warning")

    network = run.network = MavlinkNetwork(
        link_settings(options, clock), allow_remote=options.allow_remote, on_notice=notice
    )
    try:
        # A ``tcp`` vehicle serves and the ground station dials it: the mock fleet must be
        # up first; a ``udpin`` end listens, and is opened before its vehicle sends.
        dialled = [s for s in mission.fleet if _dials(s.connection)]
        listening = [s for s in mission.fleet if not _dials(s.connection)]
        for spec in listening:
            links[spec.sysid] = await _open_link(spec, network, options, views)
        for forward in options.forwards:
            try:
                await network.forward(forward, commands=options.forward_commands)
            except LinkError as exc:
                raise MissionRefused(f"--forward {forward}: {exc}", EXIT_BAD_INPUT) from exc
        if options.sim:
            fleet = MockFleet(
                sim_configs(mission, options.faults, options.keys),
                mission.map,
                mission.geo,
                clock,
                seed=options.seed,
            )
            await fleet.start()
        for spec in dialled:
            links[spec.sysid] = await _open_link(spec, network, options, views)
        for spec in mission.fleet:
            _tap(links[spec.sysid], spec.sysid, mission_log, clock, t0)
        pilots = {
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
        rates = telemetry_rates(mission, options, notice)
        await _unless_aborted(abort, _hear_everyone(mission, links, options))
        ready = asyncio.gather(
            *(
                _ready(
                    spec,
                    links[spec.sysid],
                    pilots[spec.sysid],
                    mission,
                    options,
                    views,
                    rates[spec.sysid],
                )
                for spec in mission.fleet
            )
        )
        await _unless_aborted(abort, ready)
        return await _fly(mission, options, run, links, pilots, mission_log, notify, abort, t0)
    finally:
        for link in links.values():
            await link.close()
        await network.close()
        if fleet is not None:
            await fleet.stop()


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


#: Connections a one-line message names before it says "...".
SHOWN_CONNECTIONS = 3


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


async def _hear_everyone(
    mission: Mission, links: dict[int, VehicleLink], options: LiveOptions
) -> None:
    """Wait for every vehicle's first heartbeat at once; refuse the mission naming every
    vehicle not heard, and what to try."""

    async def heard(link: VehicleLink) -> bool:
        try:
            await link.wait_heartbeat(timeout_s=options.heartbeat_timeout_s)
        except LinkError:
            return False
        return True

    answers = await asyncio.gather(*(heard(links[s.sysid]) for s in mission.fleet))
    silent = [s for s, ok in zip(mission.fleet, answers, strict=True) if not ok]
    if silent:
        raise MissionRefused(_not_heard(silent, mission, links, options))


def _not_heard(
    silent: list[VehicleSpec],
    mission: Mission,
    links: dict[int, VehicleLink],
    options: LiveOptions,
) -> str:
    """One line: who was not heard, where the station listened, and what to try."""
    wait = f"no heartbeat within {options.heartbeat_timeout_s:g} s"
    where = list(dict.fromkeys(s.connection for s in silent))
    shown = ", ".join(where[:SHOWN_CONNECTIONS]) + (
        ", ..." if len(where) > SHOWN_CONNECTIONS else ""
    )
    refused = sum(links[s.sysid].transport.stats.bad_signatures for s in silent)
    signatures = (
        f"; {refused} frame(s) refused for their signature (unsigned, or signed with another key)"
        if refused
        else ""
    )
    listening = f"(listening on {shown}){signatures}"
    if len(silent) < len(mission.fleet):
        ids = ", ".join(str(s.sysid) for s in silent)
        return (
            f"{wait} from vehicle(s) {ids} of {len(mission.fleet)} {listening}: the others were "
            "heard; check those vehicles' links and system ids"
        )
    hint = (
        "the simulated fleet did not start"
        if options.sim
        else "nothing is sending there: start the vehicles (or their simulators) first, "
        "see the README's Flying real vehicles, or add --sim to fly the built-in simulated fleet"
    )
    return f"{wait} from any of the {len(silent)} vehicle(s) {listening}: {hint}"


async def _ready(
    spec: VehicleSpec,
    link: VehicleLink,
    pilot: Pilot,
    mission: Mission,
    options: LiveOptions,
    views: dict[int, VehicleView],
    rates_hz: dict[int, float],
) -> None:
    """Check one vehicle before the start; raise ``MissionRefused`` saying what is wrong.
    The wait after the heartbeat is bounded by ``ready_timeout_s`` as a whole, and the
    operator sees what each vehicle is waiting for (``VehicleView.detail``)."""
    who = f"vehicle {spec.sysid} ({spec.connection})"
    view = views[spec.sysid]
    try:
        status = await link.wait_heartbeat(timeout_s=options.heartbeat_timeout_s)
    except LinkError as exc:
        refused = link.transport.stats.bad_signatures
        if refused:  # only with a key: a link without one never checks signatures
            raise MissionRefused(
                f"{who}: {exc}; {refused} frame(s) refused for their signature "
                "(unsigned, or signed with another key)"
            ) from exc
        raise MissionRefused(f"{who}: {exc}") from exc
    profile = link.profile
    if profile is None or profile.kind.value != spec.type.value:
        seen = "an unknown vehicle type" if profile is None else f"a {profile.kind.value}"
        raise MissionRefused(
            f"{who}: the mission says {spec.type.value} but its heartbeat says {seen} "
            f"(MAV_TYPE {status.type_name})",
            EXIT_BAD_INPUT,
        )
    try:
        async with asyncio.timeout(max(pilot.real_s(options.ready_timeout_s), READY_MIN_REAL_S)):
            await _get_ready(spec, link, pilot, mission, options, view, rates_hz)
    except TimeoutError:
        raise MissionRefused(
            f"{who}: not ready after {options.ready_timeout_s:g} s: still waiting for "
            f"{view.detail or 'it'}"
        ) from None
    view.phase = Phase.READY
    view.detail = ""
    view.battery_pct = link.telemetry.battery.remaining_pct


async def _get_ready(
    spec: VehicleSpec,
    link: VehicleLink,
    pilot: Pilot,
    mission: Mission,
    options: LiveOptions,
    view: VehicleView,
    rates_hz: dict[int, float],
) -> None:
    who = f"vehicle {spec.sysid} ({spec.connection})"
    view.detail = "telemetry rates"
    await link.request_rates(rates_hz)
    wait_s = pilot.real_s(options.telemetry_timeout_s)
    view.detail = "position and battery telemetry"
    try:
        await link.wait_for(Topic.POSITION, lambda _p: True, wait_s)
        if link.telemetry.battery.remaining_pct is None:
            await link.wait_for(Topic.BATTERY, lambda b: b.remaining_pct is not None, wait_s)
    except TimeoutError:
        raise MissionRefused(
            f"{who}: no position or battery telemetry within {options.telemetry_timeout_s:g} s"
        ) from None
    if spec.sensing == Sensing.RANGE and not (link.telemetry.ranges or link.telemetry.obstacles):
        view.detail = "range readings"
        await pilot._request(mavlink.MAVLINK_MSG_ID_DISTANCE_SENSOR)
        try:
            await asyncio.wait_for(_any_range(link), wait_s)
        except TimeoutError:
            raise MissionRefused(
                f"{who} is set to 'sensing: range' but sends no range readings "
                f"(DISTANCE_SENSOR or OBSTACLE_DISTANCE) within {options.telemetry_timeout_s:g} s:"
                " enable its proximity sensors, or set 'sensing: map' if it is to take the map "
                "as known",
                EXIT_BAD_INPUT,
            ) from None
    await _position_estimate(link, pilot, view)
    pos = await pilot.wait_position(_has_fix, options.telemetry_timeout_s, "position")
    cell = pilot.cell_of(pos)
    if options.resume is not None:
        # Taken over wherever the failsafe left it: on the ground, holding, or on its way home.
        if not mission.map.inside(cell):
            raise MissionRefused(f"{who} is on cell {cell}, outside the mission's map")
    else:
        if not mission.map.inside(cell):
            raise MissionRefused(
                f"{who} is at cell {cell}, outside the map: check the mission's 'origin' (the "
                "north-west corner of cell (0, 0)) and 'cell_size_m'"
            )
        if cell != mission.charger:
            raise MissionRefused(
                f"{who} is on cell {cell}, not on the charger {mission.charger}: "
                "bring it to the pad"
            )
        if link.status is not None and link.status.armed:
            raise MissionRefused(f"{who} is armed on the pad: disarm it before the start")
        view.detail = "GUIDED mode"
        try:
            await pilot.set_mode(FlightMode.GUIDED)
        except LinkError as exc:
            raise MissionRefused(f"{who}: not ready: {exc}") from exc
    view.detail = "its driving settings"
    await pilot.learn_limits()
    if spec.fence:
        view.detail = "its geofence"
        try:
            await pilot.set_fence(fence_vertices(mission))
        except LinkError as exc:
            raise MissionRefused(
                f"{who}: the geofence was not taken ({exc}); set 'fence: false' for this "
                "vehicle to fly without one"
            ) from exc


def fence_vertices(mission: Mission) -> list[tuple[float, float]]:
    """The mission area's outer boundary, one cell outside the map on every side (a
    rover stopping at a border cell may roll on a little): (latitude, longitude)
    corners, clockwise from the north-west."""
    rows, cols = mission.map.shape
    size, geo = mission.cell_size_m, mission.geo
    north, south = size, -(rows + 1) * size
    west, east = -size, (cols + 1) * size
    return [
        geo.local_to_geo(north, west),
        geo.local_to_geo(north, east),
        geo.local_to_geo(south, east),
        geo.local_to_geo(south, west),
    ]


#: Mission seconds between requests for the home position while the estimator has none.
HOME_REQUEST_PERIOD_S = 2.0


async def _position_estimate(link: VehicleLink, pilot: Pilot, view: VehicleView) -> None:
    """Wait for a 3D GPS fix and for the home position (set when the autopilot's estimator
    uses GPS): until then ArduPilot reports latitude and longitude 0, 0. A vehicle that
    sends no GPS_RAW_INT at all is judged on its home position alone."""
    telemetry = link.telemetry
    while telemetry.home is None or (telemetry.gps is not None and not telemetry.gps.has_3d_fix):
        gps = telemetry.gps
        if gps is not None and not gps.has_3d_fix:
            view.detail = f"GPS fix (fix type {gps.fix_type})"
            with contextlib.suppress(TimeoutError):
                await link.wait_for(Topic.GPS, lambda g: g.has_3d_fix, pilot.real_s(5.0))
            continue
        view.detail = "position estimate (home position)"
        with contextlib.suppress(LinkError):
            await link.command_long(
                mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_HOME_POSITION
            )
        with contextlib.suppress(TimeoutError):
            await link.wait_for(Topic.HOME, lambda _h: True, pilot.real_s(HOME_REQUEST_PERIOD_S))


def _has_fix(pos: Position) -> bool:
    """Not the 0, 0 an autopilot reports before its position estimate."""
    return abs(pos.lat_deg) > 1e-7 or abs(pos.lon_deg) > 1e-7


async def _any_range(link: VehicleLink) -> None:
    waits = [
        asyncio.ensure_future(link.wait_for(topic, lambda _r: True, 1e9))
        for topic in (Topic.RANGE, Topic.OBSTACLES)
    ]
    try:
        await asyncio.wait(waits, return_when=asyncio.FIRST_COMPLETED)
    finally:
        for w in waits:
            w.cancel()
        await asyncio.gather(*waits, return_exceptions=True)


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


async def _fly(
    mission: Mission,
    options: LiveOptions,
    run: LiveRun,
    links: dict[int, VehicleLink],
    pilots: dict[int, Pilot],
    mission_log: MissionLog,
    notify: Notify,
    abort: asyncio.Event,
    t0: float,
) -> RunResult:
    wall0 = time.perf_counter()
    cpu0 = time.process_time()
    messages0 = sum(link.messages_in for link in links.values())
    loop_lag_s: list[float] = []
    probe = asyncio.ensure_future(_probe_loop_lag(loop_lag_s))
    estimators = {
        v.sysid: EnergyEstimator(model_prior(VehicleKind(v.type.value)), options.energy)
        for v in mission.fleet
    }
    coordinator = Coordinator(
        mission.map.shape,
        mission.charger,
        [AgentSpec(v.sysid, estimators[v.sysid].estimate_pct_per_m) for v in mission.fleet],
        planner_settings(mission, options.seed),
        prior=prior_map(mission),
    )
    resume = options.resume
    restored = 0
    if resume is not None:
        coordinator.restore(resume.known, resume.covered, resume.btps)
        restored = coordinator.belief.covered_count
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
    planner = SharedPlanner(coordinator, record, run.clock, mission_log, notify, run.views)
    planner.t0 = t0
    run.planner = planner
    run.started_at = run.clock.now()
    watch = StatusWatch(run)
    statuses = asyncio.ensure_future(
        asyncio.sleep(0) if isinstance(mission_log, NullLog) else watch.keep_writing(mission_log)
    )
    agents = {
        v.sysid: Agent(
            v,
            links[v.sysid],
            pilots[v.sysid],
            planner,
            estimators[v.sysid],
            run.views[v.sysid],
            mission.map,
            options.agent,
        )
        for v in mission.fleet
    }
    # Every event from here is shown and logged by ``announce``: the two never differ.
    count = f"{len(agents)} vehicle{'' if len(agents) == 1 else 's'}"
    announce(planner, f"mission {mission.name} starts with {count}")
    if resume is not None:
        announce(planner, resumed_text(resume, restored))
    tasks = {sysid: asyncio.ensure_future(agent.run()) for sysid, agent in agents.items()}
    stop = asyncio.ensure_future(abort.wait())
    limit = None if options.time_limit_s is None else run.clock.to_real(options.time_limit_s)
    interrupted = False
    try:
        done, _ = await asyncio.wait(
            [*tasks.values(), stop], timeout=limit, return_when=asyncio.FIRST_COMPLETED
        )
        while stop not in done and not all(t.done() for t in tasks.values()):
            remaining = None if limit is None else limit - (time.perf_counter() - wall0)
            if remaining is not None and remaining <= 0:
                break
            done, _ = await asyncio.wait(
                [*(t for t in tasks.values() if not t.done()), stop],
                timeout=remaining,
                return_when=asyncio.FIRST_COMPLETED,
            )
        interrupted = not all(t.done() for t in tasks.values())
        if interrupted:
            # Home under the planner, which keeps the vehicles out of each other's way,
            # as at the end of a mission; whoever is not home in time is sent directly.
            run.aborted = True
            why = (
                "aborted by the operator"
                if abort.is_set()
                else f"time limit reached ({options.time_limit_s:g} s after the start)"
            )
            announce(planner, f"mission {why}: every vehicle goes home", Level.WARNING)
            await planner.recall()
            await asyncio.wait(
                [t for t in tasks.values() if not t.done()],
                timeout=run.clock.to_real(options.abort_return_s),
            )
    finally:
        late = [agents[sysid] for sysid, task in tasks.items() if not task.done()]
        for task in (*tasks.values(), stop):
            task.cancel()
        await asyncio.gather(*tasks.values(), stop, return_exceptions=True)
    going = [a for a in late if not record.agents[a.id].lost]
    if going:
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
    probe.cancel()
    statuses.cancel()
    await asyncio.gather(probe, statuses, return_exceptions=True)
    await watch.write(mission_log)
    planner.write_coverage()
    result = record.result(
        coordinator,
        wall_s=time.perf_counter() - wall0,
        planner_s=planner.planner_s,
        mission_s=planner.t_s,
        extra={
            "aborted": int(interrupted),
            **(
                {
                    "resumed_logged_cells": resume.covered_cells,
                    "resumed_covered_cells": restored,
                    "resumed_swept_again_cells": len(record.swept_again),
                    "resumed_at_s": resume.last_t_s,
                }
                if resume is not None
                else {}
            ),
            "speedup": options.speedup,
            "moves_held_back": planner.held_back,
            "waits": planner.waits,
            **run.rejected.report_fields(),
            "forward_refused": 0 if run.network is None else run.network.forward_refused,
            **load_figures(
                planner.decision_latency_s,
                sum(link.messages_in for link in links.values()) - messages0,
                time.process_time() - cpu0,
                time.perf_counter() - wall0,
                loop_lag_s,
            ),
        },
    )
    mission_log.result(planner.t_s, result)
    return result
