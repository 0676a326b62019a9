"""The pilot against a mock that drives as ArduPilot Rover does (``sitl_mock.drive``):
arrival judged inside the cell and stopped, a target sent once and again only when the
vehicle shows it lost it, a rover that stopped short approached again, parking that
waits out the roll and brings the rover back onto the pad, and the safe state.

Each test links to one mock vehicle on loopback (``tests.vehicles.test_link_vs_mock.linked``)
and checks the pilot against the mock's ground truth.
"""

from __future__ import annotations

import asyncio
import dataclasses
import math
from collections.abc import Callable
from typing import Any

import pytest
from pymavlink.dialects.v20 import common as mavlink

from core.cells import Cell
from core.clocks import ScaledClock
from core.geo import GeoFrame
from gcs.live.pilot import CAR_BACK_UP_CELLS, CAR_TIGHT_BACK_UP_CELLS, MoveFailed, Pilot
from gcs.mission import Mission
from sitl_mock.drive import DriveSettings, Steering
from sitl_mock.modes import Behaviour
from tests.vehicles.test_link_vs_mock import BODY_S, SPEEDUP, UDP, Pair, linked, mission  # noqa: F401
from vehicles.modes import VehicleKind
from vehicles.telemetry import Position

pytestmark = pytest.mark.timeout(40)


def driving(pair_config: Any, **drive: Any) -> dict[str, Any]:
    return {"vehicle": dataclasses.replace(pair_config, drive=DriveSettings(**drive))}


def count_targets(pair: Pair, drop: Callable[[int], bool] = lambda _n: False) -> list[int]:
    """Count the guided targets the mock receives; ``drop(n)`` loses the n-th (from 1)."""
    endpoint = pair.endpoint
    handler = endpoint._handlers["SET_POSITION_TARGET_GLOBAL_INT"]
    received = [0]

    def counting(peer: Any, msg: Any) -> None:
        received[0] += 1
        if not drop(received[0]):
            handler(peer, msg)

    endpoint._handlers["SET_POSITION_TARGET_GLOBAL_INT"] = counting
    return received


def pilot_of(pair: Pair, mission: Mission, *, car: bool = False) -> Pilot:  # noqa: F811
    speed = mission.fleet[0].speed_m_s
    return Pilot(pair.link, VehicleKind.ROVER, mission.geo, ScaledClock(SPEEDUP), speed, car=car)


def offset_m(pair: Pair, mission: Mission, cell: Cell) -> float:  # noqa: F811
    centre = mission.geo.cell_centre_local(cell)
    return math.dist(centre, (pair.truth.north_m, pair.truth.east_m))


@pytest.fixture
def base_vehicle(mission: Mission) -> Any:  # noqa: F811
    from gcs.mock_fleet import mock_fleet_configs

    return mock_fleet_configs(mission)[0].vehicle


@pytest.mark.parametrize("steering", list(Steering))
async def test_moves_arrive_inside_the_cell_with_one_target_each(
    mission: Mission,  # noqa: F811
    base_vehicle: Any,
    steering: Steering,
) -> None:
    changes = driving(base_vehicle, steering=steering, wp_radius_m=2.0)
    async with asyncio.timeout(BODY_S), linked(mission, UDP, **changes) as pair:
        pilot = pilot_of(pair, mission, car=steering is Steering.CAR)
        await pilot.learn_limits()
        assert pilot.limits.acceptance_radius_m == pytest.approx(2.0)
        sent = count_targets(pair)
        await pilot.underway()
        # East along the free top row, then down the free column 1.
        route: list[Cell] = [(0, 1), (0, 2), (0, 3), (1, 3), (1, 2)]
        for cell in route:
            before = sent[0]
            await pilot.goto(cell)
            assert pair.truth.cell == cell
            assert offset_m(pair, mission, cell) <= pilot.tolerance_m
            if steering is Steering.SKID:
                assert sent[0] - before == 1, "one target per move, never resent on a timer"


async def test_a_lost_target_is_sent_again(mission: Mission, base_vehicle: Any) -> None:  # noqa: F811
    async with asyncio.timeout(BODY_S), linked(mission, UDP, **driving(base_vehicle)) as pair:
        pilot = pilot_of(pair, mission)
        await pilot.underway()
        sent = count_targets(pair, drop=lambda n: n == 1)
        await pilot.goto((0, 3))
        assert pair.truth.cell == (0, 3)
        assert sent[0] == 2


async def test_a_rover_that_stops_short_outside_the_cell_is_sent_again(
    mission: Mission,  # noqa: F811
    base_vehicle: Any,
) -> None:
    """WP_RADIUS far larger than a cell (ArduPilot's rover.parm: 3 m): the rover may
    say it reached the target outside the cell; the pilot sends it again, and the
    move ends only inside the cell."""
    changes = driving(base_vehicle, wp_radius_m=6.0, track_gain_1_s=0.05)
    async with asyncio.timeout(BODY_S), linked(mission, UDP, **changes) as pair:
        pilot = pilot_of(pair, mission)
        await pilot.underway()
        sent = count_targets(pair)
        await pilot.goto((0, 6))
        assert offset_m(pair, mission, (0, 6)) <= pilot.tolerance_m
        assert sent[0] >= 2, "stopped short at least once"


async def test_a_move_that_cannot_succeed_fails_saying_why(
    mission: Mission,  # noqa: F811
    base_vehicle: Any,
) -> None:
    async with asyncio.timeout(BODY_S), linked(mission, UDP, **driving(base_vehicle)) as pair:
        pilot = pilot_of(pair, mission)
        await pilot.underway()
        count_targets(pair, drop=lambda _n: True)  # the vehicle never gets one
        with pytest.raises(MoveFailed, match=r"not at cell \(0, 3\) after 4 tries.*stood still"):
            await pilot.goto((0, 3))


async def test_parking_waits_out_the_roll_and_comes_back_onto_the_pad(
    mission: Mission,  # noqa: F811
    base_vehicle: Any,
) -> None:
    """Set to HOLD at speed a rover rolls on (ArduPilot: 1.36 m from 0.76 m/s); parking
    waits until it has stopped, brings it back onto the pad and only then disarms."""
    changes = driving(base_vehicle, coast_m_s2=0.1)
    async with asyncio.timeout(BODY_S), linked(mission, UDP, **changes) as pair:
        pilot = pilot_of(pair, mission)
        await pilot.underway()
        await pilot.goto((0, 4))
        await pilot.link.goto(*mission.geo.cell_centre((0, 0)), 0.0)  # back west, fast
        await pilot.wait_position(lambda p: math.hypot(p.vn_m_s, p.ve_m_s) > 1.5, 30.0)
        await pilot.park((0, 2))
        assert offset_m(pair, mission, (0, 2)) <= pilot.tolerance_m
        assert not pair.truth.armed
        assert pair.truth.drive is not None and pair.truth.drive.speed_m_s < 0.2


async def test_the_safe_state_of_a_rover_is_stopped_and_disarmed(
    mission: Mission,  # noqa: F811
    base_vehicle: Any,
) -> None:
    async with asyncio.timeout(BODY_S), linked(mission, UDP, **driving(base_vehicle)) as pair:
        pilot = pilot_of(pair, mission)
        await pilot.underway()
        await pilot.link.goto(*mission.geo.cell_centre((0, 8)), 0.0)
        await pilot.wait_position(lambda p: math.hypot(p.vn_m_s, p.ve_m_s) > 1.0, 30.0)
        said = await pilot.make_safe()
        assert said == "stopped (HOLD) and disarmed"
        assert pair.truth.behaviour is Behaviour.HOLD
        assert not pair.truth.armed
        assert pair.truth.drive is not None and pair.truth.drive.speed_m_s < 0.2


class _Router:
    def on(self, _name: str, _handler: Callable[[Any], None]) -> None:
        pass


class _Link:
    router = _Router()


#: A car at the centre of cell (4, 3), nose north (heading 0), south (180) or east (90).
@pytest.mark.parametrize(
    ("heading", "target", "walls", "cells"),
    [
        (0.0, (4, 4), set(), CAR_BACK_UP_CELLS),  # room all round: the long back-up
        (0.0, (4, 4), {(5, 4)}, CAR_TIGHT_BACK_UP_CELLS),  # a post diagonal behind
        (0.0, (4, 2), {(5, 4)}, CAR_BACK_UP_CELLS),  # the post on the other side
        (0.0, (4, 4), {(5, 3)}, 0.0),  # a wall right behind: no back-up
        (180.0, (4, 2), {(3, 2)}, CAR_TIGHT_BACK_UP_CELLS),  # nose south: behind is north
        (90.0, (3, 3), {(3, 2)}, CAR_TIGHT_BACK_UP_CELLS),  # nose east: behind is west
        (0.0, (2, 3), {(5, 3)}, CAR_BACK_UP_CELLS),  # not a cell beside it: as before
    ],
)
def test_a_car_backs_up_only_where_it_may_and_short_next_to_a_wall(
    heading: float, target: Cell, walls: set[Cell], cells: float
) -> None:
    """From 1.5 cells back, a car's way forward to the cell beside it cuts across the
    cell diagonal to it behind: where it may not enter that cell (a wall, another
    vehicle) it backs up a short step only, and never into a cell it may not enter
    (a car in a pocket of posts drove into one at every try and was given up)."""
    geo = GeoFrame(47.0, 8.0, 400.0, 2.0)
    pilot = Pilot(_Link(), VehicleKind.ROVER, geo, ScaledClock(1.0), 1.0, car=True)  # type: ignore[arg-type]
    pilot.may_enter = lambda cell: cell not in walls
    lat, lon = geo.cell_centre((4, 3))
    pos = Position(lat, lon, 400.0, 0.0, heading, 0.0, 0.0, 0.0, 0)
    assert pilot._room_behind(pos, target) == cells


class _Telemetry:
    position: Position | None = None


class _CommandLink(_Link):
    """Records the commands sent; knows only a position."""

    def __init__(self) -> None:
        self.telemetry = _Telemetry()
        self.commands: list[tuple[int, tuple[float, ...]]] = []

    async def command_long(self, command: int, *params: float) -> None:
        self.commands.append((command, params))


async def test_a_car_with_a_wall_behind_it_turns_forwards() -> None:
    """Nowhere to back up to: the car is left driving forwards (never in reverse
    towards a cell beside it)."""
    geo = GeoFrame(47.0, 8.0, 400.0, 2.0)
    link = _CommandLink()
    pilot = Pilot(link, VehicleKind.ROVER, geo, ScaledClock(1.0), 1.0, car=True)  # type: ignore[arg-type]
    pilot.may_enter = lambda cell: cell != (5, 3)  # the cell behind a car facing north
    lat, lon = geo.cell_centre((4, 3))
    link.telemetry.position = Position(lat, lon, 400.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0)
    await pilot._line_up(*geo.cell_centre((4, 4)), (4, 4))
    assert not pilot._reversing
    reverse = mavlink.MAV_CMD_DO_SET_REVERSE
    assert [params for command, params in link.commands if command == reverse] == []
