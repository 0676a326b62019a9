"""The mock vehicles' GCS failsafe (``sitl_mock.failsafe``): what they do when the ground
station falls silent, and that a new ground station can take over afterwards.

Three levels: the vehicle state machine stepped by hand (vehicle time only),
the endpoint fed MAVLink bytes by hand (which heartbeats count), and a mock
fleet over real loopback UDP/TCP with our ``VehicleLink``, where a ground
station goes silent (one heartbeat, then none, as if killed) and a second one
connects on the same address and carries on.
"""

from __future__ import annotations

import asyncio
import contextlib
import dataclasses
import math
import random
from collections.abc import AsyncIterator, Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from core.cells import Cell
from core.clocks import ManualClock, ScaledClock
from core.geo import GeoFrame
from gcs.mission import Mission, load_mission
from gcs.mock_fleet import FLEET_GCS_FAILSAFE, mock_fleet_configs
from gcs.sitl_cli import _prepare, build_parser, main
from sitl_mock.battery import BatterySettings
from sitl_mock.endpoint import LinkSettings as MockLinkSettings
from sitl_mock.endpoint import VehicleEndpoint
from sitl_mock.events import Severity, StatusText, VehicleEvent
from sitl_mock.failsafe import FailsafeAction, GcsFailsafe
from sitl_mock.fleet import MockFleet
from sitl_mock.gridmap import GridMap
from sitl_mock.modes import CopterMode, RoverMode, VehicleKind
from sitl_mock.vehicle import Vehicle, VehicleSettings
from sitl_mock.world import World
from vehicles.endpoints import free_loopback_tcp_ports, free_loopback_udp_ports
from vehicles.link import LinkSettings, VehicleLink
from vehicles.mission_items import MissionItem
from vehicles.modes import FlightMode
from vehicles.telemetry import Position, Topic

pytestmark = pytest.mark.timeout(60)

DT = 0.1
HOLD = GcsFailsafe(FailsafeAction.HOLD)
RTL = GcsFailsafe(FailsafeAction.RTL)
NONE = GcsFailsafe(FailsafeAction.NONE)
FAILSAFE_TEXT = "GCS Failsafe"
CLEARED_TEXT = "GCS Failsafe Cleared"


# ---------------------------------------------------------------------- vehicle level


def world_of(rows: list[str]) -> World:
    """'#' wall, '.' free, 'C' charging pad; 1 m cells."""
    obstacle = np.array([[ch == "#" for ch in row] for row in rows], dtype=bool)
    pads = tuple((r, c) for r, row in enumerate(rows) for c, ch in enumerate(row) if ch == "C")
    return World(GridMap(obstacle=obstacle, pads=pads), GeoFrame(47.0, 8.0, 400.0, 1.0))


def make_vehicle(
    world: World,
    failsafe: GcsFailsafe,
    kind: VehicleKind = VehicleKind.ROVER,
    **settings: Any,
) -> tuple[Vehicle, list[VehicleEvent]]:
    settings.setdefault("speed_m_s", 1.0)
    v = Vehicle(
        1,
        VehicleSettings(kind, gcs_failsafe=failsafe, **settings),
        BatterySettings(),
        world,
        random.Random(1),
    )
    events: list[VehicleEvent] = []
    v.subscribe(events.append)
    return v, events


def texts(events: list[VehicleEvent]) -> list[str]:
    return [e.text for e in events if isinstance(e, StatusText)]


def failsafe_texts(events: list[VehicleEvent]) -> list[str]:
    return [t for t in texts(events) if t.startswith(FAILSAFE_TEXT)]


def run(v: Vehicle, seconds: float, beat_every_s: float | None = None) -> None:
    """Step ``seconds`` of vehicle time; with ``beat_every_s`` a ground station's heartbeat
    arrives that often."""
    next_beat = v.elapsed_s
    for _ in range(round(seconds / DT)):
        if beat_every_s is not None and v.elapsed_s >= next_beat - 1e-9:
            v.gcs_heartbeat()
            next_beat += beat_every_s
        v.step(DT)


def centre(world: World, cell: Cell) -> tuple[float, float]:
    return world.geo.cell_centre_local(cell)


def position(v: Vehicle) -> tuple[float, float, float]:
    return (v.north_m, v.east_m, v.alt_m)


CORRIDOR = ["C" + "." * 29]
FAR: Cell = (0, 29)


def driving_rover(
    failsafe: GcsFailsafe, rows: list[str] = CORRIDOR, to: Cell = FAR, **settings: Any
) -> tuple[World, Vehicle, list[VehicleEvent]]:
    """A rover in GUIDED on its way to ``to``, just heard from its ground station."""
    world = world_of(rows)
    v, events = make_vehicle(world, failsafe, **settings)
    v.set_mode(RoverMode.GUIDED)
    v.arm()
    v.goto(*centre(world, to))
    v.gcs_heartbeat()
    return world, v, events


def flying_copter(
    failsafe: GcsFailsafe, rows: list[str] = CORRIDOR, to: Cell = FAR
) -> tuple[World, Vehicle, list[VehicleEvent]]:
    """A copter up at 5 m in GUIDED on its way to ``to``, its ground station beating."""
    world = world_of(rows)
    v, events = make_vehicle(world, failsafe, kind=VehicleKind.COPTER)
    v.set_mode(CopterMode.GUIDED)
    v.arm()
    v.takeoff(5.0)
    run(v, 3.0, beat_every_s=1.0)
    assert v.alt_m == pytest.approx(5.0)
    v.goto(*centre(world, to))
    v.gcs_heartbeat()
    return world, v, events


def test_no_failsafe_before_any_gcs_heartbeat() -> None:
    world = world_of(CORRIDOR)
    v, events = make_vehicle(world, HOLD, speed_m_s=1.0)
    v.set_mode(RoverMode.GUIDED)
    v.arm()
    v.goto(*centre(world, FAR))
    run(v, 35.0)
    assert v.cell == FAR and v.mode == RoverMode.GUIDED and v.armed
    assert failsafe_texts(events) == []
    assert not v.gcs_failsafe_active


def test_heartbeats_keep_the_failsafe_away() -> None:
    _, v, events = driving_rover(HOLD)
    run(v, 35.0, beat_every_s=1.0)
    assert v.cell == FAR and v.mode == RoverMode.GUIDED
    assert failsafe_texts(events) == []


def test_rover_holds_where_it_is_after_the_timeout() -> None:
    _, v, events = driving_rover(HOLD)
    run(v, 4.8)
    assert v.mode == RoverMode.GUIDED and failsafe_texts(events) == []
    run(v, 0.5)
    assert v.mode == RoverMode.HOLD and v.armed and v.gcs_failsafe_active
    warnings = [e for e in events if isinstance(e, StatusText) and e.text == FAILSAFE_TEXT]
    assert len(warnings) == 1 and warnings[0].severity is Severity.WARNING
    stopped = position(v)
    assert 4.0 < v.east_m < 6.5  # about 5 s at 1 m/s from the pad's centre
    run(v, 20.0)
    assert position(v) == stopped and v.mode == RoverMode.HOLD and v.armed
    assert failsafe_texts(events) == [FAILSAFE_TEXT]  # announced once


def test_copter_brakes_and_hovers() -> None:
    _, v, events = flying_copter(HOLD)
    run(v, 5.3)
    assert v.mode == CopterMode.BRAKE and v.armed and v.airborne
    assert failsafe_texts(events) == [FAILSAFE_TEXT]
    stopped = position(v)
    run(v, 10.0)
    assert position(v) == stopped and v.alt_m == pytest.approx(5.0)


def test_failsafe_none_leaves_the_vehicle_alone() -> None:
    _, v, events = driving_rover(NONE)
    run(v, 35.0)
    assert v.cell == FAR and v.mode == RoverMode.GUIDED and v.armed
    assert failsafe_texts(events) == []


def test_rover_rtl_drives_home_and_stops() -> None:
    world, v, events = driving_rover(RTL)
    run(v, 30.0)
    assert failsafe_texts(events) == [FAILSAFE_TEXT]
    assert v.mode == RoverMode.RTL and v.cell == world.map.charger and v.armed
    assert "Reached destination" in texts(events)


def test_copter_rtl_lands_at_home_and_disarms() -> None:
    world, v, events = flying_copter(RTL)
    run(v, 30.0)
    assert failsafe_texts(events) == [FAILSAFE_TEXT]
    assert v.mode == CopterMode.RTL and v.cell == world.map.charger
    assert v.landed and not v.armed
    assert "Land complete" in texts(events)


def test_rtl_flies_straight_and_stops_at_a_wall() -> None:
    """A real RTL goes straight home too: across a wall it stops there, and holds."""
    rows = ["C.#..", "..#..", "....."]
    world = world_of(rows)
    v, events = make_vehicle(world, RTL)
    v.set_mode(RoverMode.GUIDED)
    v.arm()
    for cell in ((2, 0), (2, 4), (0, 4)):  # round the wall, beating all the way
        v.goto(*centre(world, cell))
        run(v, 6.0, beat_every_s=1.0)
        assert v.cell == cell
    run(v, 20.0)
    assert failsafe_texts(events) == [FAILSAFE_TEXT]
    assert any(t.startswith("Move refused") for t in texts(events))
    assert v.mode == RoverMode.RTL and v.cell == (0, 3) and v.stopped_by_refusal


@pytest.mark.parametrize("continue_auto", [True, False])
def test_a_mission_in_auto_carries_on(continue_auto: bool) -> None:
    world = world_of(CORRIDOR)
    v, events = make_vehicle(world, GcsFailsafe(FailsafeAction.HOLD, continue_auto=continue_auto))
    cells = [world.map.charger, (0, 10), (0, 20)]  # item 0 is home
    items = [_item(seq, *world.geo.cell_centre(cell)) for seq, cell in enumerate(cells)]
    v.replace_mission(items)
    v.arm()
    v.set_mode(RoverMode.AUTO)
    v.gcs_heartbeat()
    run(v, 30.0)
    if continue_auto:
        assert failsafe_texts(events) == ["GCS Failsafe - Continuing Auto Mode"]
        assert "Mission Complete" in texts(events) and v.cell == (0, 20)
        assert v.mode == RoverMode.HOLD  # a rover holds once its mission is done
    else:
        assert failsafe_texts(events) == [FAILSAFE_TEXT]
        assert "Mission Complete" not in texts(events) and v.mode == RoverMode.HOLD
        assert v.cell[1] < 10


def _item(seq: int, lat: float, lon: float) -> MissionItem:
    return MissionItem(
        seq,
        mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
        mavlink.MAV_CMD_NAV_WAYPOINT,
        0,
        1,
        0.0,
        0.0,
        0.0,
        0.0,
        round(lat * 1e7),
        round(lon * 1e7),
        0.0,
    )


def test_a_new_heartbeat_clears_it_and_the_new_gcs_takes_over() -> None:
    world, v, events = driving_rover(HOLD)
    run(v, 10.0)
    assert v.mode == RoverMode.HOLD and v.gcs_failsafe_active
    v.gcs_heartbeat()
    assert texts(events)[-1] == CLEARED_TEXT and not v.gcs_failsafe_active
    assert v.mode == RoverMode.HOLD  # the mode is the new ground station's call
    v.set_mode(RoverMode.GUIDED)
    v.goto(*centre(world, (0, 12)))
    run(v, 10.0, beat_every_s=1.0)
    assert v.cell == (0, 12) and v.mode == RoverMode.GUIDED
    # Armed again: a second silence triggers it again.
    run(v, 6.0)
    assert v.mode == RoverMode.HOLD
    assert failsafe_texts(events) == [FAILSAFE_TEXT, CLEARED_TEXT, FAILSAFE_TEXT]


def test_after_rtl_a_copter_is_taken_over_from_the_ground() -> None:
    world, v, events = flying_copter(RTL)
    run(v, 30.0)
    assert v.landed and not v.armed
    v.gcs_heartbeat()
    assert CLEARED_TEXT in texts(events)
    v.set_mode(CopterMode.GUIDED)
    v.arm()
    v.takeoff(5.0)
    run(v, 3.0, beat_every_s=1.0)
    v.goto(*centre(world, (0, 5)))
    run(v, 5.0, beat_every_s=1.0)
    assert v.cell == (0, 5) and v.airborne and v.mode == CopterMode.GUIDED


def test_a_disarmed_vehicle_is_left_alone() -> None:
    world = world_of(CORRIDOR)
    v, events = make_vehicle(world, RTL)
    v.set_mode(RoverMode.GUIDED)
    v.gcs_heartbeat()
    run(v, 20.0)
    assert failsafe_texts(events) == [] and v.mode == RoverMode.GUIDED


def test_a_rover_in_hold_is_left_alone() -> None:
    world = world_of(CORRIDOR)
    v, events = make_vehicle(world, RTL)
    v.arm()  # in HOLD, the rover's first mode
    v.gcs_heartbeat()
    run(v, 20.0)
    assert failsafe_texts(events) == [] and v.mode == RoverMode.HOLD and v.armed


def test_a_copter_armed_on_the_ground_disarms() -> None:
    world = world_of(CORRIDOR)
    v, events = make_vehicle(world, HOLD, kind=VehicleKind.COPTER, copter_auto_disarm_s=None)
    v.set_mode(CopterMode.GUIDED)
    v.arm()
    v.gcs_heartbeat()
    run(v, 6.0)
    assert failsafe_texts(events) == ["GCS Failsafe - Disarming"]
    assert not v.armed and v.mode == CopterMode.GUIDED


def test_a_landing_copter_goes_on_landing() -> None:
    _, v, events = flying_copter(GcsFailsafe(FailsafeAction.HOLD, timeout_s=2.0))
    v.land()
    run(v, 2.5)
    assert failsafe_texts(events) == ["GCS Failsafe - Continuing Landing"]
    assert v.mode == CopterMode.LAND
    run(v, 5.0)
    assert v.landed and not v.armed


def test_rtl_refused_falls_back_to_hold() -> None:
    """Force-armed during start-up, the rover may not RTL yet: it holds instead."""
    world = world_of(CORRIDOR)
    v, events = make_vehicle(world, RTL, startup_delay_s=100.0)
    v.set_mode(RoverMode.MANUAL)
    v.arm(force=True)
    v.gcs_heartbeat()
    run(v, 6.0)
    assert failsafe_texts(events) == [FAILSAFE_TEXT] and v.mode == RoverMode.HOLD


def test_the_timeout_is_configurable_and_checked() -> None:
    _, v, _ = driving_rover(GcsFailsafe(FailsafeAction.HOLD, timeout_s=2.0))
    run(v, 2.5)
    assert v.mode == RoverMode.HOLD
    with pytest.raises(ValueError, match="timeout_s"):
        GcsFailsafe(FailsafeAction.HOLD, timeout_s=0.0)


def test_copter_brake_and_loiter_modes() -> None:
    """BRAKE (the failsafe's hold) is not armable, as on ArduPilot; LOITER is."""
    world = world_of(CORRIDOR)
    v, _ = make_vehicle(world, HOLD, kind=VehicleKind.COPTER)
    v.set_mode(CopterMode.BRAKE)
    with pytest.raises(Exception, match="not armable"):
        v.arm()
    v.set_mode(CopterMode.LOITER)
    v.arm()
    assert v.armed and v.mode_name == "LOITER"


# ---------------------------------------------------------------------- endpoint level


@dataclass
class FakePeer:
    """A peer that hands the endpoint whole datagrams and keeps what it is sent."""

    name: str = "fake"
    datagrams: bool = True
    sent: list[bytes] = dataclasses.field(default_factory=list)

    def write(self, data: bytes) -> None:
        self.sent.append(data)


def heartbeat_bytes(mav_type: int, sysid: int = 255) -> bytes:
    codec = mavlink.MAVLink(None, sysid, mavlink.MAV_COMP_ID_MISSIONPLANNER)
    msg = codec.heartbeat_encode(mav_type, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
    return bytes(msg.pack(codec))


def statustexts(data: list[bytes]) -> list[str]:
    codec = mavlink.MAVLink(None)
    codec.robust_parsing = True
    messages = [m for chunk in data for m in codec.parse_buffer(chunk) or []]
    return [m.text for m in messages if m.get_type() == "STATUSTEXT"]


@pytest.mark.parametrize(
    ("mav_type", "counts"),
    [
        (mavlink.MAV_TYPE_GCS, True),
        (mavlink.MAV_TYPE_ONBOARD_CONTROLLER, False),  # a companion computer
        (mavlink.MAV_TYPE_GROUND_ROVER, False),  # another vehicle
    ],
)
def test_only_a_ground_station_heartbeat_arms_the_failsafe(mav_type: int, counts: bool) -> None:
    world = world_of(CORRIDOR)
    v, _ = make_vehicle(world, HOLD)
    endpoint = VehicleEndpoint(v, MockLinkSettings("udpout:127.0.0.1:9"), ManualClock())
    peer = FakePeer()
    endpoint.peer_opened(peer)
    v.set_mode(RoverMode.GUIDED)
    v.arm()
    endpoint.peer_received(peer, heartbeat_bytes(mav_type))
    run(v, 6.0)
    assert (v.mode == RoverMode.HOLD) is counts
    assert (FAILSAFE_TEXT in statustexts(peer.sent)) is counts
    if counts:
        endpoint.peer_received(peer, heartbeat_bytes(mav_type))
        assert statustexts(peer.sent)[-1] == CLEARED_TEXT


# ---------------------------------------------------------------------- the sitl-mock CLI


MAP_TEXT = """\
C.........
..........
...#......
..........
.....##...
..........
#.........
"""


def write_mission(folder: Path, kind: str, speed_m_s: float) -> Path:
    (folder / "failsafe.txt").write_text(MAP_TEXT, encoding="utf-8")
    path = folder / f"failsafe_{kind}.yaml"
    path.write_text(
        "name: failsafe\nmap: failsafe.txt\ncell_size_m: 2.0\nfleet:\n  count: 1\n"
        f"  defaults:\n    type: {kind}\n    sensing: map\n    speed_m_s: {speed_m_s}\n",
        encoding="utf-8",
    )
    return path


def test_cli_failsafe_options(tmp_path: Path) -> None:
    path = write_mission(tmp_path, "rover", 1.0)
    _, configs = _prepare(build_parser().parse_args([str(path)]))
    assert configs[0].vehicle.gcs_failsafe == FLEET_GCS_FAILSAFE
    assert FLEET_GCS_FAILSAFE.action is FailsafeAction.HOLD
    assert FLEET_GCS_FAILSAFE.timeout_s == 5.0 and FLEET_GCS_FAILSAFE.continue_auto
    argv = [str(path), "--gcs-failsafe", "rtl", "--gcs-failsafe-timeout", "3"]
    _, configs = _prepare(build_parser().parse_args(argv))
    assert configs[0].vehicle.gcs_failsafe == GcsFailsafe(FailsafeAction.RTL, 3.0)
    _, configs = _prepare(build_parser().parse_args([str(path), "--gcs-failsafe", "none"]))
    assert not configs[0].vehicle.gcs_failsafe.enabled
    assert main([str(path), "--gcs-failsafe-timeout", "0"]) == 2
    # A vehicle built by hand is ArduPilot as shipped: no GCS failsafe.
    assert not VehicleSettings(VehicleKind.ROVER).gcs_failsafe.enabled


# ---------------------------------------------------------------------- over loopback

SPEEDUP = 10.0
SYSID = 1
#: Real seconds any single loopback test body may take.
BODY_S = 30.0
UDP = "udp"
TCP = "tcp"
#: A ground station that beats once when it connects and never again (killed, as far as
#: the vehicle can tell), yet goes on listening (see ``ground_station``).
SILENT = LinkSettings(heartbeat_period_s=1e6)
#: A live one, beating at 1 Hz of vehicle time.
BEATING = LinkSettings(heartbeat_period_s=1.0 / SPEEDUP)
GCS_HEARTBEAT = mavlink.MAVLink_heartbeat_message(
    mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, mavlink.MAV_STATE_ACTIVE, 3
)


class Texts:
    """Every STATUSTEXT a link receives from its creation on."""

    def __init__(self, link: VehicleLink) -> None:
        self.seen: list[str] = []
        self._new = asyncio.Event()
        link.router.on("STATUSTEXT", self._on)

    def _on(self, msg: Any) -> None:
        text = msg.text if isinstance(msg.text, str) else msg.text.decode("utf-8", "replace")
        self.seen.append(text.rstrip("\x00"))
        self._new.set()

    async def wait(self, text: str, timeout_s: float = 5.0) -> None:
        async with asyncio.timeout(timeout_s):
            while text not in self.seen:
                self._new.clear()
                await self._new.wait()


@dataclass
class Setup:
    fleet: MockFleet
    mission: Mission
    #: The ground station's address of the vehicle (what ``gcs run`` would use).
    gcs_address: str

    @property
    def truth(self) -> Vehicle:
        return self.fleet.vehicles[SYSID]

    def cell_centre(self, cell: Cell) -> tuple[float, float]:
        return self.mission.geo.cell_centre(cell)

    def cell_of(self, pos: Position) -> Cell:
        return self.mission.geo.geo_to_cell(pos.lat_deg, pos.lon_deg)


@contextlib.asynccontextmanager
async def fleet_of(
    tmp_path: Path, kind: str, vehicle: str, speed_m_s: float, failsafe: GcsFailsafe | None
) -> AsyncIterator[Setup]:
    """A one-vehicle mission fleet (``sitl-mock``'s configuration, its failsafe unless
    ``failsafe``) on a loopback address; stopped on the way out."""
    mission = load_mission(write_mission(tmp_path, vehicle, speed_m_s))
    config = mock_fleet_configs(mission)[0]
    if kind == UDP:
        (port,) = free_loopback_udp_ports(1)
        connection, gcs_address = f"udpout:127.0.0.1:{port}", f"udpin:127.0.0.1:{port}"
    else:
        (port,) = free_loopback_tcp_ports(1)
        connection, gcs_address = f"tcpin:127.0.0.1:{port}", f"tcp:127.0.0.1:{port}"
    vehicle_settings = config.vehicle
    if failsafe is not None:
        vehicle_settings = dataclasses.replace(vehicle_settings, gcs_failsafe=failsafe)
    config = dataclasses.replace(
        config,
        vehicle=vehicle_settings,
        link=dataclasses.replace(config.link, connection=connection),
    )
    async with MockFleet([config], mission.map, mission.geo, ScaledClock(SPEEDUP), seed=3) as fleet:
        yield Setup(fleet, mission, gcs_address)


@contextlib.asynccontextmanager
async def ground_station(
    setup: Setup, settings: LinkSettings
) -> AsyncIterator[tuple[VehicleLink, Texts]]:
    link = await VehicleLink.connect(setup.gcs_address, target_system=SYSID, settings=settings)
    try:
        texts_seen = Texts(link)
        await link.wait_heartbeat(timeout_s=5.0)
        if settings is SILENT:
            # Its own first beat may have gone nowhere: a udpin end learns where the vehicle
            # is only when it hears it. So the one beat it gives is this one.
            assert link.transport.send(GCS_HEARTBEAT)
        yield link, texts_seen
    finally:
        await link.close()
        # asyncio lets a closed UDP socket go on its next pass (call_soon), after
        # ``close`` has returned: give it that pass, so the next ground station can bind
        # the same port (a killed process frees it at once).
        await asyncio.sleep(0)


async def wait_position(
    link: VehicleLink, predicate: Callable[[Position], bool], timeout_s: float = 5.0
) -> Position:
    pos = link.telemetry.position
    if pos is not None and predicate(pos):
        return pos
    result: Position = await link.wait_for(Topic.POSITION, predicate, timeout_s)
    return result


async def let_vehicle_time_pass(link: VehicleLink, seconds: float) -> Position:
    """The first position stamped ``seconds`` of vehicle time after the latest one."""
    latest = await wait_position(link, lambda _p: True)
    t0 = latest.time_boot_ms
    return await wait_position(link, lambda p: p.time_boot_ms >= t0 + seconds * 1000)


async def arrive(setup: Setup, link: VehicleLink, cell: Cell, alt_m: float = 0.0) -> Position:
    """Send a GUIDED target and wait until the vehicle stands still in ``cell``."""
    await link.goto(*setup.cell_centre(cell), alt_m)
    return await wait_position(
        link,
        lambda p: setup.cell_of(p) == cell and math.hypot(p.vn_m_s, p.ve_m_s) == 0,
        timeout_s=10.0,
    )


@pytest.mark.parametrize("kind", [UDP, TCP])
async def test_killed_gcs_rover_holds_and_a_new_gcs_takes_over(tmp_path: Path, kind: str) -> None:
    """The ground station goes silent mid-move: the rover holds where it is (the mission
    fleet's default); a new ground station on the same address sees the failsafe clear,
    sets GUIDED and drives on."""
    target: Cell = (0, 9)
    async with asyncio.timeout(BODY_S), fleet_of(tmp_path, kind, "rover", 1.0, None) as setup:
        truth = setup.truth
        async with ground_station(setup, SILENT) as (first, seen):
            await first.set_mode(FlightMode.GUIDED)
            await first.arm()
            await first.goto(*setup.cell_centre(target), 0.0)
            await seen.wait(FAILSAFE_TEXT)
            status = await first.wait_for(
                Topic.STATUS, lambda s: s.flight_mode is FlightMode.HOLD, 5.0
            )
            assert status.armed
            assert truth.mode == RoverMode.HOLD and truth.gcs_failsafe_active
            assert truth.cell != target
            # In HOLD a rover's motors stop: it rolls to a stop, as ArduPilot Rover does.
            stopped = await let_vehicle_time_pass(first, 15.0)
            assert math.hypot(stopped.vn_m_s, stopped.ve_m_s) == 0
            where = (truth.north_m, truth.east_m)
        # The first ground station is gone; the vehicle holds on.
        async with ground_station(setup, BEATING) as (second, seen_again):
            await seen_again.wait(CLEARED_TEXT)
            assert not truth.gcs_failsafe_active
            assert (truth.north_m, truth.east_m) == where
            assert second.status is not None and second.status.flight_mode is FlightMode.HOLD
            await second.set_mode(FlightMode.GUIDED)
            await arrive(setup, second, target)
            assert truth.cell == target and truth.mode == RoverMode.GUIDED
            await second.disarm()
        assert FAILSAFE_TEXT not in seen_again.seen


async def test_killed_gcs_auto_mission_carries_on(tmp_path: Path) -> None:
    """The way home flown in AUTO goes on without the ground station."""
    cells: list[Cell] = [(0, 4), (3, 4), (3, 0)]
    async with asyncio.timeout(BODY_S), fleet_of(tmp_path, UDP, "rover", 1.0, None) as setup:
        truth = setup.truth
        async with ground_station(setup, SILENT) as (link, seen):
            home = setup.cell_centre(setup.mission.charger)
            items = [MissionItem.waypoint(0, *home, 0.0)] + [
                MissionItem.waypoint(seq, *setup.cell_centre(cell), 0.0)
                for seq, cell in enumerate(cells, start=1)
            ]
            await link.upload_mission(items)
            await link.arm()
            await link.set_mode(FlightMode.AUTO)
            await seen.wait("GCS Failsafe - Continuing Auto Mode")
            assert truth.cell != cells[-1]
            await seen.wait("Mission Complete", timeout_s=10.0)
            assert truth.cell == cells[-1] and truth.mode == RoverMode.HOLD
            assert FAILSAFE_TEXT not in seen.seen


async def test_killed_gcs_copter_rtl_lands_home_and_a_new_gcs_flies_it(tmp_path: Path) -> None:
    """With ``--gcs-failsafe rtl`` a copter flies home, lands and disarms; a new ground
    station sets GUIDED, arms, takes off and flies it again."""
    target: Cell = (5, 8)
    failsafe = GcsFailsafe(FailsafeAction.RTL, timeout_s=10.0)
    async with (
        asyncio.timeout(BODY_S),
        fleet_of(tmp_path, TCP, "copter", 2.0, failsafe) as setup,
    ):
        truth = setup.truth
        async with ground_station(setup, SILENT) as (first, seen):
            await first.set_mode(FlightMode.GUIDED)
            await first.arm()
            await first.takeoff(3.0)
            await wait_position(first, lambda p: p.alt_rel_m >= 2.9)
            await first.goto(*setup.cell_centre(target), 3.0)
            await seen.wait(FAILSAFE_TEXT, timeout_s=10.0)
            await seen.wait("Land complete", timeout_s=10.0)
            await first.wait_for(Topic.STATUS, lambda s: not s.armed, 5.0)
            assert truth.cell == setup.mission.charger and truth.landed
            assert truth.mode == CopterMode.RTL
        async with ground_station(setup, BEATING) as (second, seen_again):
            await seen_again.wait(CLEARED_TEXT)
            await second.set_mode(FlightMode.GUIDED)
            await second.arm()
            await second.takeoff(3.0)
            await wait_position(second, lambda p: p.alt_rel_m >= 2.9)
            await arrive(setup, second, (0, 3), 3.0)
            assert truth.cell == (0, 3) and truth.airborne and truth.armed
