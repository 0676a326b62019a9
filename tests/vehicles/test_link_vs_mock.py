"""Our ground-side link (``vehicles.VehicleLink``) against our mock vehicles (``sitl_mock``).

Until now each side was tested against fakes and MAVSDK only. Here they meet
over real MAVLink 2 on loopback, in both connection directions (the link
listens on UDP and the mock sends to it; the mock serves TCP and the link
dials it), and every claim is checked against the mock's ground truth: the
vehicle's position, battery, map and stored mission. Physical processes run
on a sped-up ``ScaledClock``; protocol timers are real time and shortened
where loss makes the defaults slow. Every test is bounded twice: a
pytest-timeout mark and an ``asyncio.timeout`` around its body.
"""

from __future__ import annotations

import asyncio
import contextlib
import dataclasses
import math
from collections.abc import AsyncIterator, Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from core.cells import Cell
from core.clocks import ScaledClock
from gcs.mission import Mission, load_mission
from gcs.mock_fleet import mock_fleet_configs
from sitl_mock.endpoint import VehicleEndpoint
from sitl_mock.faults import LinkFaults, MissionFailure, MissionFaults, VehicleFaults
from sitl_mock.fleet import MockFleet, MockVehicleConfig
from sitl_mock.mission_server import MissionProtocolSettings
from sitl_mock.vehicle import Vehicle
from vehicles.commands import CommandSettings
from vehicles.endpoints import free_loopback_tcp_ports
from vehicles.errors import CommandTimeout, HeartbeatTimeout, MissionError
from vehicles.link import LinkSettings, VehicleLink
from vehicles.mission_items import MissionItem, same_items
from vehicles.mission_protocol import MissionSettings
from vehicles.modes import FlightMode
from vehicles.signing import SigningConfig
from vehicles.telemetry import Topic
from vehicles.transport import MavlinkTransport

pytestmark = pytest.mark.timeout(30)

SPEEDUP = 20.0
#: Real seconds any single test body may take (the pytest-timeout mark is the backstop).
BODY_S = 20.0
SYSID = 1
KEY = bytes(range(32))
OTHER_KEY = bytes(range(1, 33))

#: Row 0 is north. 2 m cells, so metres and cells differ; rays longer than the
#: vehicle's 10 m range exist (the map is 20 m wide).
MAP_TEXT = """\
C.........
..........
...#......
..........
.....##...
..........
#.........
"""
MISSION_YAML = """\
name: link-vs-mock
map: link_vs_mock.txt
cell_size_m: 2.0
fleet:
  count: 1
  defaults:
    type: rover
    sensing: range
    energy_per_m_pct: 1.0
    speed_m_s: 4.0
"""
UDP = "udp"
TCP = "tcp"
KINDS = (UDP, TCP)
ORIENTATIONS = range(8)  # MAV_SENSOR_ROTATION_NONE, YAW_45, ..., YAW_315


@pytest.fixture(scope="module")
def mission(tmp_path_factory: pytest.TempPathFactory) -> Mission:
    folder: Path = tmp_path_factory.mktemp("link_vs_mock")
    (folder / "link_vs_mock.txt").write_text(MAP_TEXT, encoding="utf-8")
    path = folder / "link_vs_mock.yaml"
    path.write_text(MISSION_YAML, encoding="utf-8")
    return load_mission(path)


# ---------------------------------------------------------------------- harness


@dataclass
class Pair:
    """One mock vehicle and our link to it."""

    fleet: MockFleet
    link: VehicleLink
    mission: Mission

    @property
    def truth(self) -> Vehicle:
        return self.fleet.vehicles[SYSID]

    @property
    def endpoint(self) -> VehicleEndpoint:
        return self.fleet.endpoints[SYSID]


def mock_config(mission: Mission, connection: str, **changes: Any) -> MockVehicleConfig:
    """The mission's vehicle as ``sitl-mock`` would build it, on ``connection``, with
    ``vehicle``/``battery``/``faults`` replaced and ``link_*`` fields of the link set.
    It drives in straight lines and stops dead (no ArduPilot-like driving), and its pad
    charges it, so that what the link reports can be held to the truth exactly."""
    base = mock_fleet_configs(mission)[0]
    base = dataclasses.replace(
        base,
        vehicle=dataclasses.replace(base.vehicle, drive=None),
        battery=dataclasses.replace(base.battery, pad_charging=True),
    )
    link_changes = {k[5:]: v for k, v in changes.items() if k.startswith("link_")}
    others = {k: v for k, v in changes.items() if not k.startswith("link_")}
    link = dataclasses.replace(base.link, connection=connection, **link_changes)
    return dataclasses.replace(base, link=link, **others)


async def connect(
    address: str,
    *,
    signing: SigningConfig | None = None,
    settings: LinkSettings | None = None,
) -> VehicleLink:
    """Our link, beating at 1 Hz of vehicle time as a ground station must under a speed-up
    (the mission fleet's GCS failsafe counts in vehicle time)."""
    beat = dataclasses.replace(settings or LinkSettings(), heartbeat_period_s=1.0 / SPEEDUP)
    return await VehicleLink.connect(address, target_system=SYSID, signing=signing, settings=beat)


@contextlib.asynccontextmanager
async def linked(
    mission: Mission,
    kind: str,
    *,
    settings: LinkSettings | None = None,
    signing: SigningConfig | None = None,
    heartbeat: bool = True,
    **changes: Any,
) -> AsyncIterator[Pair]:
    """A one-vehicle mock fleet and our link to it, both closed on the way out.

    UDP: the link listens on a free port (udpin) and the mock sends there (udpout).
    TCP: the mock serves (tcpin) and the link dials it (tcp), as with ArduPilot SITL."""
    async with contextlib.AsyncExitStack() as stack:
        link: VehicleLink | None = None
        if kind == UDP:
            link = await connect("udpin:127.0.0.1:0", signing=signing, settings=settings)
            stack.push_async_callback(link.close)
            assert isinstance(link.transport, MavlinkTransport)
            assert link.transport.local_address is not None
            connection = f"udpout:127.0.0.1:{link.transport.local_address[1]}"
        else:
            connection = f"tcpin:127.0.0.1:{free_loopback_tcp_ports(1)[0]}"
        config = mock_config(mission, connection, **changes)
        fleet = MockFleet(
            [config], mission.map, mission.geo, ScaledClock(SPEEDUP), seed=7, step_s=0.1
        )
        await stack.enter_async_context(fleet)
        if link is None:
            link = await connect(fleet.gcs_connection(SYSID), signing=signing, settings=settings)
            stack.push_async_callback(link.close)
        if heartbeat:
            await link.wait_heartbeat(timeout_s=5.0)
        yield Pair(fleet, link, mission)


async def until(
    link: VehicleLink, topic: Topic, ready: Callable[[], bool], timeout_s: float
) -> None:
    """Return once ``ready()`` holds, checking now and after every update on ``topic``."""
    if ready():
        return
    await link.wait_for(topic, lambda _value: ready(), timeout_s=timeout_s)


async def let_simulated_time_pass(link: VehicleLink, seconds: float) -> None:
    """Wait for telemetry stamped ``seconds`` of vehicle time later than the latest
    position (a duration measured by the vehicle's own clock, not a sleep)."""
    assert link.telemetry.position is not None
    t0 = link.telemetry.position.time_boot_ms
    await link.wait_for(
        Topic.POSITION, lambda p: p.time_boot_ms >= t0 + seconds * 1000, timeout_s=5.0
    )


# ---------------------------------------------------------------------- missions


def sample_mission(mission: Mission, count: int, seed: int = 0) -> list[MissionItem]:
    """``count`` items: home (item 0, as on ArduPilot) then waypoints over free cells and
    a speed change now and then, with parameters that differ from item to item."""
    geo = mission.geo
    rows, cols = mission.map.shape
    free = [(r, c) for r in range(rows) for c in range(cols) if mission.map.is_free((r, c))]
    home = MissionItem.waypoint(0, *geo.cell_centre(mission.charger), 0.0)
    items = [home]
    for seq in range(1, count):
        if seq % 7 == 0:
            items.append(
                MissionItem(
                    seq,
                    mavlink.MAV_FRAME_MISSION,
                    mavlink.MAV_CMD_DO_CHANGE_SPEED,
                    param1=1,
                    param2=1.0 + seq % 5 * 0.25,
                    param3=-1,
                )
            )
            continue
        cell = free[(seq * 31 + seed) % len(free)]
        items.append(
            MissionItem.waypoint(
                seq, *geo.cell_centre(cell), 0.1 * (seq % 13), hold_s=0.5 * (seq % 3)
            )
        )
    return items


def install(vehicle: Vehicle, items: list[MissionItem]) -> None:
    """Put a mission straight into the mock's ground truth (bypassing the protocol)."""
    vehicle.replace_mission(items)


def truth_items(vehicle: Vehicle) -> list[MissionItem]:
    return list(vehicle.mission)


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("count", [1, 10, 500])
async def test_mission_round_trip_is_identical(mission: Mission, kind: str, count: int) -> None:
    items = sample_mission(mission, count)
    async with asyncio.timeout(BODY_S), linked(mission, kind) as pair:
        report = await pair.link.upload_mission(items)
        assert report.items == count
        assert report.float_requests == count  # ArduPilot-style MISSION_REQUEST, answered
        assert same_items(truth_items(pair.truth), items)
        assert same_items(await pair.link.download_mission(), items)
        await pair.link.clear_mission()
        assert pair.truth.mission == ()
        assert await pair.link.download_mission() == []


# ---------------------------------------------------------------------- guided moves

#: Straight legs (no wall in between) from the pad: east, south, west, south.
ROUTE: tuple[Cell, ...] = ((0, 6), (3, 6), (3, 1), (5, 1))


async def drive_to(pair: Pair, cell: Cell) -> None:
    """Send a guided target at the cell's centre and wait until the link sees the
    vehicle stopped in that cell."""
    geo = pair.mission.geo
    await pair.link.goto(*geo.cell_centre(cell), 0.0)

    def arrived(p: Any) -> bool:
        stopped = p.vn_m_s == 0 and p.ve_m_s == 0
        return stopped and geo.geo_to_cell(p.lat_deg, p.lon_deg) == cell

    await pair.link.wait_for(Topic.POSITION, arrived, timeout_s=5.0)


def assert_at_centre(pair: Pair, cell: Cell) -> None:
    geo = pair.mission.geo
    north, east = geo.cell_centre_local(cell)
    truth = pair.truth
    assert truth.cell == cell
    # Targets travel as 1e-7 degrees (about 1 cm), so the centre is met to within that.
    assert math.hypot(truth.north_m - north, truth.east_m - east) < 0.01
    position = pair.link.telemetry.position
    assert position is not None
    seen_north, seen_east = geo.geo_to_local(position.lat_deg, position.lon_deg)
    assert math.hypot(seen_north - north, seen_east - east) < 0.02


@pytest.mark.parametrize("kind", KINDS)
async def test_guided_moves_arrive_at_the_cell(mission: Mission, kind: str) -> None:
    async with asyncio.timeout(BODY_S), linked(mission, kind) as pair:
        await pair.link.set_mode(FlightMode.GUIDED)
        await pair.link.arm()
        await until(
            pair.link,
            Topic.STATUS,
            lambda: pair.link.status is not None and pair.link.status.armed,
            2.0,
        )
        assert pair.link.status is not None
        assert pair.link.status.flight_mode is FlightMode.GUIDED
        for cell in ROUTE:
            await drive_to(pair, cell)
            assert_at_centre(pair, cell)
        await pair.link.disarm()


# ---------------------------------------------------------------------- battery


def link_battery_pct(pair: Pair) -> float | None:
    return pair.link.telemetry.battery.remaining_pct


def reported(pct: float) -> int:
    """Whole percent as the mock reports it (rounded up: 0 only when empty)."""
    return min(100, math.ceil(pct))


async def battery_shows(pair: Pair, predicate: Callable[[float], bool]) -> float:
    await until(
        pair.link,
        Topic.BATTERY,
        lambda: (pct := link_battery_pct(pair)) is not None and predicate(pct),
        5.0,
    )
    pct = link_battery_pct(pair)
    assert pct is not None
    return pct


async def drive_measuring(pair: Pair, cell: Cell) -> float:
    """Drive a straight leg to ``cell``; the distance the vehicle really covered."""
    start = (pair.truth.north_m, pair.truth.east_m)
    await drive_to(pair, cell)
    return math.dist(start, (pair.truth.north_m, pair.truth.east_m))


@pytest.mark.parametrize("kind", KINDS)
async def test_battery_follows_distance_and_charging(mission: Mission, kind: str) -> None:
    energy = mission.fleet[0].energy_per_m_pct
    battery = dataclasses.replace(
        mock_fleet_configs(mission)[0].battery, start_pct=60.0, pad_charging=True
    )
    async with asyncio.timeout(BODY_S), linked(mission, kind, battery=battery) as pair:
        link, truth = pair.link, pair.truth
        # Disarmed on the pad: charging, and the link sees it rise.
        start = await battery_shows(pair, lambda _pct: True)
        await battery_shows(pair, lambda pct: pct >= start + 3)
        assert truth.battery.charging
        assert link.telemetry.battery.charge_state == mavlink.MAV_BATTERY_CHARGE_STATE_CHARGING

        # Armed: no more charging; driving drains exactly energy x distance.
        await link.set_mode(FlightMode.GUIDED)
        await link.arm()
        before = truth.battery.remaining_pct
        distance_m = await drive_measuring(pair, ROUTE[0])
        assert distance_m == pytest.approx(mission.cell_size_m * ROUTE[0][1], abs=0.01)
        after = truth.battery.remaining_pct
        assert before - after == pytest.approx(distance_m * energy, abs=1e-6)
        await battery_shows(pair, lambda pct: pct == reported(after))

        # Disarmed off the pad: no charge for several simulated seconds.
        await link.disarm()
        await let_simulated_time_pass(link, 5.0)
        assert truth.battery.remaining_pct == after
        assert link_battery_pct(pair) == reported(after)
        assert link.telemetry.battery.charge_state != mavlink.MAV_BATTERY_CHARGE_STATE_CHARGING

        # Back on the pad and disarmed: charging again.
        await link.arm()
        distance_m = await drive_measuring(pair, mission.charger)
        back = truth.battery.remaining_pct
        assert after - back == pytest.approx(distance_m * energy, abs=1e-6)
        await link.disarm()
        await battery_shows(pair, lambda pct: pct >= reported(back) + 2)


# ---------------------------------------------------------------------- range readings


def expected_range_m(mission: Mission, north_m: float, east_m: float, bearing_deg: float) -> float:
    """Distance along a compass bearing to the first wall or the map's edge, computed
    here by intersecting the ray with every wall cell's box (slab method; a ray that
    touches a wall's corner is stopped by it), not by the mock's grid walk."""
    cs = mission.cell_size_m
    theta = math.radians(bearing_deg)
    x0, y0 = east_m / cs, -north_m / cs  # column and row coordinates, in cells
    dx, dy = math.sin(theta), -math.cos(theta)
    rows, cols = mission.map.shape
    best = _exit_box(x0, y0, dx, dy, cols, rows)
    for r in range(rows):
        for c in range(cols):
            if mission.map.is_free((r, c)):
                continue
            hit = _enter_box(x0, y0, dx, dy, (c, c + 1), (r, r + 1))
            if hit is not None:
                best = min(best, hit)
    return best * cs


def _slab(p: float, d: float, lo: float, hi: float) -> tuple[float, float]:
    if abs(d) < 1e-12:
        return (-math.inf, math.inf) if lo <= p <= hi else (math.inf, -math.inf)
    a, b = (lo - p) / d, (hi - p) / d
    return min(a, b), max(a, b)


def _enter_box(
    x0: float, y0: float, dx: float, dy: float, xs: tuple[int, int], ys: tuple[int, int]
) -> float | None:
    tx0, tx1 = _slab(x0, dx, *xs)
    ty0, ty1 = _slab(y0, dy, *ys)
    enter, leave = max(tx0, ty0), min(tx1, ty1)
    if enter <= leave + 1e-9 and leave > 1e-9:
        return max(0.0, enter)
    return None


def _exit_box(x0: float, y0: float, dx: float, dy: float, cols: int, rows: int) -> float:
    return min(_slab(x0, dx, 0, cols)[1], _slab(y0, dy, 0, rows)[1])


def assert_reading(seen_m: float | None, expected_m: float, max_m: float, beyond_m: float) -> None:
    """``beyond_m``: what the message says for "nothing within range"."""
    assert seen_m is not None
    in_range = seen_m == pytest.approx(expected_m, abs=0.006)  # whole centimetres
    beyond = seen_m == pytest.approx(beyond_m, abs=1e-9)
    if abs(expected_m - max_m) < 1e-6:
        assert in_range or beyond  # a wall exactly at the maximum range: either is right
    elif expected_m > max_m:
        assert beyond, (seen_m, expected_m)
    else:
        assert in_range, (seen_m, expected_m)


async def fresh_ranges(pair: Pair) -> None:
    """Wait until the link holds DISTANCE_SENSOR (every orientation) and OBSTACLE_DISTANCE
    readings taken after now (vehicle time)."""
    t_ms = int(pair.truth.elapsed_s * 1000)
    cache = pair.link.telemetry
    await until(
        pair.link,
        Topic.OBSTACLES,
        lambda: cache.obstacles is not None and cache.obstacles.time_usec // 1000 > t_ms,
        3.0,
    )
    await until(
        pair.link,
        Topic.RANGE,
        lambda: all(
            o in cache.ranges and cache.ranges[o].time_boot_ms > t_ms for o in ORIENTATIONS
        ),
        3.0,
    )


#: Every 15 degrees, and a few that line up with nothing.
HEADINGS = (*range(0, 360, 15), 7.5, 101.0, 333.3)


@pytest.mark.parametrize(("kind", "cell"), [(UDP, (3, 4)), (TCP, (5, 6)), (UDP, (1, 8))])
async def test_range_readings_match_the_map(mission: Mission, kind: str, cell: Cell) -> None:
    vehicle = dataclasses.replace(mock_fleet_configs(mission)[0].vehicle, start_cell=cell)
    async with asyncio.timeout(BODY_S), linked(mission, kind, vehicle=vehicle) as pair:
        truth = pair.truth
        max_m = truth.settings.range_max_m
        north, east = mission.geo.cell_centre_local(cell)
        assert (truth.north_m, truth.east_m) == pytest.approx((north, east))
        for heading in HEADINGS:
            truth.heading_deg = float(heading)  # parked: nothing else turns it
            await fresh_ranges(pair)
            cache = pair.link.telemetry
            for o in ORIENTATIONS:
                expected = expected_range_m(mission, north, east, heading + 45 * o)
                assert_reading(cache.ranges[o].distance_m, expected, max_m, max_m)
                assert cache.ranges[o].max_m == max_m
            obstacles = cache.obstacles
            assert obstacles is not None
            assert obstacles.frame == mavlink.MAV_FRAME_BODY_FRD
            assert obstacles.angle_offset_deg == 0
            for k, seen in enumerate(obstacles.distances_m):
                bearing = heading + k * obstacles.increment_deg
                expected = expected_range_m(mission, north, east, bearing)
                assert_reading(seen, expected, max_m, max_m + 0.01)


# ---------------------------------------------------------------------- signing

FAST_COMMANDS = LinkSettings(commands=CommandSettings(timeout_s=0.2, retries=2))


async def test_signed_vehicle_obeys_only_the_key_holder(mission: Mission) -> None:
    """One signed mock serving TCP, three ground stations on it at once: no key, the
    wrong key, the right key. Only the last one's commands are carried out."""
    async with (
        asyncio.timeout(BODY_S),
        linked(mission, TCP, settings=FAST_COMMANDS, heartbeat=False, link_signing_key=KEY) as pair,
    ):
        address, endpoint, truth = pair.fleet.gcs_connection(SYSID), pair.endpoint, pair.truth
        async with contextlib.AsyncExitStack() as stack:
            unsigned = pair.link
            wrong = await connect(address, signing=SigningConfig(OTHER_KEY), settings=FAST_COMMANDS)
            stack.push_async_callback(wrong.close)
            right = await connect(
                address, signing=SigningConfig(KEY, require_signed=True), settings=FAST_COMMANDS
            )
            stack.push_async_callback(right.close)

            # Without a key we still hear the vehicle (signed frames parse), but it ignores us.
            await unsigned.wait_heartbeat(timeout_s=3.0)
            rejected = endpoint.rejected_signatures
            with pytest.raises(CommandTimeout):
                await unsigned.command_long(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1)
            assert endpoint.rejected_signatures > rejected
            assert not truth.armed

            # With the wrong key neither side accepts the other's frames.
            with pytest.raises(HeartbeatTimeout):
                await wrong.wait_heartbeat(timeout_s=0.5)
            assert wrong.transport.stats.bad_signatures > 0
            rejected = endpoint.rejected_signatures
            with pytest.raises(CommandTimeout):
                await wrong.command_long(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1)
            assert endpoint.rejected_signatures > rejected
            assert not truth.armed

            # With the right key: heard, obeyed.
            await right.wait_heartbeat(timeout_s=3.0)
            await right.set_mode(FlightMode.GUIDED)
            await right.arm()
            assert truth.armed
            await until(right, Topic.STATUS, lambda: right.status.armed, 2.0)
            await right.disarm()
            assert not truth.armed


# ---------------------------------------------------------------------- loss and faults

#: Protocol timers for a lossy loopback link: short, since a round trip takes microseconds.
LOSSY_MOCK = MissionProtocolSettings(retry_s=0.03, timeout_s=1.0)
PATIENT = LinkSettings(mission=MissionSettings(timeout_s=0.15, item_timeout_s=0.06, retries=8))
IMPATIENT = LinkSettings(mission=MissionSettings(timeout_s=0.02, item_timeout_s=0.02, retries=0))


async def attempt_upload(link: VehicleLink, items: list[MissionItem]) -> MissionError | None:
    """Upload; the error if it failed. Anything but a clean return or a MissionError
    (another exception, a hang) fails the test."""
    try:
        async with asyncio.timeout(15.0):
            await link.upload_mission(items)
    except MissionError as exc:
        assert str(exc).startswith("mission upload failed")
        return exc
    return None


def assert_whole(vehicle: Vehicle, old: list[MissionItem], new: list[MissionItem]) -> bool:
    """The vehicle holds exactly the old or the new mission; True for the new one."""
    held = truth_items(vehicle)
    assert same_items(held, old) or same_items(held, new), f"half a mission: {len(held)} items"
    return same_items(held, new)


@pytest.mark.parametrize(
    ("to_gcs", "from_gcs"), [(0.3, 0.0), (0.0, 0.3), (0.3, 0.3)], ids=["down", "up", "both"]
)
@pytest.mark.parametrize("settings", [PATIENT, IMPATIENT], ids=["patient", "impatient"])
async def test_upload_under_30_percent_loss(
    mission: Mission, to_gcs: float, from_gcs: float, settings: LinkSettings
) -> None:
    old, new = sample_mission(mission, 10, seed=1), sample_mission(mission, 100, seed=2)
    lossy = VehicleFaults(link=LinkFaults(loss_to_gcs=to_gcs, loss_from_gcs=from_gcs))
    async with (
        asyncio.timeout(BODY_S),
        linked(mission, UDP, settings=settings, link_mission=LOSSY_MOCK) as pair,
    ):
        install(pair.truth, old)
        pair.endpoint.faults = lossy
        error = await attempt_upload(pair.link, new)
        has_new = assert_whole(pair.truth, old, new)
        if error is None:
            assert has_new
        elif has_new:
            # Only a final ACK lost with every repeat (the vehicle took it all, the answer
            # never came) may fail an upload that the vehicle holds.
            assert error.seq == len(new), error
        pair.endpoint.faults = VehicleFaults()  # heal the link, then read back
        assert same_items(await pair.link.download_mission(), new if has_new else old)


FAULTY = LinkSettings(mission=MissionSettings(timeout_s=0.15, item_timeout_s=0.1, retries=3))


@dataclass(frozen=True)
class FaultCase:
    failure: MissionFailure
    repeat: bool
    upload_ok: bool | None  # None: the case is about the download
    download_ok: bool = True


FAULT_CASES = {
    "request dropped once": FaultCase(MissionFailure.WRITE_REQUEST_NO_RESPONSE, False, True),
    "request never sent": FaultCase(MissionFailure.WRITE_REQUEST_NO_RESPONSE, True, False),
    "final ACK lost": FaultCase(MissionFailure.WRITE_FINAL_ACK_NO_RESPONSE, False, True),
    "final ACK always lost": FaultCase(MissionFailure.WRITE_FINAL_ACK_NO_RESPONSE, True, True),
    "final ACK error": FaultCase(MissionFailure.WRITE_FINAL_ACK_ERROR, False, False),
    "count ignored": FaultCase(MissionFailure.WRITE_COUNT_NO_RESPONSE, True, False),
    "item not sent once": FaultCase(MissionFailure.READ_ITEM_NO_RESPONSE, False, None),
    "item never sent": FaultCase(MissionFailure.READ_ITEM_NO_RESPONSE, True, None, False),
    "list ignored": FaultCase(MissionFailure.READ_LIST_NO_RESPONSE, True, None, False),
}


@pytest.mark.parametrize("case", FAULT_CASES.values(), ids=FAULT_CASES.keys())
async def test_mocklink_failure_modes(mission: Mission, case: FaultCase) -> None:
    old, new = sample_mission(mission, 10, seed=3), sample_mission(mission, 20, seed=4)
    faults = VehicleFaults(mission=MissionFaults(case.failure, at_seq=5, repeat=case.repeat))
    async with (
        asyncio.timeout(BODY_S),
        linked(mission, UDP, settings=FAULTY, link_mission=LOSSY_MOCK, faults=faults) as pair,
    ):
        install(pair.truth, old)
        if case.upload_ok is not None:
            error = await attempt_upload(pair.link, new)
            assert (error is None) == case.upload_ok, error
            assert assert_whole(pair.truth, old, new) == case.upload_ok
            if case.failure is MissionFailure.WRITE_FINAL_ACK_ERROR:
                assert error is not None and error.result == mavlink.MAV_MISSION_ERROR
            held = new if case.upload_ok else old
        else:
            held = old
        try:
            async with asyncio.timeout(10.0):
                downloaded = await pair.link.download_mission()
        except MissionError as exc:
            assert not case.download_ok, exc
            assert str(exc).startswith("mission download failed")
        else:
            assert case.download_ok
            assert same_items(downloaded, held)
