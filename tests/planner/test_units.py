"""Unit tests of the planner's parts: belief, BM, BTP rules, staying alive, paths."""

from __future__ import annotations

import itertools
from collections import deque
from collections.abc import Callable
from typing import Any

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from core.cells import MOVES, NEIGHBOURS, Cell, CellState, Direction
from planner import btp
from planner.agent import ActionKind, AgentMode, EventKind, PlannerEvent
from planner.belief import UNREACHED, MapBelief
from planner.coordinator import Coordinator
from planner.paths import bfs_distances, nearest, path_to_charger, shortest_path
from planner.prm import Roadmap, line_cells
from planner.settings import AgentSpec, BmRule, PathPlannerKind, PlannerSettings
from sitl_mock import mapgen
from sitl_mock.gridmap import GridMap
from sitl_mock.maps import make_map, parse_ascii

FREE, OBST = CellState.FREE, CellState.OBSTACLE

#: The map generators the properties draw from, by name.
MAKERS: dict[str, Callable[..., GridMap]] = {
    "bars": mapgen.bars,
    "caves": mapgen.caves,
    "rooms": mapgen.rooms,
}


def sensing(grid_text: str):
    """A world from ASCII and a function answering the 8 readings around a cell."""
    grid = parse_ascii(grid_text)

    def readings(cell: Cell) -> dict[Direction, CellState]:
        return {d: FREE if grid.is_free(d.of(cell)) else OBST for d in NEIGHBOURS}

    return grid, readings


def known_belief(grid) -> MapBelief:
    """A belief that knows the whole map (every free cell sensed)."""
    belief = MapBelief(grid.shape, grid.charger)
    for r in range(grid.shape[0]):
        for c in range(grid.shape[1]):
            i = belief.index((r, c))
            if grid.obstacle[r, c]:
                belief.state[i] = int(OBST)
    order = sorted(
        (cell for cell in np.argwhere(~grid.obstacle)),
        key=lambda rc: abs(rc[0] - grid.charger[0]) + abs(rc[1] - grid.charger[1]),
    )
    for r, c in order:
        belief.mark_free(belief.index((int(r), int(c))))
    return belief


def true_distances(grid, start: Cell) -> dict[Cell, int]:
    dist = {start: 0}
    queue = deque([start])
    while queue:
        cell = queue.popleft()
        for d in MOVES:
            nxt = d.of(cell)
            if grid.is_free(nxt) and nxt not in dist:
                dist[nxt] = dist[cell] + 1
                queue.append(nxt)
    return dist


# -- belief --------------------------------------------------------------------


def test_sensing_records_free_and_obstacle_cells_and_outside_is_obstacle() -> None:
    grid, readings = sensing("###\n#.#\n#C#")
    belief = MapBelief(grid.shape, grid.charger)
    new = belief.sense((1, 1), readings((1, 1)))
    assert new == []  # the only free neighbour is the charger, known from the start
    assert belief.is_free((2, 1)) and belief.is_free((1, 1)) is False
    belief.cover((1, 1), 0)
    assert belief.is_free((1, 1)) and belief.is_covered((1, 1))
    assert belief.state_of((0, 1)) == OBST
    assert belief.state_of((-1, 0)) == OBST  # outside the map
    assert belief.state_of((5, 5)) == OBST


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 10_000), kind=st.sampled_from(["bars", "caves", "rooms"]))
def test_incremental_charger_distances_equal_a_fresh_search(seed: int, kind: str) -> None:
    grid = MAKERS[kind](20, 24, seed=seed)
    belief = MapBelief(grid.shape, grid.charger)
    rng = np.random.default_rng(seed)
    cells = [(int(rc[0]), int(rc[1])) for rc in np.argwhere(~grid.obstacle)]
    rng.shuffle(cells)  # discovery in any order
    for cell in cells:
        belief.mark_free(belief.index(cell))
    truth = true_distances(grid, grid.charger)
    for cell in cells:
        assert belief.distance_to_charger(cell) == truth.get(cell, UNREACHED)


@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 10_000),
    kind=st.sampled_from(["bars", "caves", "rooms", "scatter"]),
    order=st.sampled_from(["shuffled", "wavefront"]),
)
def test_a_cell_not_listed_as_a_shortcut_shortens_no_way(seed: int, kind: str, order: str) -> None:
    """Cells become free in any order, or as a ragged wavefront from the charger:
    after each one that ``MapBelief.shortcuts`` does not list, every two cells the
    charger reached before are as far apart as they were."""
    rng = np.random.default_rng(seed)
    if kind == "scatter":
        walls = rng.random((9, 9)) < rng.uniform(0.0, 0.4)
        walls[8, 4] = False
        grid = make_map(walls, ((8, 4),))
    else:
        grid = MAKERS[kind](9, 10, seed=seed)
    cells = [(int(rc[0]), int(rc[1])) for rc in np.argwhere(~grid.obstacle)]
    if order == "shuffled":
        rng.shuffle(cells)
    else:
        far = true_distances(grid, grid.charger)
        cells.sort(key=lambda c: far.get(c, 99) + rng.integers(0, 4))
    belief = MapBelief(grid.shape, grid.charger)

    def distances() -> dict[tuple[Cell, Cell], int]:
        known = make_map(belief.state_grid() != FREE, (grid.charger,))  # walls where unknown
        reached = [c for c in cells if belief.distance_to_charger(c) < UNREACHED]
        return {
            (a, b): d for a in reached for b, d in true_distances(known, a).items() if b in reached
        }

    before = distances()
    for cell in cells:
        listed = belief.shortcut_count
        belief.mark_free(belief.index(cell))
        after = distances()
        if belief.shortcut_count == listed:
            assert all(after[pair] == d for pair, d in before.items()), cell
        before = after


# -- paths -------------------------------------------------------------------


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 10_000), pick=st.integers(0, 10_000))
def test_shortest_path_length_equals_bfs_distance(seed: int, pick: int) -> None:
    grid = mapgen.caves(24, 24, seed)
    belief = known_belief(grid)
    free = [(int(rc[0]), int(rc[1])) for rc in np.argwhere(~grid.obstacle)]
    start, goal = free[pick % len(free)], free[(pick * 7 + 3) % len(free)]
    truth = true_distances(grid, start)
    path = shortest_path(belief, belief.index(start), belief.index(goal))
    assert path is not None
    assert len(path) == truth[goal]
    cells = [start] + [belief.cell(i) for i in path]
    assert all(abs(a[0] - b[0]) + abs(a[1] - b[1]) == 1 for a, b in itertools.pairwise(cells))
    assert all(grid.is_free(c) for c in cells)
    home = path_to_charger(belief, belief.index(start))
    assert home is not None and len(home) == true_distances(grid, grid.charger)[start]
    assert bfs_distances(belief, belief.index(start))[belief.index(goal)] == truth[goal]


def test_nearest_finds_the_closest_accepted_cell_and_respects_blocked_cells() -> None:
    grid, _ = sensing("#######\n#.....#\n#.###.#\n#.....#\n###C###")
    belief = known_belief(grid)
    start = belief.index((3, 3))
    found = nearest(belief, start, lambda i, d: belief.cell(i) == (1, 3))
    assert found is not None
    goal, path = found
    assert belief.cell(goal) == (1, 3) and len(path) == 6
    blocked = {belief.index((3, 2)), belief.index((2, 1))}
    found = nearest(belief, start, lambda i, d: belief.cell(i) == (1, 1), blocked)
    assert found is not None
    goal, path = found
    assert len(path) == 8 and belief.index((3, 2)) not in path


def test_prm_paths_are_grid_moves_over_free_cells() -> None:
    grid = mapgen.rooms(30, 30, 3)
    belief = known_belief(grid)
    roadmap = Roadmap(PlannerSettings(path_planner=PathPlannerKind.PRM, seed=1))
    roadmap.grow(
        belief, [belief.index((int(rc[0]), int(rc[1]))) for rc in np.argwhere(~grid.obstacle)]
    )
    free = [(int(rc[0]), int(rc[1])) for rc in np.argwhere(~grid.obstacle)]
    for k in range(0, len(free), max(1, len(free) // 12)):
        start, goal = free[k], free[-1 - k]
        path = roadmap.path(belief, belief.index(start), belief.index(goal))
        assert path is not None and belief.cell(path[-1]) == goal
        cells = [start] + [belief.cell(i) for i in path]
        assert all(abs(a[0] - b[0]) + abs(a[1] - b[1]) == 1 for a, b in itertools.pairwise(cells))
        assert len(path) >= true_distances(grid, start)[goal]
    assert line_cells(belief, belief.index(free[0]), belief.index(free[0])) == []


# -- boustrophedon motion and BTPs -------------------------------------------


def test_bm_takes_north_first_then_south_east_west() -> None:
    grid, readings = sensing("#######\n#.....#\n#.....#\n#.....#\n###C###")
    coordinator = Coordinator(
        grid.shape, grid.charger, [AgentSpec(1, 0.0)], PlannerSettings(bm_rule=BmRule.PAPER)
    )
    moves = []
    cell = grid.charger
    coordinator.observe(1, cell, readings(cell), 100.0)
    for _ in range(8):
        action = coordinator.decide(1)
        assert action.kind == ActionKind.MOVE and action.to is not None
        moves.append(Direction.between(cell, action.to))
        cell = action.to
        coordinator.observe(1, cell, readings(cell), 100.0)
    n, s, e = Direction.N, Direction.S, Direction.E
    assert moves == [n, n, n, e, s, s, e, n]


@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 10_000),
    covered=st.lists(st.booleans(), min_size=64, max_size=64),
    held=st.lists(st.booleans(), min_size=64, max_size=64),
)
def test_blocked_is_the_sweep_finding_no_next_cell(
    seed: int, covered: list[bool], held: list[bool]
) -> None:
    """``Sweep.blocked``, asked of every held agent at each decision, answers as
    ``next_cell`` does: no free, uncovered cell beside it that no agent holds."""
    grid = mapgen.open_field(10, 10, seed)
    prior = np.where(grid.obstacle, int(CellState.OBSTACLE), int(CellState.FREE)).astype(np.int8)
    coordinator = Coordinator(grid.shape, grid.charger, [AgentSpec(1, 0.0)], prior=prior)
    sweep, belief = coordinator._sweep, coordinator.belief
    inner = [(r, c) for r in range(1, 9) for c in range(1, 9)]
    for cell, cover, hold in zip(inner, covered, held, strict=True):
        if belief.is_free(cell):
            if cover:
                belief.cover(cell, 0)
            if hold:
                coordinator._traffic.occupy(belief.index(cell), 2)
    a = coordinator._agents[1]
    for cell in inner:
        if belief.is_free(cell):
            a.index = belief.index(cell)
            assert sweep.blocked(a) == (sweep.next_cell(a) is None), cell


def test_btp_is_a_side_opening_beside_a_wall() -> None:
    # Moving north at (2, 2): west (2, 1) is free, south-west (3, 1) is a wall.
    grid, readings = sensing("#####\n#...#\n#...#\n##..#\n##C##")
    belief = MapBelief(grid.shape, grid.charger)
    for cell in [(3, 2), (2, 2)]:
        belief.sense(cell, readings(cell))
        belief.cover(cell, 0)
    found = {belief.cell(i) for i in btp.detect(belief, belief.index((2, 2)), Direction.N)}
    assert found == {(2, 1)}
    # An open side with no wall beside it is not a BTP (the sweep takes it).
    grid2, readings2 = sensing("#####\n#...#\n#...#\n#...#\n##C##")
    belief2 = MapBelief(grid2.shape, grid2.charger)
    for cell in [(3, 2), (2, 2)]:
        belief2.sense(cell, readings2(cell))
        belief2.cover(cell, 0)
    assert btp.detect(belief2, belief2.index((2, 2)), Direction.N) == []
    # A covered side cell is not a BTP.
    belief.cover((2, 1), 1)
    assert btp.detect(belief, belief.index((2, 2)), Direction.N) == []


def test_btp_stacks_local_global_and_removal() -> None:
    stacks = btp.BtpStacks()
    assert stacks.push(1, 10) and not stacks.push(2, 10)
    stacks.push(2, 11)
    assert list(stacks.own(1)) == [10] and len(stacks) == 2
    stacks.release(2)
    assert stacks.owner[11] == btp.BtpStacks.POOL
    assert stacks.remove(10) and 10 not in stacks and not stacks.remove(10)


# -- staying alive policy -------------------------------------------------------


def corridor(length: int) -> tuple:
    """A straight corridor north of the charger."""
    rows = ["###"] + ["#.#"] * length + ["#C#"]
    return sensing("\n".join(rows))


def test_returns_to_charge_before_the_reserve_and_resumes_where_it_stopped() -> None:
    grid, readings = sensing("\n".join(["#########"] + ["#.......#"] * 8 + ["####C####"]))
    cost = 3.0  # % per move; the farthest cell is 11 moves away: 66 % out and back
    coordinator = Coordinator(grid.shape, grid.charger, [AgentSpec(1, cost)], PlannerSettings())
    cell, battery = grid.charger, 100.0
    coordinator.observe(1, cell, readings(cell), battery)
    returns = 0
    for _ in range(2000):
        before = coordinator.mode(1)
        action = coordinator.decide(1)
        if coordinator.mode(1) == AgentMode.RETURN and before == AgentMode.EXPLORE:
            returns += 1
            # It stopped where the next step would have cut into the reserve, and
            # left a BTP there to resume from.
            assert coordinator.btps()
        if action.kind == ActionKind.CHARGE:
            assert cell == grid.charger and battery >= 20.0 - 1e-9
            battery = 100.0  # instant charge
            coordinator.update_battery(1, battery)
            continue
        if action.kind == ActionKind.WAIT:
            break
        assert action.to is not None
        cell, battery = action.to, battery - cost
        coordinator.observe(1, cell, readings(cell), battery)
        home = coordinator.belief.distance_to_charger(cell)
        assert battery - cost * home >= 20.0 - 1e-9  # can always get home above the reserve
    assert coordinator.finished and cell == grid.charger
    assert returns >= 1 and coordinator.charges(1) == returns
    assert coordinator.belief.covered_count == int((~grid.obstacle).sum())


def test_a_blocked_agent_only_takes_a_target_it_can_afford_to_come_back_from() -> None:
    grid, readings = corridor(6)
    coordinator = Coordinator(grid.shape, grid.charger, [AgentSpec(1, 10.0)], PlannerSettings())
    coordinator.observe(1, grid.charger, readings(grid.charger), 100.0)
    # 100 % with 10 % a move and 20 % reserve: 8 moves in all, so 4 cells out and back.
    cell, battery, farthest = grid.charger, 100.0, 0
    for _ in range(40):
        action = coordinator.decide(1)
        if action.kind != ActionKind.MOVE:
            break
        assert action.to is not None
        cell, battery = action.to, battery - 10.0
        farthest = max(farthest, grid.charger[0] - cell[0])
        coordinator.observe(1, cell, readings(cell), battery)
    assert farthest == 4
    assert battery >= 20.0 - 1e-9
    assert coordinator.out_of_range_cells()  # the two far cells are reported, not skipped


def test_an_agent_whose_battery_falls_while_it_waits_goes_home() -> None:
    grid, readings = sensing("\n".join(["#######"] + ["#.....#"] * 5 + ["###C###"]))
    cost = 2.0
    coordinator = Coordinator(grid.shape, grid.charger, [AgentSpec(1, cost)], PlannerSettings())
    cell = grid.charger
    coordinator.observe(1, cell, readings(cell), 100.0)
    for _ in range(4):
        action = coordinator.decide(1)
        assert action.kind == ActionKind.MOVE and action.to is not None
        cell = action.to
        coordinator.observe(1, cell, readings(cell), 100.0)
    home = coordinator.belief.distance_to_charger(cell)
    # Hovering drained it to just below what the way home needs above the reserve.
    coordinator.update_battery(1, 20.0 + cost * home - 0.5)
    assert coordinator.decide(1).kind == ActionKind.MOVE
    assert coordinator.mode(1) == AgentMode.RETURN


def test_cells_back_in_range_after_a_better_estimate_are_covered() -> None:
    grid, readings = corridor(6)
    coordinator = Coordinator(grid.shape, grid.charger, [AgentSpec(1, 10.0)], PlannerSettings())
    cell, battery = grid.charger, 100.0
    coordinator.observe(1, cell, readings(cell), battery)

    def run(cost: float) -> None:
        nonlocal cell, battery
        for _ in range(100):
            action = coordinator.decide(1)
            if action.kind == ActionKind.CHARGE:
                battery = 100.0
                coordinator.update_battery(1, battery)
            elif action.kind == ActionKind.MOVE:
                assert action.to is not None
                cell, battery = action.to, battery - cost
                coordinator.observe(1, cell, readings(cell), battery)
            elif coordinator.finished:
                return

    run(10.0)  # 10 %/m: 4 cells out and back, the two far cells are out of range
    assert coordinator.finished and coordinator.out_of_range_cells()
    coordinator.set_energy_per_m(1, 5.0)  # a better estimate: they are in range now
    assert not coordinator.coverage_complete
    run(5.0)
    assert coordinator.finished and not coordinator.out_of_range_cells()
    assert coordinator.belief.covered_count == int((~grid.obstacle).sum())


def _door() -> Coordinator:
    """Two rooms behind a one-cell door (2, 3) above the charger, the map known; two
    agents on the charger."""
    rows = ["#######", "#..#..#", "#.....#", "###C###"]
    known = np.array([[OBST if ch == "#" else FREE for ch in r] for r in rows], dtype=np.int8)
    agents = [AgentSpec(1, 0.0), AgentSpec(2, 0.0)]
    c = Coordinator((4, 7), (3, 3), agents, PlannerSettings(), prior=known)
    c.observe(1, (3, 3), {}, 100.0)
    c.observe(2, (3, 3), {}, 100.0)
    return c


def test_a_lost_agent_blocks_its_cell_and_what_lies_behind_it() -> None:
    """A lost vehicle in a one-cell door: nobody waits on it for ever; the room behind
    is out of reach (reported, not waited for) and the others finish."""
    c = _door()
    c.observe(1, (2, 3), {}, 100.0)  # agent 1 stands in the door (2, 3)...
    c.mark_lost(1)  # ...and is lost there
    assert c.belief.state_of((2, 3)) == OBST
    assert c.belief.distance_to_charger((2, 2)) >= UNREACHED
    for _ in range(100):
        if c.mode(2) == AgentMode.DONE:
            break
        action = c.decide(2)
        assert action.kind != ActionKind.MOVE, "nothing is reachable past the lost agent"
    assert c.mode(2) == AgentMode.DONE
    assert len(c.out_of_range_cells()) == 8  # the four cells on each side of the door
    # Nothing is left in reach, but coverage is not complete: the rooms are cut off.
    kinds = [e.kind for e in c.drain_events()]
    assert EventKind.CUT_OFF in kinds and EventKind.COVERAGE_COMPLETE not in kinds
    assert c.cut_off_cells == 8


def test_coverage_without_a_loss_is_complete_not_cut_off() -> None:
    c = _door()
    for _ in range(400):
        if c.finished:
            break
        for agent in (1, 2):
            action = c.decide(agent)
            if action.kind == ActionKind.MOVE:
                assert action.to is not None
                c.observe(agent, action.to, {}, 100.0)
    assert c.finished
    kinds = [e.kind for e in c.drain_events()]
    assert EventKind.COVERAGE_COMPLETE in kinds and EventKind.CUT_OFF not in kinds
    assert c.cut_off_cells == 0


def test_an_agent_walled_in_by_a_lost_one_gives_up() -> None:
    """Behind the door when the other is lost in it: it can never come home, and it
    says so (done) instead of keeping the mission waiting."""
    c = _door()
    c.observe(2, (2, 3), {}, 100.0)
    c.observe(2, (2, 2), {}, 100.0)  # agent 2 in the room...
    c.observe(1, (2, 3), {}, 100.0)  # ...agent 1 in the door, lost there
    c.mark_lost(1)
    assert c.decide(2).kind == ActionKind.WAIT
    assert c.mode(2) == AgentMode.DONE and c.finished


def test_walls_found_after_a_loss_close_the_way_round() -> None:
    """A vehicle lost in the only known door: the cell beyond stays worth going to
    while the unknown might hold another way round from the charger, and is out of
    range once walls found later close it (before, the mission waited for it until
    its time limit)."""
    c = Coordinator((3, 4), (0, 0), [AgentSpec(1, 0.0), AgentSpec(2, 0.0)], PlannerSettings())
    c.observe(1, (0, 0), {Direction.E: FREE}, 100.0)
    c.observe(2, (0, 0), {}, 100.0)
    c.observe(2, (0, 1), {Direction.E: FREE}, 100.0)  # agent 2 in the door sees (0, 2)...
    c.mark_lost(2)  # ...and is lost there
    assert c.belief.distance_to_charger((0, 2)) >= UNREACHED
    assert not c.coverage_complete  # perhaps a way round through the unknown, south
    c.observe(1, (0, 0), {Direction.S: OBST}, 100.0)  # the way south is a wall
    assert c.coverage_complete
    assert c.out_of_range_cells() == [(0, 2)]


class _CountedSearch:
    """A target search that counts its ``run`` calls."""

    def __init__(self, search: Any) -> None:
        self.search, self.runs = search, 0

    def __getattr__(self, name: str) -> Any:
        return getattr(self.search, name)

    def run(self, *args: Any) -> Any:
        self.runs += 1
        return self.search.run(*args)


def _walk_to_the_far_end(far_transit_recheck: int) -> tuple[int, int, list[PlannerEvent]]:
    """Searches for a target, moves and the planner's events of one agent crossing a
    long corridor whose only uncovered cell is at the far end."""
    length = 60
    known = np.full((1, length), int(FREE), dtype=np.int8)
    covered = np.ones((1, length), dtype=bool)
    covered[0, -1] = False
    settings_ = PlannerSettings(far_transit_recheck=far_transit_recheck)
    coordinator = Coordinator((1, length), (0, 0), [AgentSpec(1, 0.0)], settings_)
    coordinator.restore(known, covered, [])
    cell = (0, 0)
    readings = {d: OBST if d.of(cell)[0] != 0 else FREE for d in NEIGHBOURS}
    coordinator.observe(1, cell, readings, 100.0)
    moves = 0
    # The target search counted where the targets' choice calls it (it is compiled:
    # its methods cannot be replaced).
    counted = coordinator._targets._search = _CountedSearch(coordinator._search)
    events: list[PlannerEvent] = []
    while coordinator.belief.covered_count < length:
        action = coordinator.decide(1)
        events += coordinator.drain_events()
        assert action.kind == ActionKind.MOVE and action.to is not None
        cell = action.to
        moves += 1
        readings = {
            d: FREE if d.of(cell)[0] == 0 and 0 <= d.of(cell)[1] < length else OBST
            for d in NEIGHBOURS
        }
        coordinator.observe(1, cell, readings, 100.0)
    return counted.runs, moves, events


def test_far_targets_are_searched_for_again_less_often() -> None:
    every_step, moves, _ = _walk_to_the_far_end(0)
    assert moves == 59 and every_step == 58  # the last move sweeps a neighbour: no search
    fewer, same_moves, _ = _walk_to_the_far_end(8)
    assert same_moves == moves
    # Searches 59, 33, 20, 13, 10 and 8 moves from the end (half the way beyond 8
    # between two), then at every step within 8 until the end is a neighbour.
    assert fewer == 12


def test_a_target_confirmed_on_the_way_is_not_taken_again() -> None:
    """Deciding again at every step of the way, the agent takes its target once: one
    event, not one per step (the log's BTP timeline and the safety net's count and
    messages come from these events)."""
    searches, _, events = _walk_to_the_far_end(0)
    taken = [e for e in events if e.kind in (EventKind.TARGET, EventKind.SAFETY_NET)]
    assert searches == 58
    assert taken == [PlannerEvent(EventKind.TARGET, 1, (0, 59))]


def test_the_planned_way_home_is_the_way_granted_cell_by_cell() -> None:
    """A live vehicle flies its way home as one AUTO mission, stopped wherever the
    planner does not grant the next cell: the mission must be the planner's own way
    (``planned_path``), here a detour round another agent, not a fresh shortest way
    from the next cell, which runs back through that agent."""
    known = np.full((3, 4), int(FREE), dtype=np.int8)
    agents = [AgentSpec(1, 0.0), AgentSpec(2, 0.0)]
    c = Coordinator((3, 4), (0, 0), agents, PlannerSettings(), prior=known)
    for cell in [(0, 0), (0, 1), (0, 2), (0, 3)]:
        c.observe(1, cell, {}, 100.0)
    c.observe(2, (0, 0), {}, 100.0)
    c.observe(2, (0, 1), {}, 100.0)
    c.observe(2, (0, 2), {}, 100.0)  # agent 2 stands on agent 1's way home and stays
    c.recall()
    first = c.decide(1).to
    assert first == (1, 3)  # round agent 2
    planned = c.planned_path(1)
    assert planned[-1] == (0, 0) and (0, 2) not in planned
    fresh = path_to_charger(c.belief, c.belief.index(first))
    assert fresh is not None and c.belief.index((0, 2)) in fresh  # why not this one
    granted = []
    cell = first
    while cell != (0, 0):
        c.observe(1, cell, {}, 100.0)
        action = c.decide(1)
        assert action.kind == ActionKind.MOVE and action.to is not None
        granted.append(cell := action.to)
    assert granted == planned


def _first_decision_on_the_way_back(
    top_up_ratio: float,
    battery: float,
    energy_per_m: float = 2.0,
    at: Cell = (5, 3),
    swept: bool = True,
) -> AgentMode:
    """Agent 1 stands ``at`` a cell (by default two moves from the charger, four from
    the nearest cell left), its sweep blocked (every cell around it covered), and
    decides what to do next with ``battery`` left. The map was swept by agent 1, or
    by agent 2 when not ``swept`` (then agent 1 covered nothing since it charged)."""
    grid, readings = sensing("\n".join(["#######"] + ["#.....#"] * 6 + ["###C###"]))
    settings_ = PlannerSettings(top_up_ratio=top_up_ratio)
    fleet = [AgentSpec(1, energy_per_m), AgentSpec(2, energy_per_m)]
    coordinator = Coordinator(grid.shape, grid.charger, fleet, settings_)
    sweeper = 1 if swept else 2
    for r in range(2, 7):  # the top row is seen from the next, and left to cover
        for c in range(1, 6):
            coordinator.observe(sweeper, (r, c), readings((r, c)), 100.0)
    coordinator.observe(2, grid.charger, readings(grid.charger), 100.0)
    coordinator.observe(1, at, readings(at), battery)
    coordinator.decide(1)
    return coordinator.mode(1)


def test_an_agent_near_the_charger_tops_up_when_it_costs_little_of_the_charge() -> None:
    # 2 moves there and back at 2 % a move: 8 % of the 60 % a charge would give.
    assert _first_decision_on_the_way_back(0.2, 40.0) == AgentMode.RETURN
    assert _first_decision_on_the_way_back(0.1, 40.0) == AgentMode.TRANSIT  # 8 > 6
    assert _first_decision_on_the_way_back(0.2, 90.0) == AgentMode.TRANSIT  # 8 > 2
    assert _first_decision_on_the_way_back(0.0, 40.0) == AgentMode.TRANSIT  # the paper's rule


def test_an_agent_with_nothing_to_gain_never_tops_up() -> None:
    # No battery model: the trip costs nothing, and a charge gives nothing either.
    assert _first_decision_on_the_way_back(1.0, 100.0, energy_per_m=0.0) == AgentMode.TRANSIT


def test_an_agent_nearer_its_target_than_the_charger_does_not_top_up() -> None:
    # 4 moves from the charger, 2 from the top row: 16 % of 60 % is within 0.4.
    assert _first_decision_on_the_way_back(0.4, 40.0, at=(3, 3)) == AgentMode.TRANSIT
    assert _first_decision_on_the_way_back(0.4, 40.0) == AgentMode.RETURN  # 2 from each


def test_an_agent_that_covered_nothing_since_it_charged_does_not_top_up() -> None:
    # Else a crowd jostling at the charger's door goes back to the pad for ever.
    assert _first_decision_on_the_way_back(1.0, 40.0, swept=False) == AgentMode.TRANSIT
    assert _first_decision_on_the_way_back(1.0, 40.0) == AgentMode.RETURN
