"""The target search of a blocked agent, compiled with numba.

A blocked agent ranks every reachable uncovered cell against the rest of the
team (see ``Coordinator._nearest_affordable``); in a large team most searches
cover the whole known map, which in pure Python is most of the planner's
time. This is the same breadth-first search (same N, S, E, W order, same
ranks, same tie-breaks, so the same plans) over the belief's flat arrays,
compiled to machine code.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np
from numba import njit

from planner.belief import UNREACHED, MapBelief
from planner.bounded_search import (
    AMONG_MARKS,
    JUMP_AFTER,
    JUMP_TRIES,
    first_among,
    first_lesser,
    in_square,
    landmark_gap,
    nearest_manhattan,
    none_between,
    none_uncontested,
    rivals_listed,
    surely_affordable,
    target_rank,
    way_at_least,
)
from planner.grid import CellState
from planner.landmarks import HOME, Landmarks
from planner.settings import SearchShortcuts
from planner.settled_target import SettledTarget, SettledTie
from planner.target_search import (
    HELD_BACK,
    Energy,
    Found,
    SearchMemory,
    SearchRequest,
)
from planner.team import Team

_FREE = int(CellState.FREE)
ALL_SHORTCUTS = SearchShortcuts()
#: The marks of the spare ``seen`` one ``_search`` may use: ``first_lesser``'s,
#: and one for each ``none_uncontested``.
_SPARE_MARKS = AMONG_MARKS * JUMP_TRIES + 2


@njit(cache=True, nogil=True)
def _uncontested_horizon(
    candidate: np.ndarray,
    listed: np.ndarray,
    start: int,
    stride: int,
    others_r: np.ndarray,
    others_c: np.ndarray,
    margin: int,
    kept: np.ndarray,
    lands: np.ndarray,
) -> tuple[int, int]:
    """The largest distance at which a candidate could still be uncontested.

    A candidate ``v`` at path distance ``d`` is uncontested when every other
    agent is at least ``d`` away (Manhattan); as ``d`` is at least the
    Manhattan distance from the start, and the difference of the two cells'
    distances from a landmark (``landmark_gap``), only candidates that no
    other agent is nearer to than that can be, and none farther than its
    distance to the nearest other agent. One pass over the ``listed`` cells
    (those still marked in ``candidate`` count), far cheaper than a search of
    the map.

    With ``margin`` >= 0 the pass also keeps, in ``kept``, every listed cell
    (marked or not: a claim may be released) that no other agent is more than
    ``margin`` nearer to than the start is, and returns their count (else -1):
    see ``HorizonMemo``.
    """
    if others_r.size == 0:
        return UNREACHED, -1
    r0 = start // stride - 1
    c0 = start % stride - 1
    horizon = -1
    n = others_r.size
    count = 0
    closer = 0  # the agent found nearer than us last: neighbouring candidates likely share it
    for k in range(listed.size):
        v = listed[k]
        if margin < 0 and candidate[v] == 0:
            continue
        r = v // stride - 1
        c = v % stride - 1
        mine = abs(r - r0) + abs(c - c0)
        floor = mine - margin if margin > 0 else mine
        if abs(r - others_r[closer]) + abs(c - others_c[closer]) < floor:
            continue
        nearest_other = UNREACHED
        for i in range(n):
            j = closer + i
            if j >= n:
                j -= n
            m = abs(r - others_r[j]) + abs(c - others_c[j])
            if m < nearest_other:
                nearest_other = m
                if m < floor:
                    closer = j
                    break
        if nearest_other < floor:
            continue
        if margin >= 0:
            kept[count] = v
            count += 1
        if (
            candidate[v] != 0
            and nearest_other > horizon
            and nearest_other >= max(mine, landmark_gap(v, start, lands))
        ):
            horizon = nearest_other
    return horizon, count if margin >= 0 else -1


@njit(cache=True, nogil=True)
def _search(
    state: np.ndarray,
    candidate: np.ndarray,
    listed: np.ndarray,
    margin: int,
    kept: np.ndarray,
    lands: np.ndarray,
    start: int,
    stride: int,
    battery: float,
    cost: float,
    floor: float,
    best_cost: float,
    budget: float,
    others_r: np.ndarray,
    others_c: np.ndarray,
    hold: int,
    seen: np.ndarray,
    stamp: int,
    parent: np.ndarray,
    queue: np.ndarray,
    found: np.ndarray,
    spare: tuple[np.ndarray, np.ndarray, np.ndarray],
    everyone: np.ndarray,
) -> tuple[int, int, int]:
    """Returns (rank, cell) of the best target, or (-1, -1), and the count of
    cells ``_uncontested_horizon`` kept (-1 if it did not keep any).

    ``found`` and ``spare`` (a second ``seen``, ``queue`` and ``parent``, whose
    marks are ``_SPARE_MARKS * stamp`` and up) are scratch
    for the shortcuts: once the first lesser target is known,
    ``none_uncontested`` may prove that no candidate within the horizon is
    uncontested, without searching out to it; and when the search has gone
    far without finding any target but those left to others (in a crowd),
    ``first_lesser`` may find the first lesser one directly. ``everyone``:
    every candidate (``listed`` may be a shortlist of those that may be
    uncontested).
    """
    energy = (battery, cost, floor, best_cost, budget)
    steps = (-stride, stride, 1, -1)
    best1 = -1
    best2 = -1
    # Beyond ``horizon`` no target can be uncontested (rank 0): once the best
    # lesser target is known, stop there instead of searching the whole map.
    # Worked out when first needed (most searches end at an uncontested target).
    horizon = UNREACHED
    kept_count = -1
    seen[start] = stamp
    queue[0] = start
    head = 0
    tail = 1
    # ``distance`` is that of the cells being expanded; ``level_end`` is where
    # the cells one move farther start in the queue.
    level_end = 1
    distance = 0
    jumped = False
    while head < tail:
        if head == level_end:
            level_end = tail
            distance += 1
            if distance + 1 > horizon and (best1 >= 0 or (hold == 0 and best2 >= 0)):
                break
            if not jumped and best1 < 0 and hold > 0 and tail > JUMP_AFTER:
                jumped = True
                rank, v, d = first_lesser(
                    state, candidate, everyone, start, stride, hold, others_r, others_c,
                    lands, energy, found, spare, _SPARE_MARKS * stamp,
                )  # fmt: skip
                if rank >= 0:
                    ours = spare[2]
                    w = v
                    while w != start:  # the way there, as this search would leave it
                        parent[w] = ours[w]
                        w = ours[w]
                    if rank == 0:
                        return 0, v, kept_count
                    horizon, kept_count = _uncontested_horizon(
                        candidate, listed, start, stride, others_r, others_c, margin, kept, lands
                    )
                    if d > horizon or none_uncontested(
                        state, candidate, listed, start, stride, others_r, others_c, lands,
                        energy, found, spare, _SPARE_MARKS * stamp + AMONG_MARKS * JUMP_TRIES,
                    ):  # fmt: skip
                        return 1, v, kept_count
                    # Not proved: search on, as without the shortcut (and find it again).
        u = queue[head]
        head += 1
        d = distance + 1
        for k in range(4):
            v = u + steps[k]
            if state[v] != _FREE or seen[v] == stamp:
                continue
            seen[v] = stamp
            parent[v] = u
            queue[tail] = v
            tail += 1
            if candidate[v] == 0:
                continue
            back = lands[v, HOME]
            if back < UNREACHED and 2.0 * back * best_cost > budget:
                continue  # out of range for every agent
            if back >= UNREACHED or battery - cost * (d + back) < floor:
                continue  # cannot afford it
            rank = target_rank(v, d, 2, hold, stride, others_r, others_c, lands, energy)
            if rank == 0:
                return 0, v, kept_count
            if rank == 1:
                if best1 >= 0:
                    continue
                best1 = v
            else:
                if best2 >= 0:
                    continue
                best2 = v
                if hold > 0:
                    continue  # left to others: the answer only if nothing ranks better
            # The first of the next rank: search on only as far as the horizon,
            # or not at all when no candidate within it is uncontested.
            horizon, kept_count = _uncontested_horizon(
                candidate, listed, start, stride, others_r, others_c, margin, kept, lands
            )
            if d > horizon or none_uncontested(
                state, candidate, listed, start, stride, others_r, others_c, lands,
                energy, found, spare, _SPARE_MARKS * (stamp + 1) - 1,
            ):  # fmt: skip
                return rank, v, kept_count
    if best1 >= 0:
        return 1, best1, kept_count
    if best2 >= 0:
        return 2, best2, kept_count
    return -1, -1, kept_count


@njit(cache=True, nogil=True)
def _path_search(
    state: np.ndarray,
    blocked: np.ndarray,
    start: int,
    goal: int,
    stride: int,
    bound: int,
    lands: np.ndarray,
    seen: np.ndarray,
    stamp: int,
    parent: np.ndarray,
    queue: np.ndarray,
) -> int:
    """Breadth-first from ``start`` until ``goal`` is reached (N, S, E, W order, as
    ``paths.nearest``), over the cells whose distance from the start plus
    lower bound of the way to the goal (``way_at_least``: the Manhattan
    distance, and the landmarks' ``lands``) is at most ``bound``: 1 when
    found (``parent`` then holds the path), 0 when unreachable, else the
    smallest bound that would let the search go further.

    Neither the Manhattan distance nor a distance from a landmark changes by
    more than one a move, so every shortest path to a kept cell runs over
    kept cells: the kept cells are reached in the same order, from the same
    parents, as with no bound, and the path found is the one the whole
    search finds. (A cell the landmarks do not reach is cut off from those
    they do, by any way.)
    """
    steps = (-stride, stride, 1, -1)
    seen[start] = stamp
    queue[0] = start
    head = 0
    tail = 1
    level_end = 1
    distance = 0
    beyond = UNREACHED
    while head < tail:
        if head == level_end:
            level_end = tail
            distance += 1
        u = queue[head]
        head += 1
        for k in range(4):
            v = u + steps[k]
            if state[v] != _FREE or seen[v] == stamp or blocked[v] != 0:
                continue
            reach = distance + 1 + way_at_least(v, goal, stride, lands)
            if reach > bound:
                if reach < beyond:
                    beyond = reach
                continue
            seen[v] = stamp
            parent[v] = u
            if v == goal:
                return 1
            queue[tail] = v
            tail += 1
    return 0 if beyond == UNREACHED else beyond


@njit(cache=True, nogil=True)
def _unwind(parent: np.ndarray, start: int, goal: int, way: np.ndarray) -> int:
    """Write the path to ``goal`` that a search from ``start`` left in ``parent``
    into ``way``, goal first and the start left out; return its length."""
    length = 0
    v = goal
    while v != start:
        way[length] = v
        length += 1
        v = parent[v]
    return length


@njit(cache=True, nogil=True)
def _moved_within(
    rows0: np.ndarray,
    cols0: np.ndarray,
    others0: np.ndarray,
    rows: np.ndarray,
    cols: np.ndarray,
    working: np.ndarray,
    slot: int,
    margin: int,
) -> bool:
    """``HorizonMemo``'s test: none of ``others0`` stopped working, and the largest
    move of one of them (Manhattan) plus the move of ``slot`` is within ``margin``."""
    farthest = 0
    for j in range(rows.size):
        if others0[j]:
            if not working[j]:
                return False
            m = abs(rows[j] - rows0[j]) + abs(cols[j] - cols0[j])
            if m > farthest:
                farthest = m
    return farthest + abs(rows[slot] - rows0[slot]) + abs(cols[slot] - cols0[slot]) <= margin


class HorizonMemo:
    """One agent's shortlist for the horizon pass of its target searches.

    The pass over every uncovered cell costs as much as the search itself on a
    large map, yet only cells near the agent's own Manhattan region can count.
    A full pass keeps the cells that no other agent was more than ``MARGIN``
    nearer to; until the agent and the others it was ranked against have
    moved more than ``MARGIN`` between them (and while none of those stopped
    working), no other cell can have become uncontested, so the shortlist
    plus the cells that became uncovered since gives the same horizon.
    """

    MARGIN = 16

    def __init__(self, team: Team, slot: int) -> None:
        self._team = team
        self._slot = slot
        #: The team when the cells were kept (rows, columns, the others ranked against);
        #: None while nothing is kept.
        self._at: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
        self._since = 0  # ``MapBelief.added_count`` when they were kept
        #: The shortlist: the ``_kept`` cells, then those added since, in the first
        #: ``_listed`` items (grown by what was added in between, when handed out).
        self._buffer = np.zeros(0, dtype=np.int64)
        self._kept = 0
        self._listed = 0

    def shortlist(self, belief: MapBelief) -> np.ndarray | None:
        """The cells to pass over, or None when a full pass is due."""
        if self._at is None:
            return None
        team = self._team
        rows0, cols0, others0 = self._at
        if not _moved_within(
            rows0, cols0, others0, team.rows, team.cols, team.working, self._slot, self.MARGIN
        ):
            return None
        size = self._kept + belief.added_count - self._since
        if size > self._buffer.size:
            grown = np.zeros(max(size, 2 * self._buffer.size), dtype=np.int64)
            grown[: self._listed] = self._buffer[: self._listed]
            self._buffer = grown
        if size > self._listed:
            added = np.frombuffer(belief.added, dtype=np.int64)
            first = self._since + self._listed - self._kept
            self._buffer[self._listed : size] = added[first : belief.added_count]
            self._listed = size
        return self._buffer[:size]

    def remember(self, kept: np.ndarray, belief: MapBelief) -> None:
        team = self._team
        self._at = (team.rows.copy(), team.cols.copy(), team.others_mask(self._slot))
        self._since = belief.added_count
        if kept.size > self._buffer.size:
            self._buffer = np.zeros(2 * kept.size, dtype=np.int64)
        self._buffer[: kept.size] = kept
        self._kept = self._listed = kept.size


class WayMemo:
    """One agent's candidates near its way, carried along a transit from one
    check of its target (``TargetSearch._confirm``) to the next.

    The check lists the candidates within the way's length of the agent by
    Manhattan distance before it tests their lower bounds. Later, on the way
    to the same target, a cell that was farther than the way then is farther
    still when the agent has come no farther, by Manhattan distance, than the
    way has shortened: the distance to it falls by at most what the agent
    moved. So the cells listed then, those that became free since
    (``MapBelief.added``) and those claimed then (a claim may be released:
    claimed cells are no candidates while it lasts) hold every candidate
    within reach now, and the check passes over them instead of over the
    uncovered cells of the whole map or of the square around the agent.
    """

    def __init__(self) -> None:
        self._goal = -1  # none kept
        self._start = 0
        self._moves = 0
        self._since = 0  # ``MapBelief.added_count`` when they were kept
        self._claimed = np.zeros(0, dtype=np.int64)
        #: The cells kept, in the first ``_kept`` items, and room behind them.
        self._cells = np.zeros(64, dtype=np.int64)
        self._kept = 0
        #: A tie the last check settled on the way (``SettledTie``).
        self.tie = SettledTie()

    def listed(
        self, start: int, goal: int, moves: int, belief: MapBelief, most: int
    ) -> np.ndarray | None:
        """Every candidate within ``moves`` of ``start`` by Manhattan distance, and
        others, on the way to ``goal``; None when what is kept cannot tell, or
        would hand out more than ``most`` cells."""
        if goal != self._goal:
            return None
        stride = belief.stride
        came = abs(start // stride - self._start // stride) + abs(
            start % stride - self._start % stride
        )
        if came > self._moves - moves:
            return None
        kept, added = self._kept, belief.added_count - self._since
        size = kept + added + self._claimed.size
        if size > most:
            return None
        if size > self._cells.size:
            grown = np.zeros(max(size, 2 * self._cells.size), dtype=np.int64)
            grown[:kept] = self._cells[:kept]
            self._cells = grown
        cells = self._cells
        new = np.frombuffer(belief.added, dtype=np.int64)
        cells[kept : kept + added] = new[self._since : belief.added_count]
        cells[kept + added : size] = self._claimed
        return cells[:size]

    def room(self, size: int) -> np.ndarray:
        """Where the next cells to keep are to be written: at least ``size`` items
        (the cells ``listed`` handed out, when they are read: the pass writes
        behind its reading)."""
        if size > self._cells.size:
            self._cells = np.zeros(max(size, 2 * self._cells.size), dtype=np.int64)
        return self._cells

    def keep(
        self, kept: int, start: int, goal: int, moves: int, belief: MapBelief, claimed: np.ndarray
    ) -> None:
        """``kept`` cells were written at ``room``'s (-1: the pass stopped short)."""
        if kept < 0:
            self._goal = -1
            return
        self._goal, self._start, self._moves = goal, start, moves
        self._since, self._kept, self._claimed = belief.added_count, kept, claimed


@dataclass
class SearchCounts:
    """How often the compiled search took each way to an answer (for the tests and
    the benches: the shortcuts must be taken to be worth their code)."""

    searches: int = 0  # full breadth-first searches (``_search``)
    confirmed: int = 0  # answers of ``_confirm``
    carried: int = 0  # settled targets carried on
    way_listed: int = 0  # confirmations that passed over the way memo's cells


class AgentMemory(SearchMemory):
    """What the compiled search keeps of one agent (each part may be None: not kept)."""

    def __init__(
        self,
        horizon: HorizonMemo | None = None,
        way: WayMemo | None = None,
        settled: SettledTarget | None = None,
    ) -> None:
        self.horizon = horizon
        self.way = way
        self.settled = settled


class CompiledSearch:
    """The target search with compiled kernels (``planner.target_search``): scratch
    arrays for ``_search``, reused across calls on one belief."""

    #: Most candidates ``_confirm`` looks at one by one. On a long way in rooms
    #: the lower bounds leave hundreds, all farther than the target, and the
    #: bounded walks to them (``first_among``, mostly the search back) cost
    #: far less than the search of everything within the way's length (rooms
    #: 1000x1000 with 10 agents: 20 thousand such searches, 2.3 ms each, at 128).
    RIVALS = 1024
    #: Most candidates ``_all_left_to_others`` lists; it passes over every
    #: uncovered cell, and a longer list only makes it give up later.
    LEFT_TO_OTHERS = 128
    FEW = 512
    LIST_COST = 8

    def __init__(self, belief: MapBelief, shortcuts: SearchShortcuts = ALL_SHORTCUTS) -> None:
        size = len(belief.state)
        self.belief = belief
        self.shortcuts_taken = shortcuts
        self.counts = SearchCounts()
        self.seen = np.zeros(size, dtype=np.int32)
        self.parent = np.zeros(size, dtype=np.int32)
        self.queue = np.zeros(size, dtype=np.int32)
        self.stamp = 0
        self.state = np.frombuffer(belief.state, dtype=np.uint8)
        self.candidate = np.frombuffer(belief.uncovered_mask, dtype=np.uint8)
        self.uncovered_list = np.frombuffer(belief.uncovered_list, dtype=np.int64)
        self.shortcuts = np.frombuffer(belief.shortcuts, dtype=np.int64)
        self._kept = np.zeros(size, dtype=np.int64)
        self._way = np.zeros(size, dtype=np.int64)
        self._near = np.zeros(size, dtype=np.int64)
        #: Candidates that might outrank the target on the way (``_confirm``),
        #: with a place for the target.
        self._rivals = np.zeros(self.RIVALS + 1, dtype=np.int64)
        #: The candidates ``_search``'s shortcuts look at one by one (at most its size).
        self._few = np.zeros(self.FEW, dtype=np.int64)
        self._no_near = np.zeros(0, dtype=np.int64)  # ``rivals_listed`` keeps none
        #: A second ``seen``, ``queue`` and ``parent``, for ``_search``.
        self._spare = (
            np.zeros(size, dtype=np.int32),
            np.zeros(size, dtype=np.int32),
            np.zeros(size, dtype=np.int32),
        )
        self._pool_mask = np.zeros(size, dtype=np.uint8)
        self._blocked = np.zeros(size, dtype=np.uint8)
        self.home = np.frombuffer(belief.charger_dist, dtype=np.int32)
        #: Set by ``_confirm`` when no other candidate the agent could take lay
        #: within the way's length: any shortest way keeps the target (``SettledTarget``).
        self._alone = False
        self.landmarks = Landmarks(belief)
        #: The distances from the landmarks (``Landmarks.lands``), brought up to
        #: date at the start of each ``run`` and ``path``.
        self.lands = self.landmarks.lands

    def path(
        self, start: int, goal: int, blocked: Iterable[int] = (), longest: int | None = None
    ) -> list[int] | None:
        """The shortest path from ``start`` to ``goal`` over known free cells, not
        entering ``blocked`` cells: the start excluded, the goal included. None
        if there is none, or none of at most ``longest`` moves."""
        if start == goal:
            return []
        stride = self.belief.stride
        self.lands = self.landmarks.update()
        shortest = int(way_at_least(start, goal, stride, self.lands))
        if longest is not None and longest < shortest:
            return None  # surely none (a bound under 1 would also read as found)
        marked = list(blocked)
        self._blocked[marked] = 1
        bound, slack = (shortest, 1) if longest is None else (longest, 0)
        try:
            while True:
                # Widen the bound until the goal is in: the slack doubles, so the
                # searches that fall short cost no more than the last one.
                self.stamp += 1
                found = _path_search(
                    self.state,
                    self._blocked,
                    start,
                    goal,
                    stride,
                    bound,
                    self.lands,
                    self.seen,
                    self.stamp,
                    self.parent,
                    self.queue,
                )
                if found <= 1 or longest is not None:
                    break
                slack = max(2 * slack, found - shortest)
                bound = shortest + slack
        finally:
            self._blocked[marked] = 0
        return self._unwind(start, goal) if found == 1 else None

    def _unwind(self, start: int, goal: int) -> list[int]:
        length = _unwind(self.parent, start, goal, self._way)
        return self._way[length - 1 :: -1].tolist()

    def _way_to(self, start: int, cell: int, way: Sequence[int]) -> Sequence[int]:
        """The way the last search left from ``start`` to ``cell``, or ``way`` itself
        when it ends there and is as long: the coordinator keeps the way it is on
        then (``Coordinator._take_target``), and a fresh list of a way of
        thousands of moves cost more than the check that found it."""
        if way and way[-1] == cell and _unwind(self.parent, start, cell, self._way) == len(way):
            return way
        return self._unwind(start, cell)

    def _confirm(
        self,
        start: int,
        goal: int,
        way: Sequence[int],
        known_at: tuple[int, int] | None,
        listed: np.ndarray,
        margin: int,
        memo: HorizonMemo | None,
        energy: tuple[float, float, float, float, float],
        others: tuple[np.ndarray, np.ndarray],
        hold: int,
        claimed: np.ndarray,
        way_memo: WayMemo | None,
    ) -> Found | None:
        """What the search from ``start`` would return, found without it when the
        agent is on ``way`` to ``goal``; None when only the search can tell.
        ``claimed``: the cells masked out as claimed by others; ``way_memo``: the
        agent's candidates near its way, used and renewed here.

        The search returns the first uncontested candidate it reaches (rank 0)
        or, when there is none, the first of the next rank. ``goal`` ranks so
        at the end of ``way``, so the search returns it or a candidate it
        reaches no later. One pass over the uncovered cells within the way's
        length finds the few that might (``rivals_listed``); when ``goal`` is
        contested, none anywhere may be uncontested (the horizon pass). Then
        a search bounded to the ways to those few (``first_among``) finds
        what the search over the map around the agent out to the target
        would, as it would at every step of a long transit. With no rival,
        ``way`` is the answer as it stands if it is still a shortest way
        (``_still_shortest``).
        """
        candidate = self.candidate
        if candidate[goal] == 0:
            return None
        moves = len(way)
        lands = self.lands
        battery, cost, floor, best_cost, budget = energy
        back = int(self.home[goal])
        if back >= UNREACHED or 2.0 * back * best_cost > budget:
            return None
        if battery - cost * (moves + back) < floor:
            return None  # perhaps a shorter way now: let the search tell
        stride = self.belief.stride
        rows, cols = others
        near = nearest_manhattan(rows, cols, goal // stride - 1, goal % stride - 1)
        if rows.size == 0 or near >= moves:
            rank, limit = 0, UNREACHED
        elif hold == 0:
            rank, limit = 2, 0
        elif near > hold:
            rank, limit = 1, hold + 1
        else:
            return None  # left to the agent beside it: the search looks for another
        if rank > 0:
            # No candidate may be uncontested, however far. The search's horizon
            # pass (which also renews the memo's shortlist) finds none in Manhattan
            # terms, or the search's own proof (``none_uncontested``) rules them out.
            horizon, kept = _uncontested_horizon(
                candidate, listed, start, stride, rows, cols, margin, self._kept, lands
            )
            if kept >= 0 and memo is not None:
                memo.remember(self._kept[:kept], self.belief)
            if horizon >= 0:
                self.stamp += 1
                if not none_uncontested(
                    self.state, candidate, listed, start, stride, rows, cols, lands, energy,
                    self._few, self._spare, _SPARE_MARKS * self.stamp,
                ):  # fmt: skip
                    return None
        test = (moves, limit, stride, rows, cols, lands, energy, self._rivals[:-1])
        # A listed cell costs about LIST_COST cells of the square around the start
        # read row by row (its row and column are worked out by division; the
        # square's few candidates are then passed over as a list).
        square = 2 * moves * moves
        if rank == 0 and listed.size * self.LIST_COST < square:
            # Cells off ``listed`` are surely contested: rank 0 needs only these.
            count = rivals_listed(candidate, listed, start, goal, *test, self._no_near)[0]
        else:
            # The memo's cells, unless the uncovered cells or the square are fewer.
            most = min(self.belief.uncovered_count, square // self.LIST_COST)
            pool = None
            if way_memo is not None:
                pool = way_memo.listed(start, goal, moves, self.belief, most)
                self.counts.way_listed += pool is not None
            if pool is None:
                if self.belief.uncovered_count * self.LIST_COST < square:
                    pool = self.uncovered_list[: self.belief.uncovered_count]
                else:
                    pool = self._near[: in_square(candidate, start, moves, stride, self._near)]
            room = self._no_near if way_memo is None else way_memo.room(pool.size)
            count, kept = rivals_listed(candidate, pool, start, goal, *test, room)
            if way_memo is not None:
                way_memo.keep(kept, start, goal, moves, self.belief, claimed)
        if count == self.RIVALS:
            return None  # too many to look at one by one: the search is as quick
        if self._still_shortest(start, goal, moves, known_at):
            if count == 0:
                self._alone = True
                return Found(rank, goal, way)
            # ``goal`` is as far as ``way``: only a rival nearer comes first, or one
            # as near whose way comes first in the search's order (left to the
            # search below). Bounded to the ways to the rivals alone, the search
            # leaves out the cells near the way to the target.
            found = self._first_among(
                start, self._rivals[:count], moves, rank, hold, others, energy
            )
            if found is None:
                self._alone = True
                return Found(rank, goal, way)
            if len(found[2]) < moves:
                return found
            # As far as the goal: the rivals after it come later still, so only
            # which of the two comes first is left to tell, by the ways to them alone.
            rival = found[1]
            tie = None if way_memo is None else way_memo.tie
            if tie is not None and self._tie_holds(start, goal, rival, moves, tie):
                return Found(rank, goal, way)
            self._rivals[:2] = rival, goal
            pair = self._rivals[:2]
            found = self._first_among(start, pair, moves, rank, hold, others, energy, way)
            if tie is not None:
                if found is not None and found[1] == goal:
                    tie.keep(self._way_cells(start, moves), rival, self.belief)
                else:
                    tie.forget()
            return found
        self._rivals[count] = goal
        return self._first_among(
            start, self._rivals[: count + 1], moves, rank, hold, others, energy, way
        )

    def _way_cells(self, start: int, moves: int, way: Sequence[int] | None = None) -> np.ndarray:
        """The start, then ``way`` (None: the search's first way, as ``_way_to``
        just unwound it), ``moves`` cells."""
        cells = np.empty(moves + 1, dtype=np.int64)
        cells[0] = start
        if way is None:
            cells[1:] = self._way[moves - 1 :: -1]
        else:
            cells[1:] = np.fromiter(way, dtype=np.int64, count=moves)
        return cells

    def _tie_holds(self, start: int, goal: int, rival: int, moves: int, tie: SettledTie) -> bool:
        """Does ``goal`` still come before ``rival``, as far, as ``tie`` proves (see
        ``planner.settled_target``)? Carries it on if so."""
        if tie.rival != rival:
            return False
        at = tie.where(start, goal)
        belief = self.belief
        if (
            at < 0
            or tie.cells.size - 1 - at != moves
            or tie.blocked != belief.blocked_count
            or not tie.none_found_within(belief, start, moves, self.lands)
        ):
            return False
        tie.carry(at, belief)
        return True

    def _first_among(
        self,
        start: int,
        targets: np.ndarray,
        bound: int,
        rank: int,
        hold: int,
        others: tuple[np.ndarray, np.ndarray],
        energy: tuple[float, float, float, float, float],
        way: Sequence[int] = (),
    ) -> Found | None:
        """``first_among`` with this search's scratch arrays: (rank, cell, path),
        the path ``way`` when that is one as short (``_way_to``)."""
        rank, cell = self._first_reached(start, targets, bound, rank, hold, others, energy)
        return None if rank < 0 else Found(rank, cell, self._way_to(start, cell, way))

    def _first_reached(
        self,
        start: int,
        targets: np.ndarray,
        bound: int,
        rank: int,
        hold: int,
        others: tuple[np.ndarray, np.ndarray],
        energy: tuple[float, float, float, float, float],
    ) -> tuple[int, int]:
        """``first_among`` with this search's scratch arrays: (rank, cell), the way
        there left in ``parent``."""
        stamp = self.stamp + 1
        self.stamp += AMONG_MARKS
        return first_among(
            self.state,
            self.candidate,
            targets,
            start,
            self.belief.stride,
            bound,
            rank,
            hold,
            others[0],
            others[1],
            self.lands,
            energy,
            self.seen,
            stamp,
            self.parent,
            self.queue,
        )

    def _all_left_to_others(
        self,
        start: int,
        energy: tuple[float, float, float, float, float],
        others: tuple[np.ndarray, np.ndarray],
        hold: int,
    ) -> tuple[bool, Found | None]:
        """``(True, what the search returns)`` when every candidate is surely left
        to another agent (within ``hold`` of one, and nearer to it), else
        ``(False, None)``.

        Then the search, finding no better rank, covers the whole known map
        for a candidate the agent can afford (rank 2: the coordinator holds
        the agent back, so which one does not matter: ``HELD_BACK``). Here a
        pass over the uncovered cells rules out better ranks, a second one
        lists those the agent might afford; when a way through a landmark
        affords one (``surely_affordable``), that is the answer, else a
        search bounded to the ways to them finds one, or that there is none.
        With too many to list, only the search can tell.
        """
        candidate, full = self.candidate, self.uncovered_list[: self.belief.uncovered_count]
        found = self._rivals[: self.LEFT_TO_OTHERS]
        team = (self.belief.stride, others[0], others[1], self.lands, energy, found)
        if rivals_listed(candidate, full, start, -1, UNREACHED, hold + 1, *team, self._no_near)[0]:
            return False, None  # some may rank better
        count = rivals_listed(candidate, full, start, -1, UNREACHED, 0, *team, self._no_near)[0]
        if count == self.LEFT_TO_OTHERS:
            return False, None
        targets = found[:count]
        if count == 0:
            return True, None
        if surely_affordable(targets, start, self.lands, energy):
            return True, HELD_BACK
        battery, cost, floor, _, _ = energy
        bound = UNREACHED
        if cost > 0:  # the farthest any of them can be afforded, and a move to spare
            bound = int((battery - floor) / cost) - int(self.home[targets].min()) + 1
        rank, _ = self._first_reached(
            start, targets, min(bound, UNREACHED), 2, hold, others, energy
        )
        return True, None if rank < 0 else HELD_BACK

    def _still_shortest(
        self, start: int, goal: int, moves: int, known_at: tuple[int, int] | None
    ) -> bool:
        """Is there surely no way from ``start`` to ``goal`` shorter than ``moves``?

        So when ``moves`` is the Manhattan distance. So too when a way that
        long was a shortest way at ``known_at`` (``MapBelief.stamp``, and the
        agent has kept to it since), no cell was blocked since, and none of
        the cells that may have shortened a way since (``MapBelief.shortcuts``:
        every other new cell leaves the distances between the cells known
        before as they were) lies where a shorter way could pass: by the
        bounds of ``rivals_listed`` (in rooms, many such cells lie within the
        Manhattan bound of a way round a wall, but their distances from the
        landmarks, as known now, tell that they are too far from one end or the other).
        """
        stride = self.belief.stride
        r0, c0, r1, c1 = start // stride, start % stride, goal // stride, goal % stride
        if moves == abs(r0 - r1) + abs(c0 - c1):
            return True
        if known_at is None:
            return False
        since, blocked = known_at
        belief = self.belief
        if blocked != belief.blocked_count:
            return False
        new = self.shortcuts[since : belief.shortcut_count]
        return none_between(new, start, goal, moves, stride, self.lands)

    def memory(self, team: Team, slot: int) -> AgentMemory:
        return AgentMemory(HorizonMemo(team, slot), WayMemo(), SettledTarget())

    def run(self, request: SearchRequest, memory: SearchMemory | None = None) -> Found | None:
        """The answer of ``planner.target_search`` (``memory``: an ``AgentMemory``)."""
        taken = self.shortcuts_taken
        kept = memory if isinstance(memory, AgentMemory) and request.pool is None else None
        horizon = kept.horizon if kept is not None and taken.shortlist else None
        way = kept.way if kept is not None and taken.way_memo else None
        settled = kept.settled if kept is not None and taken.settled else None
        hint = request.hint if request.pool is None else None
        battery, cost, floor, best_cost, budget = request.energy
        found = self._run_all(
            request.start, battery, cost, floor, best_cost, budget, request.others,
            request.hold, request.excluded, request.pool, horizon, hint, way, settled,
        )  # fmt: skip
        return found

    def _run_all(
        self,
        start: int,
        battery: float,
        cost: float,
        floor: float,
        best_cost: float,
        budget: float,
        others: tuple[np.ndarray, np.ndarray],
        hold: int,
        excluded: Sequence[int],
        pool: Iterable[int] | None = None,
        memo: HorizonMemo | None = None,
        hint: tuple[int, Sequence[int], tuple[int, int] | None] | None = None,
        way_memo: WayMemo | None = None,
        settled: SettledTarget | None = None,
    ) -> Found | None:
        """The best target as ``(rank, cell, path)`` among ``pool`` (None: the
        uncovered cells), ranked against the ``others`` (rows, columns) agents;
        ``excluded`` cells (claimed by other agents) are not candidates.
        ``memo`` and ``way_memo``: the searching agent's, when ``pool`` is None
        (``way_memo`` serves the ``hint``). ``hint``: the
        target the agent was heading for, its way there and the
        ``MapBelief.stamp`` when that was last known to be a shortest way, if
        ever (``pool`` None only): when it is certain what the search would
        return, it is returned without one, with a shortest path there
        (perhaps not the one the search finds: the way, when it is as short).
        ``settled``: the agent's target as the last check proved it, carried
        along the ``hint`` while nothing it rests on changed, and renewed by
        each check (``pool`` None only).
        With ``hold`` > 0, rank 2 is always ``HELD_BACK``."""
        self.lands = self.landmarks.update()
        energy = (battery, cost, floor, best_cost, budget)
        if settled is None or pool is not None or others[0].size:
            # Ranked against others: nothing is settled (``_carried`` would refuse it).
            if settled is not None and settled.goal >= 0:
                settled.forget()
            return self._run(start, energy, others, hold, excluded, pool, memo, hint, way_memo)
        if (
            hint is not None
            and settled.goal == hint[0]
            and self._carried(start, hint, energy, excluded, settled)
        ):
            self.counts.carried += 1
            return Found(0, hint[0], hint[1])
        found = self._run(start, energy, others, hold, excluded, pool, memo, hint, way_memo)
        self._settle(settled, start, found, energy, excluded)
        return found

    def _run(
        self,
        start: int,
        energy: tuple[float, float, float, float, float],
        others: tuple[np.ndarray, np.ndarray],
        hold: int,
        excluded: Sequence[int],
        pool: Iterable[int] | None,
        memo: HorizonMemo | None,
        hint: tuple[int, Sequence[int], tuple[int, int] | None] | None,
        way_memo: WayMemo | None,
    ) -> Found | None:
        """``run`` without the settled target."""
        battery, cost, floor, best_cost, budget = energy
        self._alone = False
        margin = -1
        if pool is None:
            mask = self.candidate
            listed = memo.shortlist(self.belief) if memo is not None else None
            if listed is None:
                listed = self.uncovered_list[: self.belief.uncovered_count]
                margin = HorizonMemo.MARGIN if memo is not None else -1
        else:
            mask = self._pool_mask
            pool = list(pool)
            mask[pool] = 1
            listed = np.array(pool, dtype=np.int64)
        claimed = np.array(excluded, dtype=np.int64)
        saved = mask[claimed]
        mask[claimed] = 0
        # The shortcuts read the uncovered cells' mask (``self.candidate``) with
        # the claimed cells masked out, as the search does.
        try:
            if hint is not None and pool is None and self.shortcuts_taken.confirm:
                goal, way, known_at = hint
                sure = self._confirm(
                    start, goal, way, known_at, listed, margin, memo, energy, others, hold,
                    claimed, way_memo,
                )  # fmt: skip
                if sure is not None:
                    self.counts.confirmed += 1
                    return sure
                if margin >= 0 and memo is not None:
                    renewed = memo.shortlist(self.belief)  # by the confirmation
                    if renewed is not None:
                        listed, margin = renewed, -1
            if pool is None and hold > 0 and others[0].size and self.shortcuts_taken.left_to_others:
                known, found = self._all_left_to_others(start, energy, others, hold)
                if known:
                    return found
            self.stamp += 1
            self.counts.searches += 1
            rank, cell, kept = _search(
                self.state,
                mask,
                listed,
                margin,
                self._kept,
                self.lands,
                start,
                self.belief.stride,
                battery,
                cost,
                floor,
                best_cost,
                budget,
                others[0],
                others[1],
                hold,
                self.seen,
                self.stamp,
                self.parent,
                self.queue,
                self._few,
                self._spare,
                self.uncovered_list[: self.belief.uncovered_count] if pool is None else listed,
            )
        finally:
            mask[claimed] = saved
            if pool is not None:
                mask[pool] = 0
        if kept >= 0 and memo is not None:
            memo.remember(self._kept[:kept], self.belief)
        if rank < 0:
            return None
        if rank == HELD_BACK[0] and hold > 0:
            return HELD_BACK
        return Found(rank, cell, self._way_to(start, cell, hint[1] if hint is not None else ()))

    def _carried(
        self,
        start: int,
        hint: tuple[int, Sequence[int], tuple[int, int] | None],
        energy: tuple[float, float, float, float, float],
        excluded: Sequence[int],
        settled: SettledTarget,
    ) -> bool:
        """Is the hint's target, by the hint's way, what the search would return,
        as ``settled`` proves (see ``planner.settled_target``)? Carries it on if so."""
        goal, way, _ = hint
        battery, cost, floor = energy[0], energy[1], energy[2]
        at = settled.step(start, goal, battery, cost)
        if at < 0:
            return False
        moves = settled.cells.size - 1 - at
        belief = self.belief
        if (
            len(way) != moves
            or settled.stamp != belief.stamp
            or settled.terms != energy[1:]
            or not self.candidate[goal]
            or goal in excluded
            or battery - cost * (moves + int(self.home[goal])) < floor
            or not settled.none_found_within(belief, start, moves, self.lands)
        ):
            return False
        claimed = settled.claimed
        if claimed.size:
            released = claimed[self.candidate[claimed] != 0]
            if released.size and not np.isin(released, excluded).all():
                return False
        settled.carry_on(at, battery, belief)
        return True

    def _settle(
        self,
        settled: SettledTarget,
        start: int,
        found: Found | None,
        energy: tuple[float, float, float, float, float],
        excluded: Sequence[int],
    ) -> None:
        """Keep what the check just proved (while no other agent works)."""
        if settled.goal >= 0:
            settled.forget()
        if found is None or found[0] != 0 or not found[2]:
            return
        path = found[2]
        # Any shortest way keeps a target no other candidate was as near as
        # (``_alone``); else only the search's first way does.
        cells = self._way_cells(start, len(path), path if self._alone else None)
        settled.keep(cells, energy[0], energy[1:], self.belief, np.array(excluded, np.int64))


def warm_up() -> None:
    """Compile this module's kernels (or load them from numba's cache) now, not in
    the first decision: a program calls it before it times or flies anything."""
    belief = MapBelief((1, 2), (0, 0))
    belief.mark_free(belief.index((0, 1)))
    search = CompiledSearch(belief)
    nobody = np.zeros(0, dtype=np.int64)
    energy = Energy(100.0, 0.0, 0.0, 0.0, 100.0)
    search.run(SearchRequest(belief.index((0, 0)), energy, (nobody, nobody), 0))
    nearest_manhattan(nobody, nobody, 0, 0)
    search.path(belief.index((0, 0)), belief.index((0, 1)))
