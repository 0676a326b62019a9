"""Readiness before a live mission starts: every vehicle heard, then each checked
concurrently (its type, the telemetry the mission needs, a 3D GPS fix and a home
position, on the charger, GUIDED accepted, its driving limits read, its geofence
taken), each step shown to the operator; a refusal says what is wrong and where."""

from __future__ import annotations

import asyncio
import contextlib

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from core.cells import Cell
from gcs.errors import EXIT_BAD_INPUT
from gcs.live.pilot import Pilot
from gcs.live.run import LiveOptions, MissionRefused
from gcs.live.shared import Phase, VehicleView
from gcs.mission import Mission, Sensing, VehicleSpec
from vehicles.errors import LinkError
from vehicles.link import VehicleLink
from vehicles.modes import FlightMode
from vehicles.telemetry import Position, Topic

#: The readiness wait in real seconds at least: it is made of protocol exchanges (rates,
#: parameters, the geofence) whose resends run on the network's time, not the mission's;
#: at a high speed-up the mission-time bound alone left a lossy link a few real seconds.
READY_MIN_REAL_S = 60.0

#: Connections a one-line message names before it says "...".
SHOWN_CONNECTIONS = 3


async def hear_everyone(
    mission: Mission, links: dict[int, VehicleLink], options: LiveOptions, *, simulated: bool
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
        raise MissionRefused(_not_heard(silent, mission, links, options, simulated))


def _not_heard(
    silent: list[VehicleSpec],
    mission: Mission,
    links: dict[int, VehicleLink],
    options: LiveOptions,
    simulated: bool,
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
        if simulated
        else "nothing is sending there: start the vehicles (or their simulators) first, "
        "see the README's Flying real vehicles, or add --sim to fly the built-in simulated fleet"
    )
    return f"{wait} from any of the {len(silent)} vehicle(s) {listening}: {hint}"


async def get_ready(
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
    await _telemetry(spec, link, pilot, options, view, rates_hz)
    await _position_estimate(link, pilot, view)
    pos = await pilot.wait_position(_has_fix, options.telemetry_timeout_s, "position")
    cell = pilot.cell_of(pos)
    if options.resume is not None:
        # Taken over wherever the failsafe left it: on the ground, holding, or on its way home.
        if not mission.map.inside(cell):
            raise MissionRefused(f"{who} is on cell {cell}, outside the mission's map")
    else:
        await _on_the_pad(who, cell, link, pilot, mission, view)
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


async def _telemetry(
    spec: VehicleSpec,
    link: VehicleLink,
    pilot: Pilot,
    options: LiveOptions,
    view: VehicleView,
    rates_hz: dict[int, float],
) -> None:
    """The streams asked for, and position, battery (and range) telemetry heard."""
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


async def _on_the_pad(
    who: str, cell: Cell, link: VehicleLink, pilot: Pilot, mission: Mission, view: VehicleView
) -> None:
    """A new mission starts with every vehicle disarmed on the charger, in GUIDED."""
    if not mission.map.inside(cell):
        raise MissionRefused(
            f"{who} is at cell {cell}, outside the map: check the mission's 'origin' (the "
            "north-west corner of cell (0, 0)) and 'cell_size_m'"
        )
    if cell != mission.charger:
        raise MissionRefused(
            f"{who} is on cell {cell}, not on the charger {mission.charger}: bring it to the pad"
        )
    if link.status is not None and link.status.armed:
        raise MissionRefused(f"{who} is armed on the pad: disarm it before the start")
    view.detail = "GUIDED mode"
    try:
        await pilot.set_mode(FlightMode.GUIDED)
    except LinkError as exc:
        raise MissionRefused(f"{who}: not ready: {exc}") from exc


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
