"""The mock behaves as ArduPilot's own SITL was seen to (``sitl_mock.drive`` and start-up):
targets reached within WP_RADIUS and stopped short, paths restarted on each new target,
pivots and turning circles, coasting in HOLD, reversing, a battery that never rises on
the pad until MAV_CMD_BATTERY_RESET, and no position until the GPS fix.

The state machine is stepped by hand; no network, no clock.
"""

from __future__ import annotations

import math
from itertools import pairwise

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sitl_mock.battery import BatterySettings
from sitl_mock.drive import Drive, DriveSettings, Steering
from sitl_mock.events import ItemReached
from sitl_mock.modes import RoverMode
from sitl_mock.vehicle import CommandRefused
from tests.sitl_mock.test_mock_vehicle import centre, make_vehicle, run, world_of

pytestmark = pytest.mark.timeout(60)

OPEN = ["." * 16, "." * 16, "...C" + "." * 12, "." * 16, "." * 16, "." * 16]


def driving_rover(steering: Steering, wp_radius_m: float = 2.0, cell_size_m: float = 2.0):
    world = world_of(OPEN, cell_size_m)
    drive = DriveSettings(steering=steering, wp_radius_m=wp_radius_m)
    v, events = make_vehicle(world, drive=drive)
    v.set_mode(RoverMode.GUIDED)
    v.arm()
    return world, v, events


def reached(events: list) -> list[int]:
    return [e.seq for e in events if isinstance(e, ItemReached)]


@pytest.mark.parametrize("steering", list(Steering))
def test_guided_target_reached_within_radius_with_item_reached_seq_0(steering: Steering) -> None:
    world, v, events = driving_rover(steering)
    v.goto(*centre(world, (2, 5)))  # two cells east, the rover faces north: a turn first
    run(v, 20.0)
    assert reached(events) == [0], "MISSION_ITEM_REACHED seq 0, once, as ArduPilot Rover"
    assert v.drive is not None and v.drive.stopped
    offset = math.dist((v.north_m, v.east_m), centre(world, (2, 5)))
    assert offset <= 2.0  # within WP_RADIUS, not necessarily on the point
    assert v.guided_target == centre(world, (2, 5))  # still reported after it is reached


def test_large_radius_stops_short_of_the_target() -> None:
    """With ArduPilot's stock WP_RADIUS (3 m) the rover stops where it is when its moving
    target point arrives: short of the target, as SITL did (0.58-0.75 m)."""
    world, v, events = driving_rover(Steering.SKID, wp_radius_m=3.0)
    target = centre(world, (2, 7))  # eight metres straight ahead (east after the pivot)
    v.goto(*target)
    run(v, 30.0)
    assert reached(events) == [0]
    short = math.dist((v.north_m, v.east_m), target)
    assert 0.05 < short < 3.0


def test_a_skid_rover_pivots_in_place_before_it_drives() -> None:
    world, v, _ = driving_rover(Steering.SKID)
    start = (v.north_m, v.east_m)
    v.goto(*centre(world, (2, 0)))  # due west; it faces north
    run(v, 0.8)
    assert math.dist(start, (v.north_m, v.east_m)) < 0.05, "turning on the spot first"
    assert v.heading_deg != 0.0
    run(v, 20.0)
    assert v.cell == (2, 0)


def test_a_car_turns_no_tighter_than_its_circle() -> None:
    world, v, _ = driving_rover(Steering.CAR)
    v.goto(*centre(world, (2, 5)))
    headings = []
    positions = []
    for _ in range(40):
        run(v, 0.1)
        headings.append(v.heading_deg)
        positions.append((v.north_m, v.east_m))
    radius = DriveSettings().turn_radius_m
    for (h0, h1), (p0, p1) in zip(pairwise(headings), pairwise(positions), strict=True):
        turned = math.radians(abs((h1 - h0 + 180) % 360 - 180))
        assert turned <= math.dist(p0, p1) / radius + 1e-6


def test_a_new_target_restarts_the_path_from_the_stopping_point() -> None:
    drive = Drive(DriveSettings())
    drive.speed_m_s = 2.0
    drive.go(0.0, 0.0, 0.0, (10.0, 0.0))
    assert drive.leg is not None
    assert drive.leg.origin == pytest.approx((2.0, 0.0))  # 2 m/s at 1 m/s2: 2 m to stop


def test_hold_while_moving_coasts_on() -> None:
    world, v, _ = driving_rover(Steering.SKID)
    v.goto(*centre(world, (2, 7)))
    run(v, 4.0)
    assert v.drive is not None
    speed = v.drive.speed_m_s
    assert speed > 0.5
    here = (v.north_m, v.east_m)
    v.set_mode(RoverMode.HOLD)
    run(v, 15.0)
    rolled = math.dist(here, (v.north_m, v.east_m))
    assert rolled == pytest.approx(speed**2 / (2 * DriveSettings().coast_m_s2), rel=0.15)


def test_reversing_drives_the_tail_first() -> None:
    world, v, _ = driving_rover(Steering.CAR)
    v.set_reverse(True)
    v.goto(*centre(world, (4, 3)))  # behind it: it faces north
    run(v, 15.0)
    assert v.cell == (4, 3)
    assert abs((v.heading_deg + 180) % 360 - 180) < 20  # still facing north


def test_reverse_is_refused_by_a_vehicle_that_does_not_drive() -> None:
    world = world_of(OPEN)
    v, _ = make_vehicle(world)
    with pytest.raises(CommandRefused):
        v.set_reverse(True)


@settings(max_examples=40, deadline=None)
@given(
    steering=st.sampled_from(list(Steering)),
    row=st.integers(0, 5),
    col=st.integers(0, 15),
)
def test_every_open_cell_is_reached_within_radius(steering: Steering, row: int, col: int) -> None:
    world, v, events = driving_rover(steering)
    target = centre(world, (row, col))
    v.goto(*target)
    run(v, 40.0)
    assert reached(events) == [0]
    assert math.dist((v.north_m, v.east_m), target) <= 2.0 + 1e-6


# ------------------------------------------------------------- battery and start-up


def test_the_battery_does_not_rise_on_the_pad_until_reset() -> None:
    world = world_of(OPEN)
    v, _ = make_vehicle(world, battery=BatterySettings(start_pct=40.0))
    run(v, 30.0)
    assert v.battery.remaining_pct == pytest.approx(40.0)
    v.battery.reset(100.0)
    assert v.battery.remaining_pct == 100.0
    assert v.battery.consumed_mah == 0.0


def test_a_self_charging_pad_stays_an_option() -> None:
    world = world_of(OPEN)
    pack = BatterySettings(start_pct=40.0, pad_charging=True, charge_rate_pct_s=2.0)
    v, _ = make_vehicle(world, battery=pack)
    run(v, 10.0)
    assert v.battery.remaining_pct == pytest.approx(60.0, abs=0.5)


def test_no_position_and_no_arming_before_the_fix() -> None:
    world = world_of(OPEN)
    v, _ = make_vehicle(world, startup_delay_s=5.0)
    assert v.reported_lat_lon_deg == (0.0, 0.0)
    with pytest.raises(CommandRefused, match="Need Position Estimate"):
        v.arm()
    run(v, 5.2)
    assert v.reported_lat_lon_deg == v.lat_lon_deg
    v.set_mode(RoverMode.GUIDED)
    v.arm()
    assert v.armed
