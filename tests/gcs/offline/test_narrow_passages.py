"""A large fleet through a narrow passage: agents coming home to charge meet
agents going out again head on, and the passage must not jam for good."""

from __future__ import annotations

from collections import deque

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from core.cells import Cell, CellState
from gcs.generated_missions import case_mission
from gcs.offline.simulate import SimOptions, simulate
from gcs.planning import planner_settings
from planner.agent import ActionKind, AgentMode, PlannerEvent
from planner.coordinator import Coordinator
from planner.settings import AgentSpec, PlannerSettings
from planner.traffic import GIVEN_WAY_AFTER
from sitl_mock.gridmap import GridMap
from sitl_mock.mapgen import caves, entrance, rooms
from sitl_mock.maps import make_map, parse_ascii
from tests.checks import check_run, energy_for_round_trips, make_mission

pytestmark = pytest.mark.timeout(300)

FREE, OBST = CellState.FREE, CellState.OBSTACLE


def room_beyond_passage(room_h: int, room_w: int, length: int, width: int) -> GridMap:
    """A room, and a passage ``length`` cells long and ``width`` wide from it
    down to the charging pad (the only way in)."""
    height, wide = room_h + length + 3, room_w + 2
    obstacle = np.ones((height, wide), dtype=bool)
    obstacle[1 : 1 + room_h, 1 : 1 + room_w] = False
    pad = entrance(height, wide)
    first = pad[1] - width // 2
    obstacle[1 + room_h : height - 1, first : first + width] = False
    obstacle[pad] = False
    return make_map(obstacle, (pad,))


def run_through(grid: GridMap, agents: int, trips: float, limit: int) -> None:
    """``trips``: how many round trips to the farthest cell the usable battery
    makes (1.0: just one, so the fleet keeps coming home)."""
    mission = make_mission(grid, agents, energy_per_m_pct=energy_for_round_trips(grid, trips))
    events: list[tuple[int, PlannerEvent]] = []
    result = simulate(mission, SimOptions(max_iterations=limit), events=events)
    check_run(result, grid, events)


def test_a_returning_queue_and_one_going_out_pass_in_a_one_cell_passage() -> None:
    """Fifty agents, a passage one cell wide: the queue coming home to charge met
    the one leaving the charger head on and both waited for ever (the run stopped
    at its limit with 84 % covered). Done in about 1300 iterations now."""
    run_through(room_beyond_passage(30, 60, 20, 1), 50, trips=1.0, limit=6000)


def test_a_crowd_at_the_chargers_door_does_not_go_back_to_top_up_for_ever() -> None:
    """Caves 150x150, 50 agents, ``top_up_ratio`` 0.7: the crowd leaving the charger
    jostled at its door, spent a little charge without covering anything and went
    back to the pad for it, again and again (every agent on the pad or beside it at
    iteration 30000, 161 cells left). An agent now tops up only once it has covered
    a cell since it charged: done in about 1400 iterations."""
    grid = caves(150, 150, 1)
    mission = case_mission(grid, 50, "caves150-1")
    settings_ = planner_settings(mission, top_up_ratio=0.7)
    events: list[tuple[int, PlannerEvent]] = []
    result = simulate(mission, SimOptions(settings=settings_, max_iterations=4000), events=events)
    check_run(result, grid, events)


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    room=st.tuples(st.integers(6, 30), st.integers(8, 60)),
    length=st.integers(3, 30),
    width=st.integers(1, 2),
    agents=st.integers(8, 50),
    trips=st.floats(1.0, 2.0),
)
def test_a_large_fleet_covers_a_room_beyond_a_narrow_passage(
    room: tuple[int, int], length: int, width: int, agents: int, trips: float
) -> None:
    grid = room_beyond_passage(*room, length, width)
    run_through(grid, agents, trips, limit=20 * grid.free_count + 1000)


def test_an_agent_too_low_to_step_aside_goes_home_and_the_corridor_clears() -> None:
    """Rooms joined by one-cell doors and corridors, 45 agents: in a corridor an
    agent on its way out met an idle one, boxed in by a third whose battery let
    it stay but not step back from the charger to make way. None of them ever
    moved again (the run stopped at its limit with 96.1 % covered); now the
    third goes home, the others make way for it, and the run completes in
    about 1400 iterations."""
    grid = rooms(46, 55, 966984, door_width=1, corridor_width=1, room_min=3, room_max=8)
    run_through(grid, 45, trips=2.985, limit=6000)


def _placed(rows: list[str], agents: dict[int, Cell]) -> Coordinator:
    """A coordinator over a known map (``C`` the charger) with agents placed."""
    grid = parse_ascii("\n".join(rows))
    known = np.where(grid.obstacle, OBST, FREE).astype(np.int8)
    specs = [AgentSpec(i, 0.1) for i in agents]
    c = Coordinator(grid.shape, grid.charger, specs, PlannerSettings(), prior=known)
    for i, cell in agents.items():
        c.observe(i, cell, {}, 100.0)
    return c


def test_an_agent_asked_to_make_way_by_one_long_held_up_going_home_goes_home_too() -> None:
    """A passage two cells wide: the cell aside is the other lane of the queue coming
    home, and the two lanes took turns at asking, so that the agent paced between
    them for ever (rooms 1000x1000, 50 agents)."""
    c = _placed(["####", "#..#", "#..#", "#..#", "#C##"], {1: (2, 1), 2: (1, 1)})
    returning, idle = c._agents[2], c._agents[1]
    returning.mode = AgentMode.RETURN
    returning.path = deque(c.belief.index(cell) for cell in [(2, 1), (3, 1), (4, 1)])
    returning.waited = GIVEN_WAY_AFTER * c.settings.patience
    idle.make_way_for = 2
    c.decide(1)
    assert c.mode(1) == AgentMode.RETURN


def test_an_agent_going_home_asked_again_while_aside_steps_on_home() -> None:
    """Agents going home in the room before the charger's door: one that had
    stepped aside was asked back by the next, and paced between two cells for
    ever (rooms 1000x1000, 50 agents). A step on home frees the cell as well."""
    c = _placed(["#####", "#...#", "#...#", "##C##"], {1: (2, 2), 2: (2, 1), 3: (1, 2)})
    going_home, behind = c._agents[1], c._agents[3]
    going_home.mode = behind.mode = AgentMode.RETURN
    behind.path = deque(c.belief.index(cell) for cell in [(2, 2), (3, 2)])
    going_home.letting_pass = (2, c.belief.index((2, 3)), 8)
    going_home.make_way_for = 3
    action = c.decide(1)
    assert action.kind == ActionKind.MOVE and action.to == (3, 2)


def test_an_agent_on_the_charger_never_steps_out_to_make_way() -> None:
    """The pad has room for all, so nobody waits for it; but asked from the cell it
    had just left (held until it decides again), an agent that had come home
    stepped out again, and back, for ever (rooms 1000x1000, 50 agents)."""
    c = _placed(["#####", "#...#", "#...#", "##C##"], {1: (3, 2), 2: (2, 1)})
    home = c._agents[1]
    home.mode = AgentMode.RETURN
    home.make_way_for, home.pushed = 2, True
    assert c.decide(1).kind == ActionKind.CHARGE


def test_an_agent_going_home_waits_for_those_ahead_and_is_not_pushed_aside() -> None:
    """Agents going home never wait on each other in a circle (each waits for one
    nearer the charger), so a push passed on by a boxed-in queue only sets them
    pacing: in the crowd before the charger's door of rooms 1000x1000 with 50
    agents, pushes went round and round for ever. It goes on home instead."""
    c = _placed(["#####", "#...#", "#...#", "##C##"], {1: (2, 2), 2: (2, 1)})
    going_home = c._agents[1]
    going_home.mode = AgentMode.RETURN
    going_home.make_way_for, going_home.pushed = 2, True
    action = c.decide(1)
    assert action.kind == ActionKind.MOVE and action.to == (3, 2)


def test_an_agent_blocked_by_an_idle_one_asks_it_aside_instead_of_walking_round() -> None:
    """Rooms 300x300 with 50 agents: agents on their way to the last frontier met
    idle agents in an open corridor, walked round them, and at the next decision
    took the fresh path through them again: they paced between the two ways for
    2500 iterations. The idle agent is asked to step aside, and does, off the way."""
    c = _placed(["#######", "#.....#", "#.....#", "#C#####"], {1: (2, 1), 2: (2, 2)})
    goal = (2, 4)
    for cell in [(r, col) for r in (1, 2) for col in range(1, 6)] + [c.belief.charger]:
        if cell != goal:
            c.belief.cover(cell, 0)
    going, idle = c._agents[1], c._agents[2]
    going.mode, idle.mode = AgentMode.TRANSIT, AgentMode.IDLE
    going.goal = c.belief.index(goal)
    assert c.decide(1).kind == ActionKind.WAIT  # not walked round
    assert c.planned_path(1)[0] == (2, 2) and idle.make_way_for == 1
    step = c.decide(2)
    assert step.kind == ActionKind.MOVE and step.to == (1, 2)
    c.observe(2, (1, 2), {}, 100.0)
    assert c.decide(2).kind == ActionKind.WAIT  # stays aside while it passes
    assert c.decide(1).to == (2, 2)
