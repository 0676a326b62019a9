"""Unit tests of the coordinator's seams (``planner`` alone, on small maps drawn here):
the sweep, target choice, traffic (reservations, no swaps) and the staying alive
policy."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from core.cells import NEIGHBOURS, Cell, CellState, Direction
from planner.agent import AgentMode, EventKind
from planner.coordinator import Coordinator
from planner.settings import AgentSpec, BmRule, BtpChoice, PlannerSettings, TargetPolicy

FREE, OBST = CellState.FREE, CellState.OBSTACLE


def _walls(rows: list[str]) -> tuple[np.ndarray, Cell]:
    """A map drawn with ``#`` walls, ``.`` free cells and ``C`` the charger: the
    obstacle mask and the charger's cell."""
    walls = np.array([[ch == "#" for ch in row] for row in rows])
    (charger,) = [(r, c) for r, row in enumerate(rows) for c, ch in enumerate(row) if ch == "C"]
    return walls, charger


def _readings(walls: np.ndarray, cell: Cell) -> dict[Direction, CellState]:
    """The 8 readings around ``cell`` (beyond the map: walls)."""
    rows, cols = walls.shape
    found = {}
    for d in NEIGHBOURS:
        r, c = d.of(cell)
        inside = 0 <= r < rows and 0 <= c < cols
        found[d] = FREE if inside and not walls[r, c] else OBST
    return found


def _known(
    rows: list[str], specs: list[AgentSpec], settings: PlannerSettings | None = None
) -> Coordinator:
    """A coordinator that is given the map, with every agent on the charger."""
    walls, charger = _walls(rows)
    prior = np.where(walls, int(OBST), int(FREE)).astype(np.int8)
    c = Coordinator(walls.shape, charger, specs, settings, prior=prior)
    for spec in specs:
        c.observe(spec.id, charger, _readings(walls, charger), 100.0)
    return c


def _cover_all_but(c: Coordinator, rows: list[str], uncovered: set[Cell]) -> None:
    for r, row in enumerate(rows):
        for col, ch in enumerate(row):
            if ch != "#" and (r, col) not in uncovered:
                c.belief.cover((r, col), 0)


def test_the_sweep_goes_first_into_the_tightest_uncovered_cell() -> None:
    """Beside a dead end and an open room, ``BmRule.TIGHT`` sweeps the dead end first;
    the paper's rule takes the first of N, S, E, W."""
    rows = ["#######", "#.....#", "#..C..#", "###.###", "###.###", "#######"]
    tight = _known(rows, [AgentSpec(1, 0.0)])
    assert tight.decide(1).to == (3, 3)
    assert tight.mode(1) == AgentMode.EXPLORE
    paper = _known(rows, [AgentSpec(1, 0.0)], PlannerSettings(bm_rule=BmRule.PAPER))
    assert paper.decide(1).to == (1, 3)


#: A corridor one cell wide, the charger at its western end.
CORRIDOR = ["#" * 22, "#C" + "." * 19 + "#", "#" * 22]


#: A corridor one cell wide and 40 long, the charger at its western end.
LONG_CORRIDOR = ["#" * 42, "#C" + "." * 39 + "#", "#" * 42]


def _one_sweeping_ahead(pace: float) -> Coordinator:
    """Agent 2 on its way to the corridor's uncovered east end (8 cells from it),
    agent 1 on the charger (29 cells from it) with nothing nearer to it."""
    settings = PlannerSettings(rival_pace=pace)
    c = _known(LONG_CORRIDOR, [AgentSpec(1, 0.0), AgentSpec(2, 0.0)], settings)
    _cover_all_but(c, LONG_CORRIDOR, {(1, col) for col in range(30, 41)})
    walls, _ = _walls(LONG_CORRIDOR)
    c.observe(2, (1, 22), _readings(walls, (1, 22)), 100.0)
    c.decide(2)
    assert c.mode(2) == AgentMode.TRANSIT and c.planned_path(2)[-1] == (1, 30)
    return c


def test_an_agent_leaves_a_target_to_one_that_would_reach_it_first() -> None:
    """Every target left is nearer to agent 2, but beyond ``hold_radius`` (5) of it: by
    default agent 1 sets out for one; with ``rival_pace`` 0.5 agent 2, drawing nearer
    by half a cell per move, would be within 5 cells of it long before agent 1 walked
    its 30 moves, so agent 1 waits; at 0.1 it would not (9 - 5 >= 0.1 x 30)."""
    for pace, sets_out in ((0.0, True), (0.1, True), (0.5, False)):
        c = _one_sweeping_ahead(pace)
        action = c.decide(1)
        assert (c.mode(1) == AgentMode.TRANSIT) == sets_out, pace
        assert (action.to == (1, 2)) == sets_out, pace


def test_a_blocked_agent_takes_the_nearest_target_and_claims_it() -> None:
    c = _known(CORRIDOR, [AgentSpec(1, 0.0), AgentSpec(2, 0.0)])
    _cover_all_but(c, CORRIDOR, {(1, 8), (1, 20)})
    first = c.decide(1)
    assert c.mode(1) == AgentMode.TRANSIT and first.to == (1, 2)
    assert [e.kind for e in c.drain_events()] == [EventKind.TARGET]
    assert c.planned_path(1)[-1] == (1, 8)
    c.decide(2)  # the nearer target is claimed: the other one
    assert c.mode(2) == AgentMode.TRANSIT and c.planned_path(2)[-1] == (1, 20)


def test_an_agent_that_cannot_afford_its_target_goes_to_charge() -> None:
    """Five cells out with 30 %: home costs 5 %, but the target 14 cells on and
    back 33 %, which would leave less than the 20 % reserve."""
    c = _known(CORRIDOR, [AgentSpec(1, 1.0)])
    _cover_all_but(c, CORRIDOR, {(1, 20)})
    walls, _ = _walls(CORRIDOR)
    c.observe(1, (1, 6), _readings(walls, (1, 6)), 30.0)
    action = c.decide(1)
    assert c.mode(1) == AgentMode.RETURN and action.to == (1, 5)
    assert EventKind.RETURN in [e.kind for e in c.drain_events()]


def test_an_agent_that_can_afford_its_target_goes_there() -> None:
    c = _known(CORRIDOR, [AgentSpec(1, 1.0)])
    _cover_all_but(c, CORRIDOR, {(1, 20)})
    walls, _ = _walls(CORRIDOR)
    c.observe(1, (1, 6), _readings(walls, (1, 6)), 90.0)
    action = c.decide(1)
    assert c.mode(1) == AgentMode.TRANSIT and action.to == (1, 7)


def test_the_battery_falling_without_a_move_sends_the_agent_home() -> None:
    c = _known(CORRIDOR, [AgentSpec(1, 1.0)])
    walls, _ = _walls(CORRIDOR)
    c.observe(1, (1, 6), _readings(walls, (1, 6)), 60.0)
    c.update_battery(1, 24.0)  # 5 moves home leave 19 %: below the reserve
    action = c.decide(1)
    assert c.mode(1) == AgentMode.RETURN and action.to == (1, 5)


#: Rooms joined by one-cell doors, the charger in the lower hall.
ROOMS = [
    "###########",
    "#....#....#",
    "#....#....#",
    "#.........#",
    "#....#....#",
    "####.###.##",
    "#.........#",
    "#....C....#",
    "###########",
]


def test_no_two_agents_share_a_cell_or_swap_cells() -> None:
    """A fleet sweeping rooms joined by one-cell doors, one move after another: no
    agent ever heads for a cell another stands on, nor for one another has left in
    the same round (so none trades places with another, or follows it along the
    same edge in one step). The charger, a depot with room for all, aside."""
    walls, charger = _walls(ROOMS)
    specs = [AgentSpec(i, 0.0) for i in range(1, 6)]
    c = Coordinator(walls.shape, charger, specs, PlannerSettings())
    at = {s.id: charger for s in specs}
    for s in specs:
        c.observe(s.id, charger, _readings(walls, charger), 100.0)
    for _ in range(400):
        if c.finished:
            break
        left: set[Cell] = set()  # cells left in this round
        for s in specs:
            action = c.decide(s.id)
            if action.to is None:
                continue
            if action.to != charger:
                assert action.to not in at.values() and action.to not in left
            left.add(at[s.id])
            c.observe(s.id, action.to, _readings(walls, action.to), 100.0)
            at[s.id] = action.to
    assert c.finished
    assert c.belief.covered_count == int((~walls).sum())


def _sweep(c: Coordinator, walls: np.ndarray, agent: int, moves: int) -> list[Cell | None]:
    """The cells of the agent's next ``moves`` decisions (None: no move)."""
    cells: list[Cell | None] = []
    for _ in range(moves):
        action = c.decide(agent)
        cells.append(action.to)
        if action.to is not None:
            c.observe(agent, action.to, _readings(walls, action.to), 100.0)
    return cells


def test_the_forward_rule_goes_straight_on_where_the_paper_turns_north_or_south() -> None:
    rows = ["#######", "#.....#", "#.....#", "#C....#", "#######"]
    walls, _ = _walls(rows)
    paper = _known(rows, [AgentSpec(1, 0.0)], PlannerSettings(bm_rule=BmRule.PAPER))
    assert _sweep(paper, walls, 1, 4) == [(2, 1), (1, 1), (1, 2), (2, 2)]
    forward = _known(rows, [AgentSpec(1, 0.0)], PlannerSettings(bm_rule=BmRule.FORWARD))
    assert _sweep(forward, walls, 1, 4) == [(2, 1), (1, 1), (1, 2), (1, 3)]


def test_with_a_launch_interval_agents_leave_the_charger_one_after_another() -> None:
    rows = ["#######", "#.....#", "#.....#", "#C....#", "#######"]
    walls, _ = _walls(rows)
    specs = [AgentSpec(1, 0.0), AgentSpec(2, 0.0)]
    c = _known(rows, specs, PlannerSettings(launch_interval=3))
    assert _sweep(c, walls, 1, 1) != [None]
    assert _sweep(c, walls, 2, 4)[:3] == [None, None, None]


def test_every_reading_of_the_paper_covers_the_rooms() -> None:
    """The other readings of the paper (``BmRule.FORWARD``, ``BtpChoice``,
    ``net_when_alone``, ``launch_interval``) still cover every cell."""
    walls, charger = _walls(ROOMS)
    paper = PlannerSettings(
        bm_rule=BmRule.PAPER, target_policy=TargetPolicy.OWN_FIRST, spread=False
    )
    readings = [
        replace(paper, bm_rule=BmRule.FORWARD),
        replace(paper, btp_choice=BtpChoice.LINE),
        replace(paper, btp_choice=BtpChoice.LAST, replan_transit=False),
        replace(paper, net_when_alone=True),
        replace(paper, launch_interval=5),
    ]
    for settings in readings:
        specs = [AgentSpec(i, 0.0) for i in range(1, 4)]
        c = Coordinator(walls.shape, charger, specs, settings)
        for s in specs:
            c.observe(s.id, charger, _readings(walls, charger), 100.0)
        for _ in range(600):
            if c.finished:
                break
            for s in specs:
                _sweep(c, walls, s.id, 1)
        assert c.finished, settings
        assert c.belief.covered_count == int((~walls).sum()), settings
