"""The pilot's flight home in AUTO against the mock vehicle: a vehicle stopped on the
way (the planner did not grant its next cell) and let go on flies the rest of the
route already on board, set as the current item, instead of having it uploaded
again; any other way home is uploaded. Checked against the mock's ground truth
(the mission it stores, where it is)."""

from __future__ import annotations

import asyncio

import pytest

from core.cells import Cell
from core.clocks import ScaledClock
from gcs.live.pilot import Pilot
from gcs.mission import Mission
from sitl_mock.modes import Behaviour
from tests.vehicles.test_link_vs_mock import BODY_S, SPEEDUP, UDP, linked, mission  # noqa: F401
from vehicles.modes import VehicleKind
from vehicles.telemetry import Position

pytestmark = pytest.mark.timeout(30)

#: Mission seconds any wait on the vehicle may take here.
WAIT_S = 60.0


async def test_the_rest_of_the_route_on_board_is_flown_not_uploaded_again(
    mission: Mission,  # noqa: F811
) -> None:
    async with asyncio.timeout(BODY_S), linked(mission, UDP) as pair:
        speed = mission.fleet[0].speed_m_s
        pilot = Pilot(pair.link, VehicleKind.ROVER, mission.geo, ScaledClock(SPEEDUP), speed)
        await pilot.underway()
        # East along the top row, which is free (row 0 of the map).
        cells: list[Cell] = [(0, c) for c in range(1, 9)]
        route = await pilot.start_route(cells, land=True)
        assert route.uploaded
        on_board = pair.truth.mission
        assert len(on_board) == 1 + len(cells)  # item 0 is home (ArduPilot)

        def past(cell: Cell) -> bool:
            seq = pilot.mission_seq()
            return seq is not None and seq > route.first_seq + cells.index(cell)

        await pilot.wait_position(lambda p: pilot.at(p, (0, 3)) or past((0, 3)), WAIT_S)
        stopped = pilot.cell_of(await pilot.stop_here())
        assert pair.truth.behaviour is Behaviour.GUIDED
        rest = cells[cells.index(stopped) + 1 :]
        assert rest, "stopped before the end of the route"

        resumed = await pilot.start_route(rest, land=True)
        assert not resumed.uploaded
        assert resumed.first_seq == route.first_seq + cells.index(rest[0])
        assert pair.truth.mission is on_board  # nothing was uploaded
        columns: list[int] = []

        def arrived(p: Position) -> bool:
            columns.append(pilot.cell_of(p)[1])
            return pilot.at(p, cells[-1])

        await pilot.wait_position(arrived, WAIT_S)
        assert pair.truth.cell == cells[-1]
        assert min(columns) >= stopped[1]  # on from where it stopped, never back

        # Back west: not the rest of the route on board, so it is uploaded.
        back: list[Cell] = [(0, c) for c in range(7, 0, -1)]
        again = await pilot.start_route(back, land=True)
        assert again.uploaded and pair.truth.mission is not on_board
        await pilot.wait_position(lambda p: pilot.at(p, back[-1]), WAIT_S)
        assert pair.truth.cell == back[-1]
