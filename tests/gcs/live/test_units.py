"""The live mission's pure parts: range readings -> cell states, and the energy estimate."""

from __future__ import annotations

import math
import random

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from core.cells import CellState, Direction
from gcs.live.energy import EnergyEstimator, EnergySettings, model_prior
from gcs.live.sensing import (
    Pose,
    Ray,
    neighbour_states,
    pose_at,
    rays_from_obstacles,
    rays_from_sensors,
    readings_from_map,
    still_between,
)
from sitl_mock.maps import make_map
from sitl_mock.ranging import sector_distances_m
from vehicles.modes import VehicleKind
from vehicles.telemetry import ObstacleDistances, RangeReading

FREE, WALL, UNKNOWN = CellState.FREE, CellState.OBSTACLE, CellState.UNKNOWN


def grid(rows: list[str]):  # type: ignore[no-untyped-def]
    obstacle = np.array([[ch == "#" for ch in row] for row in rows])
    return make_map(obstacle, ((len(rows) - 1, 1),))


def sensors(grid_map, cell, heading_deg, cell_m=1.0, max_m=10.0):  # type: ignore[no-untyped-def]
    """DISTANCE_SENSOR readings the mock would send from the centre of ``cell``."""
    north, east = -(cell[0] + 0.5) * cell_m, (cell[1] + 0.5) * cell_m
    ranges = sector_distances_m(grid_map, cell_m, north, east, heading_deg, 8, max_m)
    return {o: RangeReading(o, r, 0.1, max_m, o, 0) for o, r in enumerate(ranges)}


def obstacles(grid_map, cell, heading_deg, cell_m=1.0, max_m=10.0):  # type: ignore[no-untyped-def]
    north, east = -(cell[0] + 0.5) * cell_m, (cell[1] + 0.5) * cell_m
    ranges = sector_distances_m(grid_map, cell_m, north, east, heading_deg, 72, max_m)
    return ObstacleDistances(tuple(ranges), 5.0, 0.0, 0.1, max_m, 12, 0)


MAP = grid(
    [
        "#####",
        "#.#.#",
        "#...#",
        "##..#",
        "#####",
    ]
)
ORTHOGONAL = (Direction.N, Direction.E, Direction.S, Direction.W)


def states_from(grid_map, cell, heading, offset=(0.0, 0.0), sectors=72, cm=True, believed=None):  # type: ignore[no-untyped-def]
    """What the station makes of the mock's rays from ``offset`` (cells east, north) off
    the centre of ``cell``, ranges in whole centimetres as MAVLink carries them, when it
    believes the vehicle stood at ``believed`` (``offset`` unless given)."""
    north = -(cell[0] + 0.5) + offset[1]
    east = cell[1] + 0.5 + offset[0]
    ranges = sector_distances_m(grid_map, 1.0, north, east, heading, sectors, 10.0)
    if cm:
        ranges = [round(r, 2) for r in ranges]
    obs = ObstacleDistances(tuple(ranges), 360.0 / sectors, 0.0, 0.1, 10.0, 12, 0)
    origin = offset if believed is None else believed
    return neighbour_states(rays_from_obstacles(heading, obs, origin), 1.0)


@pytest.mark.parametrize("heading", [0.0, 90.0, 180.0, 270.0, 45.0])
def test_sensor_sectors_rotate_with_the_heading(heading: float) -> None:
    cell = (2, 2)
    states = neighbour_states(rays_from_sensors(heading, sensors(MAP, cell, heading)), 1.0)
    truth = readings_from_map(MAP, cell)
    assert all(s in (truth[d], UNKNOWN) for d, s in states.items())
    if heading % 90 == 0:
        for d in ORTHOGONAL:
            assert states[d] == truth[d], d


def test_a_diagonal_behind_a_side_wall_is_unknown() -> None:
    # From (2, 2): N (1, 2) is a wall, so the NE ray stops at the corner and cannot tell (1, 3).
    states = neighbour_states(rays_from_sensors(0.0, sensors(MAP, (2, 2), 0.0)), 1.0)
    assert states[Direction.N] == WALL
    assert states[Direction.NE] == UNKNOWN


def random_room(rng: random.Random) -> list[str]:
    """A walled 7x7 room whose inner 5x5 cells are a third walls, at random."""
    inner = ["#" + "".join(rng.choice("..#") for _ in range(5)) + "#" for _ in range(5)]
    return ["#######", *inner, "#######"]


def test_from_the_centre_the_narrow_sectors_settle_every_neighbour_seen() -> None:
    rng = random.Random(3)
    for _ in range(200):
        rows = random_room(rng)
        g = grid(rows)
        cell = (3, 3)
        if not g.is_free(cell):
            continue
        states = states_from(g, cell, rng.choice([0.0, 90.0, 180.0, 270.0]))
        truth = readings_from_map(g, cell)
        for d, s in states.items():
            assert s in (truth[d], UNKNOWN), (rows, d)
            if d in ORTHOGONAL:
                assert s == truth[d]
            elif any(truth[side] == FREE for side in _sides(d)):
                assert s == truth[d], (rows, d)  # seen through a free side neighbour


@settings(max_examples=300, deadline=None)
@given(
    seed=st.integers(0, 10_000),
    heading=st.floats(0.0, 360.0, exclude_max=True),
    east=st.floats(-0.48, 0.48),
    north=st.floats(-0.48, 0.48),
    sectors=st.sampled_from([8, 72]),
)
def test_from_anywhere_in_the_cell_no_neighbour_is_called_what_it_is_not(
    seed: int, heading: float, east: float, north: float, sectors: int
) -> None:
    """A vehicle stops anywhere inside its cell (ArduPilot Rover up to its WP_RADIUS short)
    and faces any way: what the rays say is the truth or UNKNOWN, never the opposite."""
    rows = random_room(random.Random(seed))
    g = grid(rows)
    cell = (3, 3)
    if not g.is_free(cell):
        return
    states = states_from(g, cell, heading, (east, north), sectors)
    truth = readings_from_map(g, cell)
    for d, s in states.items():
        assert s in (truth[d], UNKNOWN), (rows, heading, east, north, d)


@settings(max_examples=1000, deadline=None)
@given(
    seed=st.integers(0, 10_000),
    heading=st.floats(0.0, 360.0, exclude_max=True),
    east=st.floats(-0.45, 0.45),
    north=st.floats(-0.45, 0.45),
    error_east=st.floats(-0.03, 0.03),
    error_north=st.floats(-0.03, 0.03),
)
def test_a_place_known_to_a_few_centimetres_calls_no_wall_free(
    seed: int,
    heading: float,
    east: float,
    north: float,
    error_east: float,
    error_north: float,
) -> None:
    """The reported place is a few centimetres off where the ranges were taken (a report
    and the readings are not taken at the same instant): a ray that cuts a corner must
    not make a wall free, nor a free cell a wall."""
    rows = random_room(random.Random(seed))
    g = grid(rows)
    cell = (3, 3)
    if not g.is_free(cell):
        return
    believed = (east + error_east, north + error_north)
    states = states_from(g, cell, heading, (east, north), believed=believed)
    truth = readings_from_map(g, cell)
    for d, s in states.items():
        assert s in (truth[d], UNKNOWN), (rows, heading, east, north, d)


def test_a_reading_is_placed_between_the_poses_around_it() -> None:
    """Ranges are placed where the vehicle was when it took them, on the line between the
    positions reported before and after (a braking rover still creeps), the heading
    turning the short way round north; a vehicle that turned more than a couple of
    degrees in between did not hold its sensors still."""
    before, after = Pose(0.0, 0.0, 359.0, 1000), Pose(0.1, -0.2, 1.0, 1400)
    mid = pose_at(before, after, 1100)
    assert (mid.north_m, mid.east_m) == pytest.approx((0.025, -0.05))
    assert mid.heading_deg == pytest.approx(359.5)
    assert pose_at(before, after, 2000).north_m == pytest.approx(0.1)  # clamped
    assert still_between(before, after)
    assert not still_between(before, Pose(0.0, 0.0, 5.0, 1400))


def test_half_a_cell_off_the_centre_the_axes_are_still_settled() -> None:
    """Stopped half a cell short (the back of the cell) facing a wall two cells on: the
    wall next door is seen as a wall, the free cell as free, though from the centre the
    ranges would mean the opposite."""
    g = grid(["#####", "#.#.#", "#...#", "#...#", "#####"])
    states = states_from(g, (3, 2), 0.0, (0.0, -0.45))  # south half of (3, 2), facing north
    assert states[Direction.N] == FREE  # (2, 2)
    states = states_from(g, (2, 2), 0.0, (0.0, -0.45))
    assert states[Direction.N] == WALL  # (1, 2): met at 0.95 cells, a free cell's range


def _sides(d: Direction) -> tuple[Direction, Direction]:
    return (Direction((d.dr, 0)), Direction((0, d.dc)))


def test_cell_size_scales_the_geometry() -> None:
    rays = [Ray(0.0, 2.0, 10.0), Ray(180.0, 6.5, 10.0)]
    states = neighbour_states(rays, cell_size_m=4.0)
    assert states[Direction.N] == WALL and states[Direction.S] == FREE


def test_short_sensor_cannot_say_free() -> None:
    states = neighbour_states([Ray(0.0, 0.6, 0.6)], cell_size_m=1.0)
    assert states[Direction.N] == UNKNOWN


def test_other_orientations_are_ignored() -> None:
    reading = RangeReading(25, 0.2, 0.1, 10.0, 0, 0)  # MAV_SENSOR_ROTATION_PITCH_270 (down)
    assert rays_from_sensors(0.0, {25: reading}) == []


# -- energy -------------------------------------------------------------------------------


def drive(est: EnergyEstimator, rate: float, metres: float, start: float = 100.0) -> float:
    """Feed the estimator as telemetry would: whole percent, rounded up, every 0.5 m."""
    true = start
    for _ in range(int(metres / 0.5)):
        true -= rate * 0.5
        est.add(0.5, math.ceil(true))
    return true


def test_prior_rules_before_any_distance() -> None:
    est = EnergyEstimator(model_prior(VehicleKind.ROVER))
    est.add(0.0, 100.0)
    assert est.rate_pct_per_m == pytest.approx(model_prior(VehicleKind.ROVER))


def test_estimate_is_an_upper_bound_from_the_start() -> None:
    est = EnergyEstimator(0.05)
    est.add(0.0, 100.0)
    for metres in (6.0, 10.0, 20.0, 50.0, 120.0):
        est2 = EnergyEstimator(0.05)
        est2.add(0.0, 100.0)
        drive(est2, 0.4, metres)
        assert est2.rate_pct_per_m >= 0.4 - 1e-9, metres
        assert est2.estimate_pct_per_m >= 1.3 * 0.4 - 1e-9


def test_estimate_converges_with_margin() -> None:
    est = EnergyEstimator(0.1)
    est.add(0.0, 100.0)
    drive(est, 0.35, 200.0)
    assert len(est.windows) >= 3
    assert est.rate_pct_per_m == pytest.approx(0.35, rel=0.1)
    assert est.estimate_pct_per_m == pytest.approx(1.3 * est.rate_pct_per_m)


def test_charging_starts_a_new_discharge_and_keeps_windows() -> None:
    est = EnergyEstimator(0.1)
    est.add(0.0, 100.0)
    drive(est, 0.5, 60.0)
    windows = len(est.windows)
    est.add(0.0, 100.0)  # charged
    assert len(est.windows) == windows
    assert est.rate_pct_per_m == pytest.approx(0.5, rel=0.15)


def test_noise_and_sag_keep_it_pessimistic() -> None:
    rng = random.Random(1)
    est = EnergyEstimator(0.1, EnergySettings())
    est.add(0.0, 100.0)
    true = 100.0
    for step in range(300):
        true -= 0.4 * 0.5 * (1 + rng.uniform(-0.3, 0.3))
        if step == 100:
            true -= 10.0  # a sag
        est.add(0.5, math.ceil(true))
    assert est.estimate_pct_per_m >= 0.4


def hover(
    est: EnergyEstimator, true: float, rate_pct_s: float, seconds: float, *, paused: bool = True
) -> float:
    """A wait in the air: the charge falls with no metre moved (samples every 0.5 s);
    the estimator told so unless ``paused`` is False."""
    if paused:
        est.pause()
    for _ in range(int(seconds / 0.5)):
        true -= rate_pct_s * 0.5
        est.add(0.0, math.ceil(true))
    if paused:
        est.resume()
    return true


@pytest.mark.parametrize("waits", [2, 4, 8])
def test_waiting_is_not_counted_per_metre_and_the_estimate_stays_an_upper_bound(
    waits: int,
) -> None:
    """A copter held back between sweeps hovers; what it uses then depends on how long it
    is held, not on the metres it flies, and counted per metre it sent copters home
    early. The estimate stays above the true rate whatever the quantisation leaves."""
    moving_rate = 0.35
    plain, waiting = EnergyEstimator(0.05), EnergyEstimator(0.05)
    plain.add(0.0, 100.0)
    waiting.add(0.0, 100.0)
    drive(plain, moving_rate, 160.0)
    true = 100.0
    for leg in range(8):
        true = drive(waiting, moving_rate, 20.0, start=true)
        if leg % (8 // waits) == 0:
            true = hover(waiting, true, 0.05, 40.0)  # 2 % of the battery each time
    assert true < 100.0 - 160.0 * moving_rate - 2.0 * waits + 1e-9
    # Whole-percent reports leave up to one percent of each wait counted (never less
    # than was used moving): a fifth of a 5 % window at most.
    assert moving_rate <= waiting.rate_pct_per_m <= plain.rate_pct_per_m * 1.25
    # Unpaused, the same waits are charged to the metres flown.
    counted = EnergyEstimator(0.05)
    counted.add(0.0, 100.0)
    true = 100.0
    for leg in range(8):
        true = drive(counted, moving_rate, 20.0, start=true)
        if leg % (8 // waits) == 0:
            true = hover(counted, true, 0.05, 40.0, paused=False)
    assert counted.rate_pct_per_m > waiting.rate_pct_per_m


def test_a_charge_during_a_wait_leaves_out_only_what_was_used_after_it() -> None:
    """Charged on the pad while it waited, then hovering: what it used after the charge
    is the wait's, and is left out (one percent of it stays counted)."""

    def fly(paused: bool) -> EnergyEstimator:
        est = EnergyEstimator(0.05)
        est.add(0.0, 50.0)
        if paused:
            est.pause()
        for pct in (100.0, 99.0, 98.0, 97.0):  # charged, then 3 % hovering
            est.add(0.0, pct)
        if paused:
            est.resume()
        drive(est, 0.4, 10.0, start=97.0)
        return est

    waited, counted = fly(paused=True), fly(paused=False)
    assert 0.4 <= waited.rate_pct_per_m < counted.rate_pct_per_m


def test_settings_are_checked() -> None:
    with pytest.raises(ValueError):
        EnergySettings(margin=0.9)
    with pytest.raises(ValueError):
        EnergyEstimator(0.0)


def test_percentile_interpolates_and_bounds() -> None:
    from gcs.percentile import percentile

    values = [float(x) for x in range(1, 101)]
    assert percentile(values, 50) == 50.5
    assert percentile(values, 99) == 99.01
    assert (percentile(values, 0), percentile(values, 100)) == (1.0, 100.0)
    assert percentile([7.0], 99) == 7.0
    assert percentile([], 50) != percentile([], 50)  # nan
