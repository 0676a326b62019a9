"""Unit tests of the mock vehicles' physics: battery, range sensing, moves, modes, missions.

No network and no clock: the state machine is stepped by hand.
"""

from __future__ import annotations

import math
import random
from typing import TypedDict

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from core.cells import Cell
from core.geo import GeoFrame
from sitl_mock.battery import Battery, BatterySag, BatterySettings, ChargeState
from sitl_mock.connection import ConnectionStringError, mirror, parse_mock_side
from sitl_mock.events import ItemReached, StatusText, VehicleDied, VehicleEvent
from sitl_mock.gridmap import GridMap
from sitl_mock.modes import CopterMode, RoverMode, VehicleKind
from sitl_mock.ranging import ray_distance_m
from sitl_mock.vehicle import CommandRefused, Vehicle, VehicleSettings
from sitl_mock.world import World
from vehicles.mission_items import MissionItem

pytestmark = pytest.mark.timeout(30)

DT = 0.1


def grid(rows: list[str]) -> GridMap:
    """'#' wall, '.' free, 'C' charging pad."""
    obstacle = np.array([[ch == "#" for ch in row] for row in rows], dtype=bool)
    pads = tuple((r, c) for r, row in enumerate(rows) for c, ch in enumerate(row) if ch == "C")
    return GridMap(obstacle=obstacle, pads=pads)


def world_of(rows: list[str], cell_size_m: float = 1.0) -> World:
    return World(grid(rows), GeoFrame(47.0, 8.0, 400.0, cell_size_m))


def make_vehicle(
    world: World,
    vid: int = 1,
    kind: VehicleKind = VehicleKind.ROVER,
    start: Cell | None = None,
    battery: BatterySettings | None = None,
    **settings: object,
) -> tuple[Vehicle, list[VehicleEvent]]:
    v = Vehicle(
        vid,
        VehicleSettings(kind, start_cell=start, **settings),  # type: ignore[arg-type]
        battery or BatterySettings(),
        world,
        random.Random(vid),
    )
    events: list[VehicleEvent] = []
    v.subscribe(events.append)
    return v, events


def texts(events: list[VehicleEvent]) -> list[str]:
    return [e.text for e in events if isinstance(e, StatusText)]


def run(v: Vehicle | list[Vehicle], seconds: float) -> None:
    vehicles = v if isinstance(v, list) else [v]
    for _ in range(round(seconds / DT)):
        for each in vehicles:
            each.step(DT)


def centre(world: World, cell: Cell) -> tuple[float, float]:
    return world.geo.cell_centre_local(cell)


def guided_rover(world: World, **kw: object) -> tuple[Vehicle, list[VehicleEvent]]:
    v, events = make_vehicle(world, **kw)  # type: ignore[arg-type]
    v.set_mode(RoverMode.GUIDED)
    v.arm()
    return v, events


# ---------------------------------------------------------------------- battery


def test_battery_drains_with_distance_moved() -> None:
    world = world_of(["C........."])
    v, _ = guided_rover(world, battery=BatterySettings(energy_per_m_pct=0.5))
    v.goto(*centre(world, (0, 8)))
    run(v, 10.0)
    assert v.cell == (0, 8)
    assert v.battery.remaining_pct == pytest.approx(100.0 - 8 * 0.5, abs=1e-6)
    assert v.battery.consumed_mah == pytest.approx(4.0 / 100 * 5000.0, abs=1e-3)


def test_battery_does_not_drain_standing_still_and_voltage_falls_with_charge() -> None:
    b = Battery(BatterySettings())
    full_v = b.voltage_v
    b.step(10.0, moved_m=0.0, airborne=False, can_charge=False, vehicle_time_s=10.0)
    assert b.remaining_pct == 100.0
    assert full_v == pytest.approx(16.8)
    b.step(1.0, moved_m=150.0, airborne=False, can_charge=False, vehicle_time_s=11.0)
    assert b.remaining_pct == pytest.approx(85.0)
    assert 13.2 < b.voltage_v < full_v
    assert b.current_a > 0


def test_copter_drains_while_hovering() -> None:
    b = Battery(BatterySettings(hover_drain_pct_s=0.2))
    b.step(10.0, moved_m=0.0, airborne=True, can_charge=False, vehicle_time_s=10.0)
    assert b.remaining_pct == pytest.approx(98.0)


def test_a_self_charging_pack_charges_only_disarmed_on_a_pad() -> None:
    world = world_of(["C...."])
    settings_ = BatterySettings(start_pct=50.0, charge_rate_pct_s=2.0, pad_charging=True)
    v, _ = make_vehicle(world, battery=settings_)
    run(v, 5.0)
    assert v.battery.remaining_pct == pytest.approx(60.0)
    assert v.battery.charge_state is ChargeState.CHARGING
    v.set_mode(RoverMode.GUIDED)
    v.arm()
    run(v, 5.0)  # armed on the pad: no charging
    assert v.battery.remaining_pct == pytest.approx(60.0)
    v.goto(*centre(world, (0, 2)))
    run(v, 3.0)
    v.disarm()
    level = v.battery.remaining_pct
    run(v, 5.0)  # disarmed off the pad: no charging
    assert v.battery.remaining_pct == pytest.approx(level)


class Thresholds(TypedDict):
    low_pct: float
    critical_pct: float
    emergency_pct: float


#: Battery failsafe levels as a user sets them (ArduPilot's defaults have none).
THRESHOLDS = Thresholds(low_pct=30.0, critical_pct=15.0, emergency_pct=5.0)


def test_battery_charge_states() -> None:
    b = Battery(BatterySettings(start_pct=31.0, energy_per_m_pct=1.0, **THRESHOLDS))
    assert b.charge_state is ChargeState.OK
    b.step(1.0, moved_m=2.0, airborne=False, can_charge=False, vehicle_time_s=1.0)
    assert b.charge_state is ChargeState.LOW
    b.step(1.0, moved_m=15.0, airborne=False, can_charge=False, vehicle_time_s=2.0)
    assert b.charge_state is ChargeState.CRITICAL
    b.step(1.0, moved_m=10.0, airborne=False, can_charge=False, vehicle_time_s=3.0)
    assert b.charge_state is ChargeState.EMERGENCY


def test_battery_has_no_failsafe_levels_by_default() -> None:
    b = Battery(BatterySettings(start_pct=10.0, energy_per_m_pct=1.0))
    b.step(1.0, moved_m=9.0, airborne=False, can_charge=False, vehicle_time_s=1.0)
    assert b.charge_state is ChargeState.OK


def test_battery_failsafe_is_announced_as_ardupilot_does() -> None:
    """ArduPilot says "Battery 1 is low|critical <V> used <mAh>" once per level, as a
    WARNING; a ground station must not take it for an error."""
    world = world_of(["C" + "." * 40])
    battery = BatterySettings(start_pct=35.0, energy_per_m_pct=1.0, **THRESHOLDS)
    v, events = guided_rover(world, battery=battery)
    v.goto(*centre(world, (0, 40)))
    run(v, 60.0)
    said = [e for e in events if isinstance(e, StatusText)]
    warnings = [e for e in said if e.text.startswith("Battery 1 is")]
    assert [w.text.split()[3] for w in warnings] == ["low", "critical"]
    assert all(w.severity == mavlink.MAV_SEVERITY_WARNING for w in warnings)
    assert all(w.text.endswith(" mAh") and "V used " in w.text for w in warnings)


def test_battery_noise_is_seeded_and_bounded() -> None:
    def drain(seed: int) -> float:
        b = Battery(BatterySettings(noise_fraction=0.2), random.Random(seed))
        for t in range(100):
            b.step(1.0, moved_m=1.0, airborne=False, can_charge=False, vehicle_time_s=t)
        return 100.0 - b.remaining_pct

    assert drain(3) == drain(3)
    assert drain(3) != drain(4)
    assert 0.8 * 10.0 <= drain(3) <= 1.2 * 10.0


def test_sag_drops_charge_at_its_time() -> None:
    world = world_of(["C...."])
    sag = BatterySettings(sags=(BatterySag(at_s=2.0, drop_pct=30.0),))
    v, events = make_vehicle(world, battery=sag)
    v.set_mode(RoverMode.GUIDED)
    v.arm()
    run(v, 1.9)
    assert v.battery.remaining_pct == pytest.approx(100.0)
    run(v, 0.3)
    assert v.battery.remaining_pct == pytest.approx(70.0)
    assert any("sag" in t for t in texts(events))


def test_empty_battery_kills_the_vehicle_for_good() -> None:
    world = world_of(["C........."])
    v, events = guided_rover(world, battery=BatterySettings(start_pct=2.0, energy_per_m_pct=1.0))
    v.goto(*centre(world, (0, 9)))
    run(v, 10.0)
    assert v.dead and not v.armed
    assert v.battery.remaining_pct == 0.0
    assert any(isinstance(e, VehicleDied) for e in events)
    assert "Battery exhausted: vehicle lost" in texts(events)
    where = (v.north_m, v.east_m)
    run(v, 5.0)
    assert (v.north_m, v.east_m) == where
    assert v.cell == world.cell_of(1)


# ---------------------------------------------------------------------- range sensing


def _reference_range(
    world: World, north: float, east: float, bearing_deg: float, max_m: float
) -> float:
    """Independent reference: ray against every wall square (closed), slab method."""
    gm = world.map
    cs = world.cell_size_m
    rows, cols = gm.shape
    x0, y0 = east / cs, -north / cs  # x = column, y = row, in cells
    dx, dy = math.sin(math.radians(bearing_deg)), -math.cos(math.radians(bearing_deg))
    here = (math.floor(y0), math.floor(x0))
    best = max_m / cs
    for r in range(-1, rows + 1):
        for c in range(-1, cols + 1):
            if (r, c) == here or gm.is_free((r, c)):
                continue
            t_lo, t_hi = -math.inf, math.inf
            for p, d, lo in ((x0, dx, c), (y0, dy, r)):
                if abs(d) < 1e-12:
                    if not lo <= p <= lo + 1:
                        t_lo, t_hi = 1.0, 0.0
                    continue
                a, b = (lo - p) / d, (lo + 1 - p) / d
                t_lo, t_hi = max(t_lo, min(a, b)), min(t_hi, max(a, b))
            if t_lo <= t_hi + 1e-9 and t_hi >= 0:
                best = min(best, max(t_lo, 0.0))
    return best * cs


RANGE_MAP = [
    "..........#.",
    ".##....#....",
    ".#..C.......",
    "......#.#...",
    "...#........",
    "..........##",
]


@settings(max_examples=300, deadline=None)
@given(
    cell=st.sampled_from(
        [(r, c) for r, row in enumerate(RANGE_MAP) for c, ch in enumerate(row) if ch != "#"]
    ),
    # Headings on a 0.01-degree grid: a ray either passes exactly through a cell corner
    # (where the corner rule decides) or clearly misses it, never by a rounding error.
    heading=st.integers(0, 35999).map(lambda centi: centi / 100.0),
    cell_size=st.sampled_from([1.0, 2.5]),
)
def test_ranges_match_the_ground_truth_for_every_heading(
    cell: Cell, heading: float, cell_size: float
) -> None:
    world = world_of(RANGE_MAP, cell_size)
    north, east = centre(world, cell)
    max_m = 6.0 * cell_size
    for k in range(8):
        bearing = (heading + 45.0 * k) % 360.0
        got = world.range_m(north, east, bearing, max_m)
        want = _reference_range(world, north, east, bearing, max_m)
        assert got == pytest.approx(want, abs=1e-6), (cell, bearing)


def test_range_examples() -> None:
    world = world_of(["#....", ".....", "..#..", "....."])
    n, e = centre(world, (2, 0))
    assert world.range_m(n, e, 90.0, 10.0) == pytest.approx(1.5)  # wall at column 2
    assert world.range_m(n, e, 270.0, 10.0) == pytest.approx(0.5)  # map edge
    assert world.range_m(n, e, 0.0, 10.0) == pytest.approx(1.5)  # wall at (0, 0)
    assert world.range_m(n, e, 0.0, 1.0) == pytest.approx(1.0)  # capped
    assert ray_distance_m(world.map, 1.0, n, e, 180.0, 10.0) == pytest.approx(1.5)  # bottom edge


# ---------------------------------------------------------------------- moves


def test_move_into_an_obstacle_is_refused() -> None:
    world = world_of(["C..#.."])
    v, events = guided_rover(world)
    v.goto(*centre(world, (0, 5)))
    run(v, 6.0)
    assert v.cell == (0, 2)
    assert (v.north_m, v.east_m) == pytest.approx(centre(world, (0, 2)))
    assert any("Move refused" in t and "(0, 3)" in t and "obstacle" in t for t in texts(events))
    assert v.stopped_by_refusal


def test_move_outside_the_map_is_refused() -> None:
    world = world_of(["C.."])
    v, events = guided_rover(world)
    v.goto(*centre(world, (0, 5)))
    run(v, 5.0)
    assert v.cell == (0, 2)
    assert any("outside the map" in t for t in texts(events))


def test_diagonal_move_does_not_cut_a_wall_corner() -> None:
    world = world_of(["C#", ".."])
    v, events = guided_rover(world)
    v.goto(*centre(world, (1, 1)))
    run(v, 3.0)
    assert v.cell == (0, 0)
    assert any("Move refused" in t for t in texts(events))


def test_move_into_a_cell_held_by_another_vehicle_is_refused() -> None:
    world = world_of(["C....."])
    parked, _ = make_vehicle(world, vid=2, start=(0, 3))
    v, events = guided_rover(world, yield_timeout_s=1.0)
    v.goto(*centre(world, (0, 5)))
    run([v, parked], 6.0)
    assert v.cell == (0, 2)
    assert (v.north_m, v.east_m) == pytest.approx(centre(world, (0, 2)))
    assert any("held by vehicle 2" in t for t in texts(events))
    assert world.holder((0, 3)) == 2


def test_following_a_moving_vehicle_waits_instead_of_refusing() -> None:
    world = world_of(["C......"])
    lead, _ = guided_rover(world, vid=1, start=(0, 2))
    follower, events = guided_rover(world, vid=2, start=(0, 1))
    lead.goto(*centre(world, (0, 6)))
    follower.goto(*centre(world, (0, 5)))
    run([follower, lead], 6.0)  # the follower steps first, into the lead's cell
    assert (lead.cell, follower.cell) == ((0, 6), (0, 5))
    assert not any("Move refused" in t for t in texts(events))


def test_the_pad_is_a_depot_for_the_whole_fleet() -> None:
    world = world_of(["..C.."])
    a, _ = make_vehicle(world, vid=1)
    b, _ = guided_rover(world, vid=2, start=(0, 4))
    assert a.cell == (0, 2)
    b.goto(*centre(world, (0, 2)))
    run([a, b], 3.0)
    assert b.cell == (0, 2) == a.cell


# ---------------------------------------------------------------------- modes and commands


def test_arming_refused_in_rtl_and_during_startup() -> None:
    world = world_of(["C..."])
    v, _ = make_vehicle(world, startup_delay_s=2.0)
    with pytest.raises(CommandRefused, match="Need Position Estimate"):
        v.arm()
    with pytest.raises(CommandRefused, match="requires position"):
        v.set_mode(RoverMode.GUIDED)
    run(v, 2.1)
    v.set_mode(RoverMode.RTL)
    with pytest.raises(CommandRefused, match="not armable"):
        v.arm()
    v.set_mode(RoverMode.HOLD)
    v.arm()
    assert v.armed


def test_rover_rtl_drives_home_and_stops() -> None:
    world = world_of(["C...."])
    v, events = guided_rover(world)
    v.goto(*centre(world, (0, 4)))
    run(v, 3.0)
    v.return_to_launch()
    run(v, 3.0)
    assert v.cell == (0, 0)
    assert v.mode == RoverMode.RTL
    assert "Reached destination" in texts(events)


def _item(
    seq: int, command: int, lat: float = 0.0, lon: float = 0.0, z: float = 0.0
) -> MissionItem:
    return MissionItem(
        seq,
        mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
        command,
        0,
        1,
        0.0,
        0.0,
        0.0,
        0.0,
        round(lat * 1e7),
        round(lon * 1e7),
        z,
    )


def _waypoints(world: World, cells: list[Cell], z: float = 0.0) -> list[MissionItem]:
    home = world.geo.cell_centre(world.map.charger)
    items = [_item(0, mavlink.MAV_CMD_NAV_WAYPOINT, *home)]
    for i, cell in enumerate(cells, start=1):
        items.append(_item(i, mavlink.MAV_CMD_NAV_WAYPOINT, *world.geo.cell_centre(cell), z=z))
    return items


def test_rover_auto_mission_reaches_every_waypoint_then_holds() -> None:
    world = world_of(["C...", "....", "...."])
    v, events = make_vehicle(world)
    v.replace_mission(_waypoints(world, [(0, 3), (2, 3), (2, 0)]))
    v.arm()
    v.set_mode(RoverMode.AUTO)
    run(v, 10.0)
    assert v.cell == (2, 0)
    assert [e.seq for e in events if isinstance(e, ItemReached)] == [1, 2, 3]
    assert "Reached waypoint #2" in texts(events)
    assert "Mission Complete" in texts(events)
    assert v.mode == RoverMode.HOLD
    assert v.mission_state == mavlink.MISSION_STATE_COMPLETE


def test_copter_takes_off_flies_and_lands_on_rtl() -> None:
    world = world_of(["C...", "...."])
    v, events = make_vehicle(world, kind=VehicleKind.COPTER, battery=BatterySettings())
    v.set_mode(CopterMode.GUIDED)
    v.arm()
    with pytest.raises(CommandRefused):
        v.goto(*centre(world, (1, 3)))  # not flying yet
    v.takeoff(5.0)
    run(v, 3.0)
    assert v.alt_m == pytest.approx(5.0)
    with pytest.raises(CommandRefused):
        v.disarm()
    v.goto(*centre(world, (1, 3)))
    run(v, 3.0)
    assert v.cell == (1, 3)
    drained = 100.0 - v.battery.remaining_pct
    assert drained > 0
    v.return_to_launch()
    run(v, 10.0)
    assert v.cell == (0, 0) and v.landed and not v.armed
    assert "Land complete" in texts(events)
    with pytest.raises(CommandRefused, match="not armable"):
        v.arm()


def test_copter_auto_disarms_when_left_on_the_ground() -> None:
    world = world_of(["C..."])
    v, _ = make_vehicle(world, kind=VehicleKind.COPTER, copter_auto_disarm_s=3.0)
    v.set_mode(CopterMode.GUIDED)
    v.arm()
    run(v, 3.5)
    assert not v.armed


def test_connection_strings_mirror() -> None:
    assert mirror("udpin:127.0.0.1:14550") == "udpout:127.0.0.1:14550"
    assert mirror("udpout:127.0.0.1:14551") == "udpin:127.0.0.1:14551"
    assert mirror("tcp:127.0.0.1:5760") == "tcpin:127.0.0.1:5760"
    assert mirror("udpin://0.0.0.0:14540") == "udpout:127.0.0.1:14540"
    assert parse_mock_side("tcpin:localhost:5760").port == 5760
    with pytest.raises(ConnectionStringError, match="loopback"):
        parse_mock_side("udpout:192.168.1.10:14550")
    assert parse_mock_side("udpout:192.168.1.10:14550", allow_non_loopback=True).port == 14550
    serial = parse_mock_side("serial:///dev/ttyUSB0:115200")
    assert (serial.host, serial.baud) == ("/dev/ttyUSB0", 115200)
    assert parse_mock_side("/dev/ttyACM0,57600").host == "/dev/ttyACM0"
    with pytest.raises(ConnectionStringError, match="far end is another device"):
        mirror("serial:/dev/ttyUSB0:57600")
