"""The compiled searches' shortcuts give exactly what the plain passes give, kernel by
kernel (the plans with each shortcut switched off: ``tests/planner/test_target_search.py``)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from core.cells import CellState
from planner.belief import UNREACHED, MapBelief
from planner.paths import bfs_distances, shortest_path
from planner.settings import SearchShortcuts
from planner.speed import bounds as lower_bounds
from planner.speed import landmarks, walk_back, walks
from planner.speed.compiled_search import (
    AgentMemory,
    CompiledSearch,
    HorizonMemo,
    WayMemo,
)
from planner.speed.search_kernels import uncontested_horizon
from planner.speed.settled_target import SettledTarget
from planner.speed.still_field import StillField
from planner.target_search import HELD_BACK, Energy, Found, Hint, SearchRequest
from planner.team import Team
from sitl_mock import mapgen

SIDE = 40


def _run(
    search: CompiledSearch,
    start: int,
    battery: float,
    cost: float,
    floor: float,
    best_cost: float,
    budget: float,
    others: tuple[np.ndarray, np.ndarray],
    hold: int,
    excluded: list[int],
    pool=None,
    memo: HorizonMemo | None = None,
    hint: tuple | None = None,
    way_memo: WayMemo | None = None,
    settled: SettledTarget | None = None,
    pace: float = 0.0,
    still: StillField | None = None,
) -> Found | None:
    """The search's answer, with the agent's memories given (None: not kept)."""
    energy = Energy(battery, cost, floor, best_cost, budget)
    hinted = None if hint is None else Hint(*hint)
    request = SearchRequest(start, energy, others, hold, excluded, pool, hinted, pace)
    return search.run(request, AgentMemory(memo, way_memo, settled, still))


def _lands(search: CompiledSearch) -> np.ndarray:
    """The search's distances from the landmarks, up to date (as ``run`` has them)."""
    return search.update_lands()


def _horizon(belief: MapBelief, cells: np.ndarray, slot: int, rows, cols, working) -> int:
    others = working.copy()
    others[slot] = False
    start = belief.index((int(rows[slot]), int(cols[slot])))
    candidate = np.frombuffer(belief.uncovered_mask, dtype=np.uint8)
    search = CompiledSearch(belief)
    _lands(search)
    rivals = (rows[others], cols[others], 0)
    horizon, _ = uncontested_horizon(candidate, cells, start, search.grid, rivals, -1, cells)
    return horizon


@settings(max_examples=150, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    agents=st.integers(2, 8),
    moves=st.integers(0, HorizonMemo.MARGIN + 4),
)
def test_horizon_shortlist_gives_the_full_pass_horizon(seed: int, agents: int, moves: int) -> None:
    """After the team moves (within the margin or beyond it), cells are covered and
    found and agents start working, the shortlist's horizon is the full pass's, or
    the memo asks for a full pass."""
    rng = np.random.default_rng(seed)
    belief = MapBelief((SIDE, SIDE), (0, 0))
    for r, c in rng.integers(0, SIDE, size=(300, 2)):
        belief.mark_free(belief.index((int(r), int(c))))
    team = Team(agents, (0, 0))
    rows, cols, working = team.rows, team.cols, team.working  # changed in place below
    rows[:] = rng.integers(0, SIDE, agents)
    cols[:] = rng.integers(0, SIDE, agents)
    working[:] = rng.random(agents) < 0.8
    working[0] = True
    memo = HorizonMemo(team, 0)
    search = CompiledSearch(belief)
    listed = search.uncovered_list[: belief.uncovered_count]
    others = working.copy()
    others[0] = False
    start = belief.index((int(rows[0]), int(cols[0])))
    _lands(search)
    rivals = (rows[others], cols[others], 0)
    _, kept = uncontested_horizon(
        search.candidate, listed, start, search.grid, rivals, 16, search._kept
    )
    if kept < 0:
        return  # nobody else at work: no shortlist is kept (the horizon is unbounded)
    memo.remember(search._kept[:kept], belief)

    for _ in range(moves):  # every agent takes a step, some cells change
        rows[:] = np.clip(rows + rng.integers(-1, 2, agents), 0, SIDE - 1)
        cols[:] = np.clip(cols + rng.integers(-1, 2, agents), 0, SIDE - 1)
    for i in list(belief.uncovered)[: int(rng.integers(0, 40))]:
        belief.cover(belief.cell(i), 1)
    for r, c in rng.integers(0, SIDE, size=(int(rng.integers(0, 40)), 2)):
        belief.mark_free(belief.index((int(r), int(c))))
    working |= rng.random(agents) < 0.2  # idle agents back at work: only more rivals

    shortlist = memo.shortlist(belief)
    full = search.uncovered_list[: belief.uncovered_count]
    if shortlist is not None:
        assert _qualifying(belief, full, rows, cols, working) <= set(shortlist.tolist())
        assert _horizon(belief, shortlist, 0, rows, cols, working) == _horizon(
            belief, full, 0, rows, cols, working
        )


def _qualifying(belief: MapBelief, cells: np.ndarray, rows, cols, working) -> set[int]:
    """The cells agent 0 is no farther from (Manhattan) than any other working agent."""
    found = set()
    for v in cells.tolist():
        r, c = belief.cell(v)
        mine = abs(r - rows[0]) + abs(c - cols[0])
        rivals = [abs(r - rows[j]) + abs(c - cols[j]) for j in range(1, len(rows)) if working[j]]
        if all(m >= mine for m in rivals):
            found.add(v)
    return found


def test_memo_asks_for_a_full_pass_when_a_rival_moved_beyond_the_margin() -> None:
    """A cell a rival stood beside, left out of the shortlist, is open once the rival
    has gone far away: the memo must not answer with the old shortlist."""
    belief = MapBelief((SIDE, SIDE), (0, 0))
    far_corner = belief.index((0, SIDE - 1))
    belief.mark_free(far_corner)
    team = Team(2, (0, 0))
    team.cols[1] = SIDE - 2  # beside the far corner: nobody else's to take
    search = CompiledSearch(belief)
    listed = search.uncovered_list[: belief.uncovered_count]
    rows, cols = team.others(0)
    _lands(search)
    _, kept = uncontested_horizon(
        search.candidate,
        listed,
        belief.index((0, 0)),
        search.grid,
        (rows, cols, 0),
        16,
        search._kept,
    )
    assert far_corner not in search._kept[:kept]
    memo = HorizonMemo(team, 0)
    memo.remember(search._kept[:kept], belief)
    team.rows[1], team.cols[1] = SIDE - 1, 0  # the rival crosses the map
    shortlist = memo.shortlist(belief)
    assert shortlist is None or far_corner in shortlist


def test_memo_asks_for_a_full_pass_when_a_rival_stops_working() -> None:
    belief = MapBelief((SIDE, SIDE), (0, 0))
    belief.mark_free(belief.index((0, 1)))
    team = Team(2, (0, 0))
    team.rows[1] = team.cols[1] = 10
    memo = HorizonMemo(team, 0)
    memo.remember(np.zeros(0, dtype=np.int64), belief)
    assert memo.shortlist(belief) is not None
    team.working[1] = False
    assert memo.shortlist(belief) is None


def _swept_map(rng: np.random.Generator, seed: int, covered: float) -> tuple[MapBelief, np.ndarray]:
    """A known map, scattered walls or rooms (where the way round is long), with
    about ``covered`` of its free cells covered; and its walls."""
    if rng.random() < 0.5:
        walls, charger = rng.random((SIDE, SIDE)) < rng.uniform(0.0, 0.3), (0, 0)
    else:
        rooms = mapgen.rooms(SIDE, SIDE, seed % 1000)
        walls, charger = rooms.obstacle.copy(), rooms.charger
    walls[charger] = False
    belief = MapBelief((SIDE, SIDE), charger)
    for r, c in zip(*np.nonzero(~walls), strict=True):
        belief.mark_free(belief.index((int(r), int(c))))
    for i in list(belief.uncovered):
        if rng.random() < covered:
            belief.cover(belief.cell(i), 1)
    return belief, walls


@pytest.mark.parametrize("rivals", [CompiledSearch.RIVALS, 3])
@settings(max_examples=300, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    agents=st.integers(1, 6),
    hold=st.sampled_from([0, 2, 5]),
    steps=st.integers(1, 6),
)
def test_a_confirmed_hint_is_what_the_search_returns(
    rivals: int, seed: int, agents: int, hold: int, steps: int
) -> None:
    """An agent takes a target, walks part of the way while the others move, cells
    are covered and found (some opening shorter ways) and the battery drains or
    sags: whenever the hint (the target, the rest of the way and when it was a
    shortest way) is confirmed, the search returns the same target at
    the same rank, by a path as long, and the path is the search's or the way.
    How many rivals the check looks at one by one (``CompiledSearch.RIVALS``; a
    small map seldom has more than a few) only chooses which proof runs:
    with 3, most checks with rivals fall back to the search."""
    rng = np.random.default_rng(seed)
    belief, walls = _swept_map(rng, seed, rng.uniform(0.5, 0.98))
    team = Team(agents, (0, 0))
    free = np.argwhere(~walls)
    picks = free[rng.integers(0, len(free), agents)]
    team.rows[:], team.cols[:] = picks[:, 0], picks[:, 1]
    team.working[:] = rng.random(agents) < 0.8
    memo = HorizonMemo(team, 0)
    search = CompiledSearch(belief)
    search.rivals_most = rivals
    search._rivals = np.zeros(rivals + 1, dtype=np.int64)
    cost = float(rng.choice([0.0, 0.2, 1.0, 2.0]))
    budget = 80.0
    battery = float(rng.uniform(40.0, 100.0))
    best_cost = cost

    def ask(hint=None):
        start = belief.index((int(team.rows[0]), int(team.cols[0])))
        claims = [i for i in belief.uncovered if rng.random() < 0.02]
        args = (start, battery, cost, 20.0, best_cost, budget, team.others(0), hold, claims)
        return _run(search, *args, None, memo, hint), _run(search, *args, None, None)

    first, _ = ask()
    if first is None:
        return
    goal, way = first[1], first[2]
    known_at: tuple[int, int] | None = belief.stamp  # a shortest way, then
    for _ in range(min(steps, len(way) - 1)):
        cell = belief.cell(way.pop(0))
        team.rows[0], team.cols[0] = cell
        battery -= cost
        moved = np.clip(team.rows[1:] + rng.integers(-1, 2, agents - 1), 0, SIDE - 1)
        team.rows[1:] = moved
        team.cols[1:] = np.clip(team.cols[1:] + rng.integers(-1, 2, agents - 1), 0, SIDE - 1)
    battery -= float(rng.choice([0.0, 0.0, 5.0, 40.0]))  # a sag, or a worse estimate
    best_cost *= float(rng.choice([1.0, 1.0, 3.0]))  # the team's cheapest mover is lost
    for i in list(belief.uncovered):
        if rng.random() < 0.05 and i != goal:
            belief.cover(belief.cell(i), 1)
    gone = np.argwhere(walls)  # walls found to be passable: shorter ways, perhaps
    for r, c in gone[rng.permutation(len(gone))[: int(rng.integers(0, 40))]]:
        belief.mark_free(belief.index((int(r), int(c))))
        if rng.random() < 0.7:  # swept at once by someone: no candidate, only a way
            belief.cover((int(r), int(c)), 1)
    if rng.random() < 0.2:
        known_at = None  # a detour, say
    confirmed, searched = ask((goal, list(way), known_at))
    _as_searched(confirmed, searched)
    if confirmed is None:
        return
    assert confirmed[2] in (searched[2], way)


def _as_searched(found, searched) -> None:
    """A search's answer skipped or shortened is the full search's: none when it
    finds none, else the same target at the same rank, by a way as long."""
    assert (found is None) == (searched is None)
    if found is not None:
        assert found[:2] == searched[:2]
        assert len(found[2]) == len(searched[2])


@settings(max_examples=200, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    agents=st.integers(2, 12),
    hold=st.sampled_from([2, 5, 8]),
    pace=st.sampled_from([0.0, 0.05, 0.1, 0.3, 1.0]),
)
def test_all_left_to_others_is_what_the_search_finds(
    seed: int, agents: int, hold: int, pace: float
) -> None:
    """With the other agents amid the last uncovered cells, the shortcut that
    finds every candidate left to them (with a rival pace: or to be reached by
    them first) gives what the search gives, cell and path, or leaves the
    answer to the search."""
    rng = np.random.default_rng(seed)
    covered = rng.uniform(0.7, 0.99) if rng.random() < 0.3 else rng.uniform(0.99, 0.9995)
    belief, walls = _swept_map(rng, seed, covered)
    team = Team(agents, (0, 0))
    home = np.frombuffer(belief.charger_dist, dtype=np.int32)
    free = [c for c in np.argwhere(~walls) if home[belief.index((int(c[0]), int(c[1])))] < 1000]
    at = free[rng.integers(0, len(free))]
    team.rows[0], team.cols[0] = at
    left = [belief.cell(i) for i in belief.uncovered]
    for k in range(1, agents):  # most stand among the uncovered cells
        r, c = left[rng.integers(0, len(left))] if left and rng.random() < 0.8 else at
        team.rows[k], team.cols[k] = r + rng.integers(-1, 2), c + rng.integers(-1, 2)
    search = CompiledSearch(belief)
    cost = float(rng.choice([0.0, 0.1, 0.5, 1.0]))
    start = belief.index((int(at[0]), int(at[1])))
    args = (
        start,
        float(rng.uniform(40, 100)),
        cost,
        20.0,
        cost,
        80.0,
        team.others(0),
        hold,
        list[int](),
    )
    quick = _run(search, *args, pace=pace)
    plain = CompiledSearch(belief, SearchShortcuts(left_to_others=False))
    assert _run(plain, *args, pace=pace) == quick
    # Searching from there again, with the distances from there kept.
    still = StillField()
    assert _run(search, *args, pace=pace, still=still) == quick
    assert _run(search, *args, pace=pace, still=still) == quick


def test_left_to_a_rival_drawing_nearer_needs_no_search() -> None:
    """The last uncovered cells lie 10 cells or more from another agent and 58 moves
    or more from this one, on open ground. Beyond a hold radius of 5, they rank 1;
    with a rival pace of 0.5 that agent comes within 5 of them long before this one
    walks there (10 - 5 < 0.5 * 58): held back, told by a pass over the candidates, without
    the search, as the search itself tells."""
    belief = MapBelief((SIDE, SIDE), (0, 0))
    for r in range(SIDE):
        for c in range(SIDE):
            belief.mark_free(belief.index((r, c)))
    for i in list(belief.uncovered):
        r, c = belief.cell(i)
        if not (29 <= r <= 31 and 29 <= c <= 31):
            belief.cover((r, c), 1)
    rival = (np.array([20], dtype=np.int64), np.array([30], dtype=np.int64))
    args = (belief.index((0, 0)), 100.0, 0.1, 20.0, 0.1, 80.0, rival, 5, list[int]())
    search = CompiledSearch(belief)
    assert _run(search, *args, pace=0.5) == HELD_BACK
    assert search.counts.searches == 0
    plain = CompiledSearch(belief, SearchShortcuts(left_to_others=False))
    assert _run(plain, *args, pace=0.5) == HELD_BACK
    assert plain.counts.searches == 1
    found = _run(search, *args)  # no pace: set out for it
    assert found is not None and found[0] == 1 and belief.cell(found[1]) == (29, 29)


@settings(max_examples=100, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), rounds=st.integers(1, 6))
def test_still_field_is_the_breadth_first_distances(seed: int, rounds: int) -> None:
    """As the known map grows and cells are found blocked, the distances kept from
    where the agent stands are those of a breadth-first search of the map as known,
    and none are kept for a cell searched from only once."""
    rng = np.random.default_rng(seed)
    belief = MapBelief((SIDE, SIDE), (0, 0))
    for r, c in rng.integers(0, SIDE, size=(600, 2)):
        belief.mark_free(belief.index((int(r), int(c))))
    start = belief.index((0, 0))
    search = CompiledSearch(belief)
    still = StillField()
    assert still.distances(belief, start, search.queue) is None
    for _ in range(rounds):
        dist = still.distances(belief, start, search.queue)
        assert dist is not None
        truth = bfs_distances(belief, start)
        reached = np.flatnonzero(dist < UNREACHED)
        assert set(reached.tolist()) == set(truth)
        assert all(int(dist[v]) == d for v, d in truth.items())
        for r, c in rng.integers(0, SIDE, size=(int(rng.integers(0, 200)), 2)):
            belief.mark_free(belief.index((int(r), int(c))))
        if rng.random() < 0.3:
            free = [i for i in truth if i != start]
            if free:
                belief.block(free[int(rng.integers(0, len(free)))])
    assert still.distances(belief, belief.index((0, 1)), search.queue) is None


def _walls_opening(walls: np.ndarray, near: tuple[int, int], reach: int, sides: int) -> list:
    """Walls within ``reach`` (Manhattan) of ``near`` with ``sides`` free neighbours
    (1: a pocket, a new candidate but no shorter way; 2 or more: perhaps a shortcut)."""
    free = np.pad(~walls, 1)
    count = free[:-2, 1:-1].astype(int) + free[2:, 1:-1] + free[1:-1, :-2] + free[1:-1, 2:]
    rows, cols = np.nonzero(walls & (count == sides if sides == 1 else count >= sides))
    close = np.abs(rows - near[0]) + np.abs(cols - near[1]) <= reach
    return [(int(r), int(c)) for r, c in zip(rows[close], cols[close], strict=True)]


@settings(max_examples=500, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    steps=st.integers(1, 24),
    working=st.booleans(),
    crowd=st.sampled_from([0, 0, 2, 6]),
)
def test_a_settled_target_is_what_the_search_returns(
    seed: int, steps: int, working: bool, crowd: int
) -> None:
    """An agent walks a shortest way to the target its check found (the
    search's, or another as long), step by step, sometimes waiting, while cells
    are covered, found (pockets near it, ways shorter near it or anywhere),
    blocked, claimed and released, its battery drains by each move, sags or
    reads higher, its consumption is estimated anew, it takes a detour, and
    another agent may start working, or a crowd walks about: at every step,
    what the search returns with the target carried along (``SettledTarget``)
    and the ties it settled kept (``WayMemo.tie``) is what the plain search
    returns, at the same rank, by a way as long, the way or the search's."""
    rng = np.random.default_rng(seed)
    belief, walls = _swept_map(rng, seed, rng.uniform(0.95, 0.995))  # far targets, long ways
    search = CompiledSearch(belief)
    settled, way_memo = SettledTarget(), WayMemo()
    cost = float(rng.choice([0.0, 1.0, 1.0, 2.0]))
    battery = float(rng.uniform(40.0, 100.0))
    free = [i for i in belief.uncovered if belief.charger_dist[i] < UNREACHED]
    if len(free) < 2:
        return
    start = int(rng.choice(free))
    belief.cover(belief.cell(start), 1)  # where an agent stands is covered
    claims = [int(i) for i in rng.choice(free, size=3)]
    nobody = (np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64))
    other = (np.array([free[0] // belief.stride - 1]), np.array([free[0] % belief.stride - 1]))
    team = np.argwhere(~walls)[rng.integers(0, int((~walls).sum()), crowd)]

    def ask(hint, others=nobody):
        args = (start, battery, cost, 20.0, cost, 80.0, others, 5, claims, None, None)
        return _run(search, *args, hint, way_memo, settled), _run(search, *args)

    found, _ = ask(None)
    if found is None:
        return
    goal, way = found[1], list(found[2])
    if rng.random() < 0.5 and len(way) > 1:  # another way as short, round the search's next cell
        aside = search.path(start, goal, [way[0]])
        if aside is not None and len(aside) == len(way):
            way = aside
            ask((goal, list(way), belief.stamp))
    known_at: tuple[int, int] | None = belief.stamp
    for _ in range(steps):
        if len(way) < 2:
            return
        event = int(rng.integers(0, 13))
        if event != 0:  # else it waits
            start = way.pop(0)
            belief.cover(belief.cell(start), 1)
            battery -= cost
        here = belief.cell(start)
        if event == 1:
            battery += float(rng.choice([-5.0, 2.0]))  # a sag, or a reading higher
        elif event == 2:
            for i in rng.choice(list(belief.uncovered), size=5):
                if i != goal:
                    belief.cover(belief.cell(int(i)), 1)
        elif event in (3, 4):  # a wall seen wrong: a pocket, or perhaps a shorter way
            near = rng.random() < 0.7
            picks = _walls_opening(walls, here, len(way) if near else 2 * SIDE, event - 2)
            for k in rng.permutation(len(picks))[: int(rng.integers(1, 4))]:
                walls[picks[k]] = False
                belief.mark_free(belief.index(picks[k]))
                if event == 4 and rng.random() < 0.5:  # swept at once: only a way
                    belief.cover(picks[k], 1)
        elif event == 5 and claims:
            claims.pop()  # a claim released
        elif event == 6:
            claims.append(int(rng.choice(list(belief.uncovered))))
        elif event == 8:
            cost /= 2  # a better estimate of the agent's consumption
        elif event == 9:  # a detour round an agent in the way, longer
            detour = search.path(start, goal, [way[0]])
            if detour is not None:
                way, known_at = detour, None
        elif event == 10:  # a vehicle lost: where it stands, nobody passes
            i = int(rng.choice(list(belief.uncovered)))
            if i not in (goal, *way):
                belief.block(i)
        others = other if working and event == 7 else nobody
        if crowd:
            team = np.clip(team + rng.integers(-1, 2, team.shape), 0, SIDE - 1)
            others = (team[:, 0].astype(np.int64), team[:, 1].astype(np.int64))
        carried, searched = ask((goal, list(way), known_at), others)
        _as_searched(carried, searched)
        if carried is None:
            return
        assert list(carried[2]) in (list(searched[2]), way)
        if carried[1] != goal or len(carried[2]) < len(way):
            goal, way = carried[1], list(carried[2])
        known_at = belief.stamp


@settings(max_examples=300, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), steps=st.integers(1, 30), crowd=st.integers(1, 6))
def test_a_settled_tie_is_what_the_search_returns(seed: int, steps: int, crowd: int) -> None:
    """On open ground with candidates in mirrored pairs (as far from the agent,
    so ties are many), an agent with others at work walks the search's first
    way to its target, sometimes waiting, while cells are found (near or far),
    blocked and covered and the others walk about: at every step the check,
    with the ties it settled kept (``WayMemo.tie``), returns what the plain
    search returns."""
    rng = np.random.default_rng(seed)
    walls = rng.random((SIDE, SIDE)) < rng.uniform(0.0, 0.12)
    walls[0, 0] = False
    belief = MapBelief((SIDE, SIDE), (0, 0))
    for r, c in zip(*np.nonzero(~walls), strict=True):
        belief.mark_free(belief.index((int(r), int(c))))
    here = (int(rng.integers(5, SIDE - 5)), int(rng.integers(5, SIDE - 5)))
    keep = set()
    for _ in range(int(rng.integers(2, 12))):
        r, c = (int(x) for x in rng.integers(0, SIDE, 2))
        keep |= {(r, c), (2 * here[0] - r, c), (r, 2 * here[1] - c)}
    for i in list(belief.uncovered):
        if belief.cell(i) not in keep:
            belief.cover(belief.cell(i), 1)
    search, way_memo = CompiledSearch(belief), WayMemo()
    start = belief.index(here)
    if belief.state[start] != CellState.FREE:
        return
    belief.cover(here, 1)
    team = np.argwhere(~walls)[rng.integers(0, int((~walls).sum()), crowd)]

    def ask(hint):
        others = (team[:, 0].astype(np.int64), team[:, 1].astype(np.int64))
        args = (start, 100.0, 0.5, 20.0, 0.5, 80.0, others, 5, [], None, None)
        return _run(search, *args, hint, way_memo), _run(search, *args)

    found, _ = ask(None)
    if found is None or found[0] != 0:
        return
    goal, way, known_at = found[1], list(found[2]), belief.stamp
    for _ in range(steps):
        if len(way) < 2:
            return
        event = int(rng.integers(0, 6))
        if event != 0:
            start = way.pop(0)
            belief.cover(belief.cell(start), 1)
        at = belief.cell(start)
        if event == 2:  # a cell found free, near or anywhere
            near = _walls_opening(walls, at, len(way), 1) + _walls_opening(walls, at, len(way), 2)
            picks = near if near and rng.random() < 0.7 else _walls_opening(walls, at, SIDE, 1)
            if picks:
                cell = picks[int(rng.integers(0, len(picks)))]
                walls[cell] = False
                belief.mark_free(belief.index(cell))
        elif event == 3:  # blocked: a vehicle lost there
            i = int(rng.choice(np.flatnonzero(~walls.ravel())))
            cell = (i // SIDE, i % SIDE)
            if belief.index(cell) not in (goal, start, *way):
                walls[cell] = True
                belief.block(belief.index(cell))
        elif event == 4 and len(belief.uncovered) > 1:
            i = int(rng.choice([i for i in belief.uncovered if i != goal]))
            belief.cover(belief.cell(i), 1)
        team = np.clip(team + rng.integers(-1, 2, team.shape), 0, SIDE - 1)
        checked, searched = ask((goal, list(way), known_at))
        _as_searched(checked, searched)
        if checked is None or checked[0] != 0:
            return
        if checked[1] != goal or len(checked[2]) < len(way):
            goal, way = checked[1], list(checked[2])
        known_at = belief.stamp


def _belief_of(free: list[tuple[int, int]], uncovered: list[tuple[int, int]]) -> MapBelief:
    """A 7x7 map known to be these free cells, all covered but ``uncovered``."""
    belief = MapBelief((7, 7), (0, 0))
    for cell in free:
        belief.mark_free(belief.index(cell))
    for cell in free:
        if cell not in uncovered:
            belief.cover(cell, 1)
    return belief


_NOBODY = (np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64))


@pytest.mark.parametrize("others", ["none", "far"])
def test_a_target_is_carried_only_along_the_searchs_first_way(others: str) -> None:
    """From (3, 3) the search reaches (4, 4) by S, E before (2, 4) (N is a wall):
    the target. On a way as short that steps E first, (2, 4) is the first
    reached from there: neither the target (no other agent at work) nor the
    tie between the two (another at work, too far to contest either) is
    carried along that way."""
    free = [(r, c) for r in range(7) for c in range(7) if (r, c) != (2, 3)]
    belief = _belief_of(free, [(4, 4), (2, 4)])
    search, settled, way_memo = CompiledSearch(belief), SettledTarget(), WayMemo()
    start, goal, rival, aside = (belief.index(c) for c in ((3, 3), (4, 4), (2, 4), (3, 4)))
    team = _NOBODY if others == "none" else (np.array([6]), np.array([0]))
    args = (100.0, 0.0, 20.0, 0.0, 80.0, team, 5, list[int]())
    found = _run(search, start, *args)
    assert found is not None and found[1] == goal
    # On the way aside (a detour, say), the check keeps it, as short as the search's.
    hint = (goal, [aside, goal], belief.stamp)
    assert _run(search, start, *args, None, None, hint, way_memo, settled) == (
        0,
        goal,
        [aside, goal],
    )
    assert way_memo.tie.goal == goal and settled.goal == (goal if others == "none" else -1)
    found = _run(search, aside, *args, None, None, (goal, [goal], belief.stamp), way_memo, settled)
    assert found == _run(search, aside, *args) == (0, rival, [rival])


@pytest.mark.parametrize("change", ["the wall is found open", "the rival nearer is left"])
def test_a_tie_is_not_kept_once_a_rival_comes_first(change: str) -> None:
    """From (3, 3), with N a wall, the search reaches (4, 4) by S, E before
    (2, 4) by E, N; (5, 3), first of all by S, S, is left to the agent at
    (6, 3). The agent waits. Then the wall turns out open ((2, 4) by N, E
    comes first), or the agent at (6, 3) moves off ((5, 3) comes first): the
    tie kept is not what the check returns."""
    free = [(r, c) for r in range(7) for c in range(7) if (r, c) != (2, 3)]
    belief = _belief_of(free, [(4, 4), (2, 4), (5, 3)])
    search, way_memo = CompiledSearch(belief), WayMemo()
    start, goal = belief.index((3, 3)), belief.index((4, 4))
    energy = (100.0, 0.0, 20.0, 0.0, 80.0)
    beside = (np.array([6]), np.array([3]))
    found = _run(search, start, *energy, beside, 5, [])
    assert found is not None and found[1] == goal
    hint = (goal, list(found[2]), belief.stamp)
    assert _run(search, start, *energy, beside, 5, [], None, None, hint, way_memo) == found
    assert way_memo.tie.goal == goal and way_memo.tie.rival == belief.index((2, 4))
    team, first = beside, (2, 4)
    if change == "the wall is found open":
        belief.mark_free(belief.index((2, 3)))
        belief.cover((2, 3), 1)
    else:
        team, first = (np.array([6]), np.array([0])), (5, 3)
    args = (start, *energy, team, 5, list[int](), None, None)
    checked = _run(search, *args, hint, way_memo)
    assert checked == _run(search, *args)
    assert checked is not None and checked[1] == belief.index(first)


@pytest.mark.parametrize("change", ["a shorter way home", "a higher reading"])
def test_a_target_is_not_carried_once_a_nearer_one_is_affordable(change: str) -> None:
    """From (2, 6), (0, 5) and (5, 6) are three moves away, (0, 5) first; but
    its way home round the map is too long for the battery, so (5, 6) is the
    target. The agent waits; then the wall between (0, 5) and the charger turns
    out open (far from the agent: a shorter way home, no nearer candidate), or
    the battery reads higher: (0, 5) is affordable and the target."""
    ring = [(r, 0) for r in range(7)] + [(6, c) for c in range(1, 7)]
    free = ring + [(r, 6) for r in range(6)] + [(0, 4), (0, 5)]
    belief = _belief_of(free, [(0, 5), (5, 6)])
    search, settled = CompiledSearch(belief), SettledTarget()
    start, goal, nearer = (belief.index(c) for c in ((2, 6), (5, 6), (0, 5)))
    battery = 40.0
    found = _run(
        search,
        start,
        battery,
        1.0,
        20.0,
        1.0,
        80.0,
        _NOBODY,
        5,
        [],
        None,
        None,
        None,
        None,
        settled,
    )
    assert found is not None and found[1] == goal
    known_at = belief.stamp
    if change == "a higher reading":
        battery += 4.0
    else:
        for cell in ((0, 1), (0, 2), (0, 3)):
            belief.mark_free(belief.index(cell))
    args = (start, battery, 1.0, 20.0, 1.0, 80.0, _NOBODY, 5, list[int](), None, None)
    carried = _run(search, *args, (goal, list(found[2]), known_at), None, settled)
    assert carried == _run(search, *args)
    assert carried is not None and carried[1] == nearer


def _true_distances(walls: np.ndarray, source: tuple[int, int]) -> np.ndarray:
    distance = np.full(walls.shape, -1)
    distance[source] = 0
    frontier = [source]
    while frontier:
        following = []
        for r, c in frontier:
            for nr, nc in ((r - 1, c), (r + 1, c), (r, c - 1), (r, c + 1)):
                inside = 0 <= nr < walls.shape[0] and 0 <= nc < walls.shape[1]
                if inside and not walls[nr, nc] and distance[nr, nc] < 0:
                    distance[nr, nc] = distance[r, c] + 1
                    following.append((nr, nc))
        frontier = following
    return distance


@settings(max_examples=300, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    known=st.floats(0.1, 0.9),
    found=st.floats(0.0, 1.0),
)
def test_a_way_still_shortest_has_none_shorter(seed: int, known: float, found: float) -> None:
    """A shortest way between two cells of a partly explored rooms map; more of the
    map is found (a wavefront from the charger, ragged): whenever
    ``_still_shortest`` says the way is still a shortest one, no shorter one
    opened. The cells found lie within the Manhattan bound of ways round
    walls, so the charger's distances (the landmark bound) decide."""
    rng = np.random.default_rng(seed)
    grid = mapgen.rooms(SIDE, SIDE, seed % 1000)
    walls, charger = grid.obstacle.copy(), grid.charger
    walls[charger] = False
    reach = _true_distances(walls, charger)
    cells = np.argwhere(reach >= 0)
    order = cells[np.argsort(reach[reach >= 0] + rng.uniform(0, 8, len(cells)), kind="stable")]
    belief = MapBelief((SIDE, SIDE), charger)
    first = int(known * len(order))
    for r, c in order[:first]:
        belief.mark_free(belief.index((int(r), int(c))))
    search = CompiledSearch(belief)
    home = np.frombuffer(belief.charger_dist, dtype=np.int32)
    known_cells = (belief.index((int(r), int(c))) for r, c in order[:first])
    ends = [i for i in known_cells if home[i] < UNREACHED]  # joined to the known map
    start, goal = (ends[k] for k in rng.integers(0, len(ends), 2))
    way = search.path(start, goal)
    assert way is not None
    known_at = belief.stamp
    for r, c in order[first : first + int(found * (len(order) - first))]:
        belief.mark_free(belief.index((int(r), int(c))))
    search.update_lands()  # as ``run`` does before it asks
    if search._still_shortest(start, goal, len(way), known_at):
        shortest = search.path(start, goal)
        assert shortest is not None and len(shortest) == len(way)


def _behind_a_wall(uncovered: list[tuple[int, int]]) -> MapBelief:
    """A known 22x12 map, charger in the corner, a two-cell wall at (9, 4)-(9, 5)
    between (10, 5) and (8, 5); every cell covered but ``uncovered``."""
    belief = MapBelief((22, 12), (0, 0))
    wall = {(9, 4), (9, 5)}
    for r in range(22):
        for c in range(12):
            if (r, c) not in wall:
                belief.mark_free(belief.index((r, c)))
    for i in list(belief.uncovered):
        if belief.cell(i) not in uncovered:
            belief.cover(belief.cell(i), 1)
    return belief


def _walk_case(seed: int, agents: int):
    """A known map (scattered walls or rooms), partly sensed, a start on it, its
    uncovered cells with their lower bounds from the start (``way_at_least``),
    other agents and an energy state."""
    rng = np.random.default_rng(seed)
    swept, _ = _swept_map(rng, seed, rng.uniform(0.0, 0.9))
    # Sensed a little: unknown cells among the known (as found, so that the distances
    # from the landmarks are those of the known map).
    belief = MapBelief(swept.shape, swept.charger)
    for i in range(len(swept.state)):
        known = i not in swept.uncovered or rng.random() >= 0.1
        if swept.state[i] == int(CellState.FREE) and known:
            belief.mark_free(i)
            if i not in swept.uncovered:
                belief.cover(belief.cell(i), 1)
    search = CompiledSearch(belief)
    lands = _lands(search)
    free = [i for i in range(len(belief.state)) if belief.state[i] == int(CellState.FREE)]
    start = free[int(rng.integers(0, len(free)))]
    stride = belief.stride
    bounds = {v: lower_bounds.way_at_least(start, v, stride, lands) for v in belief.uncovered}
    bounds = {v: b for v, b in sorted(bounds.items()) if b < UNREACHED // 2}  # else unreachable
    others = (rng.integers(0, SIDE, agents), rng.integers(0, SIDE, agents))
    energy = (float(rng.uniform(20.0, 100.0)), float(rng.choice([0.0, 0.5])), 20.0, 0.5, 80.0)
    return rng, search, lands, start, bounds, others, energy


def _walk_cases(test):
    """The cases of the walk tests: a map (``_walk_case``), the others, the hold
    radius and the worst rank taken."""
    cases = given(
        seed=st.integers(0, 2**32 - 1),
        agents=st.integers(0, 6),
        hold=st.sampled_from([0, 2, 5]),
        rank=st.integers(0, 2),
    )
    return settings(max_examples=300, deadline=None)(cases(test))


def _walked(walk, search: CompiledSearch, lands, targets, start, bound, rank, hold, others, energy):
    search.stamp += walks.AMONG_MARKS
    grid = (search.state, search.belief.stride, lands)
    scratch = (search.seen, search.parent, search.queue)
    rivals = (*others, hold)
    found = walk(
        grid, search.candidate, targets, (start, bound, rank, search.stamp), rivals, energy, scratch
    )
    return found, search._unwind(start, found[1]) if found[1] >= 0 else None


def _any_targets(rng, bounds: dict[int, int]) -> tuple[np.ndarray, int]:
    """Some of the uncovered cells (few or many), in any order, and a bound at
    least as far as the nearest of them by ``bounds``."""
    near = list(bounds)
    picked = [v for v in near if rng.random() < float(rng.choice([0.01, 0.05, 0.3]))]
    if not picked:
        picked = [near[int(rng.integers(0, len(near)))]]
    bound = min(bounds[v] for v in picked) + int(rng.integers(0, 2 * SIDE))
    return np.array(rng.permutation(picked), dtype=np.int64), bound


@_walk_cases
def test_targets_as_far_as_the_bound_are_found_as_breadth_first(
    seed: int, agents: int, hold: int, rank: int
) -> None:
    """With no target nearer than the bound by its lower bounds (the Manhattan
    distance, or a landmark's: in rooms most are), the depth-first walk finds
    the target the breadth-first search reaches first, by the same path, on
    maps of scattered walls, rooms and unknown cells."""
    rng, search, lands, start, bounds, others, energy = _walk_case(seed, agents)
    if not bounds:
        return
    far = list(bounds)[int(rng.integers(0, len(bounds)))]
    bound = max(1, bounds[far])
    ring = [v for v, b in bounds.items() if b == bound]
    beyond = [v for v, b in bounds.items() if b > bound]
    picked = [v for v in ring if rng.random() < 0.3] + [v for v in beyond if rng.random() < 0.02]
    targets = np.array(rng.permutation(picked), dtype=np.int64)
    case = (search, lands, targets, start, bound, rank, hold, others, energy)
    walked = _walked(walk_back.first_tied, *case)
    assert walked == _walked(walks.first_reached, *case)


@_walk_cases
def test_first_among_is_what_the_breadth_first_search_reaches(
    seed: int, agents: int, hold: int, rank: int
) -> None:
    """``first_among`` (a walk out to the least lower bound first, then the
    search) returns what the breadth-first search bounded to the same targets
    does, by the same path, whatever their bounds."""
    rng, search, lands, start, bounds, others, energy = _walk_case(seed, agents)
    if not bounds:
        return
    targets, bound = _any_targets(rng, bounds)
    case = (search, lands, targets, start, bound, rank, hold, others, energy)
    walked = _walked(walks.first_among, *case)
    assert walked == _walked(walks.first_reached, *case)


@_walk_cases
def test_the_search_back_finds_what_the_search_forward_does(
    seed: int, agents: int, hold: int, rank: int
) -> None:
    """``first_back`` (from the targets back to the start, then down to the
    nearest) returns what the breadth-first search from the start does, by
    the same path, or says that only that search can tell, whatever the
    targets and their bounds. Where the nearest target's lower bound is
    short of its distance, another agent is put as near to it as that bound:
    uncontested there, the target is taken from the agent (which takes
    uncontested targets only) at its distance, and the search forward goes
    on past it."""
    rng, search, lands, start, bounds, others, energy = _walk_case(seed, agents)
    if not bounds:
        return
    targets, bound = _any_targets(rng, bounds)
    distance = bfs_distances(search.belief, start)
    nearest = min(targets.tolist(), key=lambda v: distance.get(v, UNREACHED))
    if bounds[nearest] < distance.get(nearest, UNREACHED):
        row, col = divmod(nearest, search.belief.stride)
        others = (np.append(others[0], row - 1 + bounds[nearest]), np.append(others[1], col - 1))
        rank = 0
    case = (search, lands, targets, start, bound, rank, hold, others, energy)
    back = _walked(walk_back.first_back, *case)
    if back[0][0] != -2:
        assert back == _walked(walks.first_reached, *case)


@settings(max_examples=200, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), agents=st.integers(1, 8))
def test_none_uncontested_only_when_none_is(seed: int, agents: int) -> None:
    """The proof that no candidate is uncontested holds by the true distances: no
    candidate the agent can afford is as near to it as to every other agent;
    when it fails, one is (or there were too many to look at)."""
    rng = np.random.default_rng(seed)
    belief, walls = _swept_map(rng, seed, rng.uniform(0.3, 0.99))
    search = CompiledSearch(belief)
    free = np.argwhere(~walls)
    picks = free[rng.integers(0, len(free), agents + 1)]
    start = belief.index((int(picks[0, 0]), int(picks[0, 1])))
    others = (picks[1:, 0].astype(np.int64), picks[1:, 1].astype(np.int64))
    battery, cost = float(rng.uniform(20.0, 100.0)), float(rng.choice([0.0, 0.5, 1.0]))
    energy = (battery, cost, 20.0, 0.5, float(rng.choice([30.0, 80.0])))
    listed = search.uncovered_list[: belief.uncovered_count]
    found = search._rivals[:-1]
    search.stamp += 1
    _lands(search)
    proved = walks.none_uncontested(
        search.grid, search.candidate, listed, start, (*others, 0), energy,
        (found, search._spare, search.stamp),
    )  # fmt: skip
    distance = bfs_distances(belief, start)
    uncontested = []
    for v in belief.uncovered - {start}:  # the search never takes the cell it starts from
        back, d = int(search.home[v]), distance.get(v)
        if d is None or back >= UNREACHED or 2.0 * back * 0.5 > energy[4]:
            continue
        if battery - cost * (d + back) < 20.0:
            continue
        r, c = belief.cell(v)
        if min(abs(r - others[0]) + abs(c - others[1])) >= d:
            uncontested.append(v)
    if proved:
        assert uncontested == []
    else:
        assert uncontested or belief.uncovered_count >= found.size


def _breadth_first(belief: MapBelief, start: int) -> tuple[list[int], dict[int, int]]:
    """Every known free cell reached from ``start``, in the order the compiled
    searches reach them (N, S, E, W), and the parent of each."""
    order, parent = [start], {start: start}
    for u in order:
        for step in belief.steps:
            v = u + step
            if belief.state[v] == int(CellState.FREE) and v not in parent:
                parent[v] = u
                order.append(v)
    return order, parent


@settings(max_examples=200, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    agents=st.integers(1, 12),
    hold=st.sampled_from([1, 2, 5]),
)
def test_first_lesser_is_the_first_the_search_reaches(seed: int, agents: int, hold: int) -> None:
    """The first candidate that ranks 1 or better, found from the lower bounds
    without searching the map around the agent, is the first of them a
    breadth-first search reaches, at its distance, by its path."""
    rng = np.random.default_rng(seed)
    belief, walls = _swept_map(rng, seed, rng.uniform(0.0, 0.95))
    search = CompiledSearch(belief)
    free = np.argwhere(~walls)
    picks = free[rng.integers(0, len(free), agents + 1)]
    start = belief.index((int(picks[0, 0]), int(picks[0, 1])))
    others = (picks[1:, 0].astype(np.int64), picks[1:, 1].astype(np.int64))
    battery, cost = float(rng.uniform(20.0, 100.0)), float(rng.choice([0.0, 0.5, 1.0]))
    budget = float(rng.choice([30.0, 80.0]))
    energy = (battery, cost, 20.0, 0.5, budget)
    everyone = search.uncovered_list[: belief.uncovered_count]
    roomy = np.zeros(len(belief.state), dtype=np.int64)  # never too many to list
    search.stamp += 1
    _lands(search)
    rank, cell, d = walks.first_lesser(
        search.grid, search.candidate, everyone, start, (*others, hold), energy,
        (roomy, search._spare, 8 * search.stamp),
    )  # fmt: skip
    order, parent = _breadth_first(belief, start)
    depth = {start: 0}
    for v in order[1:]:
        depth[v] = depth[parent[v]] + 1

    def near(v: int) -> int:
        r, c = belief.cell(v)
        return int(min(abs(r - others[0]) + abs(c - others[1])))

    def in_range(v: int, moves: int) -> bool:
        back = int(search.home[v])
        return 2.0 * back * 0.5 <= budget and battery - cost * (moves + back) >= 20.0

    expected = None
    for v in order[1:]:
        uncovered = belief.uncovered_mask[v] and in_range(v, depth[v])
        if uncovered and near(v) >= min(depth[v], hold + 1):
            expected = (0 if near(v) >= depth[v] else 1, v, depth[v])
            break
    if rank < 0:
        # Left to the search: only when none ranks so, or the first lies beyond
        # the widened bounds (the least lower bound of those that may, plus 7).
        bounds = []
        for v in belief.uncovered:
            mine = lower_bounds.way_at_least(v, start, belief.stride, search.lands)
            if in_range(v, mine) and near(v) >= min(mine, hold + 1):
                bounds.append(mine)
        assert expected is None or expected[2] > min(bounds) + 7
        return
    assert (rank, cell, d) == expected
    way, v = [], cell
    while v != start:
        way.append(v)
        v = int(search._spare[2][v])
    assert way == _unwound(parent, start, cell)


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), agents=st.integers(5, 40), hold=st.sampled_from([2, 5]))
def test_a_search_through_a_crowd_ranks_as_breadth_first(seed: int, agents: int, hold: int) -> None:
    """On a map large enough for the search to jump past a crowd (every candidate
    near the agent left to another), it returns what a plain breadth-first
    ranking returns: the first uncontested candidate reached, else the first
    of the next rank if none is uncontested, by the same path."""
    rng = np.random.default_rng(seed)
    side = 140
    walls = rng.random((side, side)) < rng.uniform(0.0, 0.1)
    belief = MapBelief((side, side), (0, 0))
    walls[0, 0] = False
    for r, c in zip(*np.nonzero(~walls), strict=True):
        belief.mark_free(belief.index((int(r), int(c))))
    centre = np.array([side // 2, side // 2])
    free = np.argwhere(~walls)
    crowd = free[np.abs(free - centre).sum(axis=1) < 50]
    picks = crowd[rng.integers(0, len(crowd), agents + 1)]
    picks[0] = crowd[np.abs(crowd - centre).sum(axis=1).argmin()]
    start = belief.index((int(picks[0, 0]), int(picks[0, 1])))
    others = (picks[1:, 0].astype(np.int64), picks[1:, 1].astype(np.int64))
    # Swept around the middle but beside the other agents (left to them), and
    # here and there beyond them.
    for i in list(belief.uncovered):
        r, c = belief.cell(i)
        beside = int(min(abs(r - others[0]) + abs(c - others[1]))) <= 2
        inside = abs(r - centre[0]) + abs(c - centre[1]) < 60
        if (inside and not beside) or (not inside and rng.random() < 0.9):
            belief.cover((r, c), 1)
    search = CompiledSearch(belief)
    found = _run(search, start, 100.0, 0.1, 20.0, 0.1, 80.0, others, hold, [])
    order, parent = _breadth_first(belief, start)
    depth = {start: 0}
    best: dict[int, int] = {}
    for v in order[1:]:
        depth[v] = depth[parent[v]] + 1
        back = int(search.home[v])
        if not belief.uncovered_mask[v] or 100.0 - 0.1 * (depth[v] + back) < 20.0:
            continue
        r, c = belief.cell(v)
        near = int(min(abs(r - others[0]) + abs(c - others[1])))
        rank = 0 if near >= depth[v] else 1 if near >= min(depth[v], hold + 1) else 2
        best.setdefault(rank, v)
    if not best:
        assert found is None
        return
    rank = min(best)
    assert found is not None
    assert found[:2] == (rank, best[rank])
    assert found[2] == _unwound(parent, start, best[rank])[::-1]


def _unwound(parent: dict[int, int], start: int, goal: int) -> list[int]:
    """The path to ``goal`` in ``parent``, goal first, the start left out."""
    way, v = [], goal
    while v != start:
        way.append(v)
        v = parent[v]
    return way


def test_a_candidate_reached_first_is_taken_only_if_affordable_there() -> None:
    """A candidate two cells away behind a wall is reached before the target on the
    way, and could be afforded were it as near as it looks, but not by the way
    round: the target stands, as the search says."""
    start, behind, goal = (10, 5), (8, 5), (10, 0)
    belief = _behind_a_wall([behind, goal])
    search = CompiledSearch(belief)
    nobody = (np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64))
    way = [belief.index((10, c)) for c in range(4, -1, -1)]
    # Battery 36, 1 a move, floor 20: the target costs 5 + 10 home; the cell behind
    # the wall 2 + 13 as the crow flies (its distance home, 13, is no help: the
    # start's is 15), but 4 + 13 by the way round.
    args = (belief.index(start), 36.0, 1.0, 20.0, 1.0, 80.0, nobody, 5, list[int]())
    searched = _run(search, *args)
    confirmed = _run(search, *args, None, None, (belief.index(goal), way, None))
    assert searched is not None and searched[1] == belief.index(goal)
    assert confirmed is not None and confirmed[:2] == searched[:2]
    assert len(confirmed[2]) == len(searched[2])


@settings(max_examples=200, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    battery=st.floats(20.0, 100.0),
    cost=st.sampled_from([0.0, 0.1, 0.5, 1.0]),
    count=st.integers(1, 6),
)
def test_surely_affordable_only_when_one_is_by_the_shortest_way(
    seed: int, battery: float, cost: float, count: int
) -> None:
    """The held-back agent's proof (a way through a landmark) says a target is
    affordable only when it is by the shortest ways, to it and home; and
    whenever it is with a charge to spare for the detour through the charger."""
    rng = np.random.default_rng(seed)
    belief, walls = _swept_map(rng, seed, 0.0)
    home = _true_distances(walls, belief.charger)
    reached = np.argwhere(home >= 0)
    row, col = reached[rng.integers(0, len(reached))]
    at = (int(row), int(col))
    picked = [
        (int(reached[i][0]), int(reached[i][1])) for i in rng.integers(0, len(reached), count)
    ]
    from_start = _true_distances(walls, at)
    floor = 20.0
    energy = (battery, cost, floor, cost, 80.0)
    lands = _lands(CompiledSearch(belief))
    targets = np.array([belief.index(t) for t in picked], dtype=np.int64)
    sure = lower_bounds.surely_affordable(targets, belief.index(at), lands, energy)
    if sure:
        assert any(battery - cost * (from_start[t] + home[t]) >= floor for t in picked)
    if any(battery - cost * (home[at] + 2 * home[t]) >= floor for t in picked):
        assert sure  # through the charger, the landmark every search has


def test_left_to_others_counts_only_if_affordable_by_the_way_there() -> None:
    """The last candidate, behind a wall, is left to an agent beside it: the agent
    would be held back if it could afford it, which it could as the crow flies
    but not by the way round. So the shortcut finds nothing, as the search says."""
    start, behind = (10, 5), (8, 5)
    belief = _behind_a_wall([behind])
    search = CompiledSearch(belief)
    beside = (np.array([7], dtype=np.int64), np.array([5], dtype=np.int64))
    # Battery 36, 1 a move, floor 20: 2 + 13 home as the crow flies, 4 + 13 round.
    args = (belief.index(start), 36.0, 1.0, 20.0, 1.0, 80.0, beside, 5, list[int]())
    assert _run(search, *args) is None
    plain = CompiledSearch(belief, SearchShortcuts(left_to_others=False))
    assert _run(plain, *args) is None
    args = (belief.index(start), 37.0, *args[2:])  # now it can: held back
    found = _run(search, *args)
    assert found is not None and found[0] == 2


def test_a_way_round_stands_until_a_shorter_one_opens() -> None:
    """The way round a wall to the last uncovered cell is confirmed as it stands
    while the map only grows elsewhere; not once a cell on it is blocked, nor
    once a gap opens in the wall: then the search's path is the answer."""
    belief = MapBelief((12, 12), (11, 0))
    wall = {(r, 5) for r in range(10)}
    for r in range(12):
        for c in range(12):
            if (r, c) not in wall:
                belief.mark_free(belief.index((r, c)))
    start, goal = belief.index((0, 3)), belief.index((0, 8))
    for i in list(belief.uncovered):
        if i != goal:
            belief.cover(belief.cell(i), 1)
    search = CompiledSearch(belief)
    nobody = (np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64))
    args = (start, 100.0, 0.0, 20.0, 0.0, 80.0, nobody, 5, list[int]())
    found = _run(search, *args)
    assert found is not None
    _, _, way = found
    assert len(way) == 25  # down, through the gap at the bottom, and up
    known_at = belief.stamp
    searched = (search.counts.searches, search.counts.bounded)

    belief.mark_free(belief.index((11, 11)))  # the map grows far from any shorter way
    belief.cover((11, 11), 1)
    assert _run(search, *args, None, None, (goal, way, known_at)) == (0, goal, way)
    # The way stood as it was, without a search, bounded or not.
    assert (search.counts.searches, search.counts.bounded) == searched

    belief.block(belief.index((10, 5)))  # a lost vehicle in the gap the way went through
    confirmed = _run(search, *args, None, None, (goal, way, known_at))
    assert confirmed == _run(search, *args)
    assert confirmed is not None and len(confirmed[2]) == 27

    belief.mark_free(belief.index((0, 5)))  # a gap in the wall, swept at once
    belief.cover((0, 5), 1)
    confirmed = _run(search, *args, None, None, (goal, way, known_at))
    assert confirmed == _run(search, *args)
    assert confirmed is not None and len(confirmed[2]) == 5


@settings(max_examples=150, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    moves=st.integers(1, 30),
    walked=st.integers(0, 8),
    shortened=st.integers(0, 8),
)
def test_way_memo_holds_every_candidate_in_reach(
    seed: int, moves: int, walked: int, shortened: int
) -> None:
    """After the agent walked on, cells were found and covered and claims changed,
    the memo hands out every candidate within the way's length now (by Manhattan
    distance), or says it cannot tell: when the agent came farther than the way
    shortened, or heads for another target."""
    rng = np.random.default_rng(seed)
    belief = MapBelief((SIDE, SIDE), (0, 0))
    for r, c in rng.integers(0, SIDE, size=(400, 2)):
        belief.mark_free(belief.index((int(r), int(c))))
    search = CompiledSearch(belief)
    candidate, stride = search.candidate, belief.stride
    uncovered = search.uncovered_list[: belief.uncovered_count].copy()
    start, goal = (int(v) for v in rng.choice(uncovered, 2, replace=False))
    claimed = rng.choice(uncovered, 5, replace=False).astype(np.int64)
    claimed = claimed[claimed != goal]
    _lands(search)
    energy = (100.0, 0.0, 0.0, 0.0, 100.0)
    nobody = np.zeros(0, dtype=np.int64)
    memo = WayMemo()
    candidate[claimed] = 0
    room = memo.room(uncovered.size)
    _, kept = lower_bounds.rivals_listed(
        candidate, uncovered, (start, goal, moves, 0), search.grid, (nobody, nobody, 0), energy,
        (search._rivals[:-1], room),
    )  # fmt: skip
    candidate[claimed] = 1  # released: uncovered, as they were
    memo.keep(kept, start, goal, moves, belief, claimed)
    # The agent walks on (perhaps through the unknown: only its distance counts).
    r, c = divmod(start, stride)
    for _ in range(walked):
        dr, dc = ((1, 0), (-1, 0), (0, 1), (0, -1))[int(rng.integers(4))]
        if 1 <= r + dr <= SIDE and 1 <= c + dc <= SIDE:
            r, c = r + dr, c + dc
    now = r * stride + c
    for rr, cc in rng.integers(0, SIDE, size=(60, 2)):
        belief.mark_free(belief.index((int(rr), int(cc))))
    for v in rng.choice(search.uncovered_list[: belief.uncovered_count], 20, replace=False):
        if int(v) not in (now, goal):
            belief.cover(belief.cell(int(v)), 1)
    still = claimed[rng.random(claimed.size) < 0.5]
    moves_now = max(0, moves - shortened)
    pool = memo.listed(now, goal, moves_now, belief, UNREACHED)
    came = abs(r - start // stride) + abs(c - start % stride)
    assert memo.listed(now, goal + 1, moves_now, belief, UNREACHED) is None
    if came > moves - moves_now:
        assert pool is None
        return
    assert pool is not None
    held = set(pool.tolist())
    for v in search.uncovered_list[: belief.uncovered_count].tolist():
        near = abs(v // stride - r) + abs(v % stride - c) <= moves_now
        if near and v != goal and v not in still:
            assert v in held, f"candidate {belief.cell(v)} in reach was not handed out"


@settings(max_examples=100, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    known=st.floats(0.2, 1.0),
    agents=st.integers(0, 12),
    spare=st.integers(-2, 6),
)
def test_paths_are_those_of_the_plain_search(
    seed: int, known: float, agents: int, spare: int
) -> None:
    """Bounded by the landmarks (chosen on a partly known rooms map, then more
    of it found), with other agents' cells not entered: the same path, cell for
    cell, as the plain breadth-first search; with ``longest``, that path when
    it is no longer, else none."""
    rng = np.random.default_rng(seed)
    grid = mapgen.rooms(SIDE, SIDE, seed % 1000)
    belief = MapBelief((SIDE, SIDE), grid.charger)
    search = CompiledSearch(belief)
    walls = grid.obstacle.copy()
    walls[grid.charger] = False
    reach = _true_distances(walls, grid.charger)
    cells = np.argwhere(reach >= 0)  # found as a ragged wavefront from the charger
    free = [belief.index((int(r), int(c))) for r, c in cells]
    order = np.argsort(reach[reach >= 0] + rng.uniform(0, 8, len(cells)), kind="stable")
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(landmarks, "DETOUR", 0.0)
        for k in order[: len(free) // 3]:
            belief.mark_free(free[k])
        search.update_lands()
        for k in order[len(free) // 3 : int(known * len(free))]:
            belief.mark_free(free[k])
        reached = [i for i in free if belief.charger_dist[i] < UNREACHED]
        start, goal = (int(reached[k]) for k in rng.integers(0, len(reached), 2))
        blocked = {int(i) for i in rng.choice(reached, size=agents)} - {start, goal}
        plain = shortest_path(belief, start, goal, blocked)
        assert search.path(start, goal, blocked) == plain
        if plain is not None:
            longest = len(plain) + spare
            expected = plain if spare >= 0 else None
            assert search.path(start, goal, blocked, longest) == expected
    assert len(search.landmarks.cells) > 1  # the landmarks did bound the searches
