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

import numpy as np
from numba import njit

from planner.belief import UNREACHED, MapBelief
from planner.grid import CellState

_FREE = int(CellState.FREE)


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
    home: np.ndarray,
) -> tuple[int, int]:
    """The largest distance at which a candidate could still be uncontested.

    A candidate ``v`` at path distance ``d`` is uncontested when every other
    agent is at least ``d`` away (Manhattan); as ``d`` is at least the
    Manhattan distance from the start, and the difference of the two cells'
    distances ``home`` (the charger as a landmark), only candidates that no
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
            and nearest_other >= max(mine, abs(home[v] - home[start]))
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
    home: np.ndarray,
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
    marks are ``8 * stamp`` and up, one for each search there) are scratch
    for the shortcuts: once the first lesser target is known,
    ``_none_uncontested`` may prove that no candidate within the horizon is
    uncontested, without searching out to it; and when the search has gone
    far without finding any target but those left to others (in a crowd),
    ``_first_lesser`` may find the first lesser one directly. ``everyone``:
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
            if not jumped and best1 < 0 and hold > 0 and tail > _JUMP_AFTER:
                jumped = True
                rank, v, d = _first_lesser(
                    state, candidate, everyone, start, stride, hold, others_r, others_c,
                    home, energy, found, spare, 8 * stamp,
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
                        candidate, listed, start, stride, others_r, others_c, margin, kept, home
                    )
                    if d > horizon or _none_uncontested(
                        state, candidate, listed, start, stride, others_r, others_c, home,
                        energy, found, spare, 8 * stamp + _JUMP_TRIES,
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
            back = home[v]
            if back < UNREACHED and 2.0 * back * best_cost > budget:
                continue  # out of range for every agent
            if back >= UNREACHED or battery - cost * (d + back) < floor:
                continue  # cannot afford it
            r = v // stride - 1
            c = v % stride - 1
            nearest_other = UNREACHED
            for j in range(others_r.size):
                m = abs(r - others_r[j]) + abs(c - others_c[j])
                if m < nearest_other:
                    nearest_other = m
            if nearest_other >= d:
                return 0, v, kept_count
            if hold > 0 and nearest_other >= min(d, hold + 1):
                if best1 < 0:
                    best1 = v
                    horizon, kept_count = _uncontested_horizon(
                        candidate, listed, start, stride, others_r, others_c, margin, kept, home
                    )
                    if d > horizon or _none_uncontested(
                        state, candidate, listed, start, stride, others_r, others_c, home,
                        energy, found, spare, 8 * stamp + _JUMP_TRIES + 1,
                    ):  # fmt: skip
                        return 1, v, kept_count
            elif best2 < 0:
                best2 = v
                if hold == 0:
                    horizon, kept_count = _uncontested_horizon(
                        candidate, listed, start, stride, others_r, others_c, margin, kept, home
                    )
                    if d > horizon or _none_uncontested(
                        state, candidate, listed, start, stride, others_r, others_c, home,
                        energy, found, spare, 8 * stamp + _JUMP_TRIES + 1,
                    ):  # fmt: skip
                        return 2, v, kept_count
    if best1 >= 0:
        return 1, best1, kept_count
    if best2 >= 0:
        return 2, best2, kept_count
    return -1, -1, kept_count


#: Cells a target search reaches, with no target found but those left to
#: others, before it tries ``_first_lesser``.
_JUMP_AFTER = 4096
#: Bounds ``_first_lesser`` tries before leaving it to the search.
_JUMP_TRIES = 4


@njit(cache=True, nogil=True)
def _first_lesser(
    state: np.ndarray,
    candidate: np.ndarray,
    everyone: np.ndarray,
    start: int,
    stride: int,
    hold: int,
    others_r: np.ndarray,
    others_c: np.ndarray,
    home: np.ndarray,
    energy: tuple[float, float, float, float, float],
    found: np.ndarray,
    spare: tuple[np.ndarray, np.ndarray, np.ndarray],
    mark: int,
) -> tuple[int, int, int]:
    """The first candidate ``_search`` reaches that ranks 1 or better (within
    ``hold`` of no other agent nearer to it, or uncontested) as (rank, cell,
    distance); (-1, -1, -1) when it is left to the search. The way there is
    left in ``spare``'s ``parent``; its ``seen`` marked with ``mark`` to
    ``mark + _JUMP_TRIES - 1``.

    In a crowd every candidate near the agent is left to another, and the
    search reaches a great part of the map before it finds one that is not,
    although most of the map's candidates are not (they lie beyond the
    crowd). Their lower bounds (``_rivals_listed``) are cheap: the least of
    them, ``B``, among those that may rank so, is where the first can be.
    A search bounded to the ways to the ones within a bound (``_first_among``)
    finds the first of them within it, in the search's order, and is the
    search's answer: any other that is nearer is within the bound too. The
    bound widens from ``B`` until one is found (on open maps, nearly always at
    ``B``) or the tries run out, or too many lie within it to list.
    """
    seen, queue, parent = spare
    limit = hold + 1
    r0 = start // stride
    c0 = start % stride
    h0 = home[start]
    closer = 0
    least = UNREACHED
    for k in range(everyone.size):
        v = everyone[k]
        if candidate[v] == 0:
            continue
        mine = max(abs(v // stride - r0) + abs(v % stride - c0), abs(home[v] - h0))
        if mine >= least:
            continue
        closer = _may_rival(v, mine, limit, stride, others_r, others_c, closer, home, energy)
        if closer < 0:
            least = mine
            closer = 0
    if least == UNREACHED:
        return -1, -1, -1
    slack = 0
    for attempt in range(_JUMP_TRIES):
        bound = least + slack
        count = _rivals_listed(
            candidate, everyone, start, -1, bound, limit, stride, others_r, others_c,
            home, energy, found,
        )  # fmt: skip
        if count == found.size:
            return -1, -1, -1
        rank, cell = _first_among(
            state, candidate, found[:count], start, stride, bound, 1, hold,
            others_r, others_c, home, energy, seen, mark + attempt, parent, queue,
        )  # fmt: skip
        if rank >= 0:
            d = 0
            w = cell
            while w != start:
                w = parent[w]
                d += 1
            return rank, cell, d
        slack = 2 * slack + 1
    return -1, -1, -1


@njit(cache=True, nogil=True)
def _none_uncontested(
    state: np.ndarray,
    candidate: np.ndarray,
    listed: np.ndarray,
    start: int,
    stride: int,
    others_r: np.ndarray,
    others_c: np.ndarray,
    home: np.ndarray,
    energy: tuple[float, float, float, float, float],
    found: np.ndarray,
    spare: tuple[np.ndarray, np.ndarray, np.ndarray],
    stamp: int,
) -> bool:
    """Is it certain that no candidate is uncontested (rank 0) for ``_search``?

    A candidate is uncontested when its way from the start is no longer than
    its distance to the nearest other agent. One pass lists the few for which
    the lower bounds of ``_rivals_listed`` allow it (the ``listed`` cells
    cover them all, as for the horizon), and a breadth-first search, bounded
    to the cells on a way to one of them short enough, tells whether any is
    (False; also when there are too many to list). ``spare``: a ``seen`` and
    a ``queue`` of its own (and a ``parent`` it does not use), as the search
    is left as it stands, to go on with when this fails.
    """
    count = _rivals_listed(
        candidate, listed, start, -1, UNREACHED, UNREACHED, stride, others_r, others_c,
        home, energy, found,
    )  # fmt: skip
    if count == found.size:
        return False
    if count == 0:
        return True
    battery, cost, floor, _, _ = energy
    targets = found[:count]
    bounds = np.empty(count, dtype=np.int64)
    for i in range(count):
        t = targets[i]
        bounds[i] = nearest_manhattan(others_r, others_c, t // stride - 1, t % stride - 1)
    seen, queue, _ = spare
    steps = (-stride, stride, 1, -1)
    toward = 0
    seen[start] = stamp
    queue[0] = start
    head = 0
    tail = 1
    level_end = 1
    distance = 0
    while head < tail:
        if head == level_end:
            level_end = tail
            distance += 1
        u = queue[head]
        head += 1
        d = distance + 1
        for k in range(4):
            v = u + steps[k]
            if state[v] != _FREE or seen[v] == stamp:
                continue
            r = v // stride
            c = v % stride
            within = False
            for i in range(count):
                j = toward + i
                if j >= count:
                    j -= count
                t = targets[j]
                apart = max(abs(r - t // stride) + abs(c - t % stride), abs(home[v] - home[t]))
                if d + apart <= bounds[j]:
                    toward = j
                    within = True
                    break
            if not within:
                continue
            seen[v] = stamp
            queue[tail] = v
            tail += 1
            if candidate[v] == 0 or battery - cost * (d + home[v]) < floor:
                continue
            for i in range(count):
                if targets[i] == v and d <= bounds[i]:
                    return False
    return True


@njit(cache=True, nogil=True)
def _may_rival(
    v: int,
    mine: int,
    limit: int,
    stride: int,
    others_r: np.ndarray,
    others_c: np.ndarray,
    closer: int,
    home: np.ndarray,
    energy: tuple[float, float, float, float, float],
) -> int:
    """Could candidate ``v``, ``mine`` moves or more away, be a target that no
    other agent is nearer to than ``min(its distance, limit)``? Not when
    another agent is nearer than ``min(mine, limit)``: then the index of that
    agent (ask about the next cell from there: neighbouring cells likely share
    it). Not when it is out of range or cannot be afforded even at ``mine``
    moves (``_search``'s tests, with ``energy`` its battery, cost, floor,
    best_cost and budget): ``closer``. Else -1."""
    bar = min(mine, limit)
    r = v // stride - 1
    c = v % stride - 1
    n = others_r.size
    for i in range(n):
        j = closer + i
        if j >= n:
            j -= n
        if abs(r - others_r[j]) + abs(c - others_c[j]) < bar:
            return j
    battery, cost, floor, best_cost, budget = energy
    back = home[v]
    if back >= UNREACHED or 2.0 * back * best_cost > budget:
        return closer
    if battery - cost * (mine + back) < floor:
        return closer
    return -1


@njit(cache=True, nogil=True)
def _rivals_listed(
    candidate: np.ndarray,
    listed: np.ndarray,
    start: int,
    goal: int,
    reach: int,
    limit: int,
    stride: int,
    others_r: np.ndarray,
    others_c: np.ndarray,
    home: np.ndarray,
    energy: tuple[float, float, float, float, float],
    found: np.ndarray,
) -> int:
    """The listed candidates but ``goal`` that may be within ``reach`` moves of
    the start and ``_may_rival``: put in ``found``, and their count
    (``found.size`` when there are more).

    A path is at least as long as the Manhattan distance, and as the
    difference of its ends' distances home (the charger as a landmark: the
    stronger bound where walls make the way round long)."""
    r0 = start // stride
    c0 = start % stride
    closer = 0
    count = 0
    for k in range(listed.size):
        v = listed[k]
        mine = abs(v // stride - r0) + abs(v % stride - c0)
        if mine > reach or v == goal or candidate[v] == 0:
            continue
        mine = max(mine, abs(home[v] - home[start]))
        if mine > reach:
            continue
        closer = _may_rival(v, mine, limit, stride, others_r, others_c, closer, home, energy)
        if closer < 0:
            if count == found.size:
                return count
            found[count] = v
            count += 1
            closer = 0
    return count


@njit(cache=True, nogil=True)
def _in_square(candidate: np.ndarray, start: int, reach: int, stride: int, out: np.ndarray) -> int:
    """The candidates within ``reach`` (Manhattan) of the start, read row by row
    into ``out``; their count. Cheaper than passing over a long list of
    uncovered cells when the square is the smaller."""
    r0 = start // stride
    c0 = start % stride
    rows = candidate.size // stride
    count = 0
    for r in range(max(0, r0 - reach), min(rows, r0 + reach + 1)):
        width = reach - abs(r - r0)
        base = r * stride
        for c in range(max(0, c0 - width), min(stride, c0 + width + 1)):
            if candidate[base + c] != 0:
                out[count] = base + c
                count += 1
    return count


@njit(cache=True, nogil=True)
def _first_among(
    state: np.ndarray,
    candidate: np.ndarray,
    targets: np.ndarray,
    start: int,
    stride: int,
    bound: int,
    rank: int,
    hold: int,
    others_r: np.ndarray,
    others_c: np.ndarray,
    home: np.ndarray,
    energy: tuple[float, float, float, float, float],
    seen: np.ndarray,
    stamp: int,
    parent: np.ndarray,
    queue: np.ndarray,
) -> tuple[int, int]:
    """``_search`` when only the ``targets`` (candidates in range, and reached
    from home) can be what it returns, all within ``bound`` moves: the first
    of them it reaches that the agent can afford and that ranks ``rank`` or
    better, as (rank, cell), or (-1, -1); ``parent`` holds the path there.

    When no target is nearer than ``bound`` by Manhattan distance (on open
    maps, a transit's target and the rivals as far as it), the walk of
    ``_first_tied`` finds it; else ``_first_reached``, breadth-first.
    """
    r0 = start // stride
    c0 = start % stride
    for i in range(targets.size):
        t = targets[i]
        if abs(t // stride - r0) + abs(t % stride - c0) < bound:
            return _first_reached(
                state, candidate, targets, start, stride, bound, rank, hold,
                others_r, others_c, home, energy, seen, stamp, parent, queue,
            )  # fmt: skip
    return _first_tied(
        state, candidate, targets, start, stride, bound, rank, hold,
        others_r, others_c, home, energy, seen, stamp, parent, queue,
    )  # fmt: skip


@njit(cache=True, nogil=True)
def _target_rank(
    v: int,
    d: int,
    rank: int,
    hold: int,
    stride: int,
    others_r: np.ndarray,
    others_c: np.ndarray,
    home: np.ndarray,
    energy: tuple[float, float, float, float, float],
) -> int:
    """The rank of candidate ``v`` reached at ``d`` moves, as ``_search`` ranks it,
    or -1 when it is worse than ``rank`` or the agent cannot afford it there."""
    battery, cost, floor, _, _ = energy
    if battery - cost * (d + home[v]) < floor:
        return -1
    r = v // stride - 1
    c = v % stride - 1
    near = UNREACHED
    for j in range(others_r.size):
        m = abs(r - others_r[j]) + abs(c - others_c[j])
        if m < near:
            near = m
    if near >= d:
        found = 0
    elif hold > 0 and near >= min(d, hold + 1):
        found = 1
    else:
        found = 2
    return found if found <= rank else -1


@njit(cache=True, nogil=True)
def _first_tied(
    state: np.ndarray,
    candidate: np.ndarray,
    targets: np.ndarray,
    start: int,
    stride: int,
    bound: int,
    rank: int,
    hold: int,
    others_r: np.ndarray,
    others_c: np.ndarray,
    home: np.ndarray,
    energy: tuple[float, float, float, float, float],
    seen: np.ndarray,
    stamp: int,
    parent: np.ndarray,
    stack: np.ndarray,
) -> tuple[int, int]:
    """``_first_reached`` when no target is nearer than ``bound`` by Manhattan
    distance, without visiting the cells between.

    The breadth-first search reaches the cells one move farther in the order
    of their parents, and a parent's in the order N, S, E, W: it reaches a
    cell first by the shortest way whose moves come first in that order, and
    of the targets at one distance, first the one at the end of the first of
    these ways. A target can then only be reached at ``bound`` moves, by a
    way every move of which brings it one nearer (Manhattan), so on such a
    way each cell's distance from the start is its Manhattan distance. A
    depth-first walk trying N, S, E, W in turn, over the cells the breadth-first
    search would admit that lie on such a way to a target it would take, and
    never twice over a cell (one that led nowhere leads nowhere by any way
    there), finds the first of these ways: the same target, by the same path.
    """
    r0 = start // stride
    c0 = start % stride
    n = targets.size
    # The targets that may be taken (reached at ``bound`` moves, it is their rank there).
    taken = np.empty(n, dtype=np.int64)
    ranks = np.empty(n, dtype=np.int64)
    count = 0
    for i in range(n):
        t = targets[i]
        if candidate[t] == 0 or abs(t // stride - r0) + abs(t % stride - c0) != bound:
            continue
        found = _target_rank(t, bound, rank, hold, stride, others_r, others_c, home, energy)
        if found >= 0:
            taken[count] = t
            ranks[count] = found
            count += 1
    if count == 0:
        return -1, -1
    steps = (-stride, stride, 1, -1)
    tried = np.zeros(bound + 1, dtype=np.int8)  # the moves tried from each cell of the walk
    seen[start] = stamp
    stack[0] = start
    depth = 0
    while depth >= 0:
        k = tried[depth]
        if k == 4:
            depth -= 1  # led nowhere (and stays seen)
            continue
        tried[depth] = k + 1
        u = stack[depth]
        v = u + steps[k]
        if state[v] != _FREE or seen[v] == stamp:
            continue
        d = depth + 1
        r = v // stride
        c = v % stride
        on_way = -1
        for i in range(count):
            t = taken[i]
            if d + abs(r - t // stride) + abs(c - t % stride) == bound:
                on_way = i
                break
        if on_way < 0:
            continue
        within = False  # as ``_first_reached`` admits cells, by every target
        for i in range(n):
            t = targets[i]
            if d + max(abs(r - t // stride) + abs(c - t % stride), abs(home[v] - home[t])) <= bound:
                within = True
                break
        if not within:
            continue
        seen[v] = stamp
        parent[v] = u
        if d == bound:
            return ranks[on_way], v  # on the way to it and as far: the target itself
        depth = d
        stack[depth] = v
        tried[depth] = 0
    return -1, -1


@njit(cache=True, nogil=True)
def _first_reached(
    state: np.ndarray,
    candidate: np.ndarray,
    targets: np.ndarray,
    start: int,
    stride: int,
    bound: int,
    rank: int,
    hold: int,
    others_r: np.ndarray,
    others_c: np.ndarray,
    home: np.ndarray,
    energy: tuple[float, float, float, float, float],
    seen: np.ndarray,
    stamp: int,
    parent: np.ndarray,
    queue: np.ndarray,
) -> tuple[int, int]:
    """``_first_among``, breadth-first from the start in ``_search``'s order, over the cells whose
    distance plus a lower bound of the way on to some target (as in
    ``_rivals_listed``) is at most ``bound``: either bound changes by at most
    one a move, so, as in ``_path_search``, the targets are reached in the
    same order, from the same parents, as by the search over the whole map.
    """
    steps = (-stride, stride, 1, -1)
    n = targets.size
    toward = 0
    seen[start] = stamp
    queue[0] = start
    head = 0
    tail = 1
    level_end = 1
    distance = 0
    while head < tail:
        if head == level_end:
            level_end = tail
            distance += 1
        u = queue[head]
        head += 1
        d = distance + 1
        for k in range(4):
            v = u + steps[k]
            if state[v] != _FREE or seen[v] == stamp:
                continue
            r = v // stride
            c = v % stride
            within = False
            for i in range(n):
                j = toward + i
                if j >= n:
                    j -= n
                t = targets[j]
                apart = max(abs(r - t // stride) + abs(c - t % stride), abs(home[v] - home[t]))
                if d + apart <= bound:
                    toward = j  # neighbouring cells likely lie on the way to it too
                    within = True
                    break
            if not within:
                continue
            seen[v] = stamp
            parent[v] = u
            queue[tail] = v
            tail += 1
            if candidate[v] == 0:
                continue
            target = False
            for i in range(n):
                if targets[i] == v:
                    target = True
                    break
            if not target:
                continue
            found = _target_rank(v, d, rank, hold, stride, others_r, others_c, home, energy)
            if found >= 0:
                return found, v
    return -1, -1


@njit(cache=True, nogil=True)
def _none_between(
    cells: np.ndarray, start: int, goal: int, moves: int, stride: int, home: np.ndarray
) -> bool:
    """Does no way from ``start`` to ``goal`` through any of ``cells`` come to less
    than ``moves``, by the lower bounds of ``_rivals_listed``?"""
    r0 = start // stride
    c0 = start % stride
    r1 = goal // stride
    c1 = goal % stride
    h0 = home[start]
    h1 = home[goal]
    for k in range(cells.size):
        v = cells[k]
        r = v // stride
        c = v % stride
        there = max(abs(r - r0) + abs(c - c0), abs(home[v] - h0))
        on = max(abs(r - r1) + abs(c - c1), abs(home[v] - h1))
        if there + on < moves:
            return False
    return True


@njit(cache=True, nogil=True)
def _path_search(
    state: np.ndarray,
    blocked: np.ndarray,
    start: int,
    goal: int,
    stride: int,
    bound: int,
    seen: np.ndarray,
    stamp: int,
    parent: np.ndarray,
    queue: np.ndarray,
) -> int:
    """Breadth-first from ``start`` until ``goal`` is reached (N, S, E, W order, as
    ``paths.nearest``), over the cells whose distance from the start plus
    Manhattan distance to the goal is at most ``bound``: 1 when found
    (``parent`` then holds the path), 0 when unreachable, else the smallest
    bound that would let the search go further.

    The Manhattan distance never drops by more than one a move, so every
    shortest path to a kept cell runs over kept cells: the kept cells are
    reached in the same order, from the same parents, as with no bound, and
    the path found is the one the whole search finds.
    """
    steps = (-stride, stride, 1, -1)
    goal_r = goal // stride
    goal_c = goal % stride
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
            reach = distance + 1 + abs(v // stride - goal_r) + abs(v % stride - goal_c)
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
def nearest_manhattan(rows: np.ndarray, cols: np.ndarray, r: int, c: int) -> int:
    """The Manhattan distance from ``(r, c)`` to the nearest of the cells (0 if none)."""
    if rows.size == 0:
        return 0
    nearest = UNREACHED
    for j in range(rows.size):
        m = abs(r - rows[j]) + abs(c - cols[j])
        if m < nearest:
            nearest = m
    return nearest


class Team:
    """Where every agent is and which are working (sweeping or on the way to sweep),
    as arrays the compiled searches read without building lists each decision.
    Agents are numbered by slot."""

    def __init__(self, size: int, at: tuple[int, int]) -> None:
        self.rows = np.full(size, at[0], dtype=np.int64)
        self.cols = np.full(size, at[1], dtype=np.int64)
        self.working = np.ones(size, dtype=np.bool_)

    def others_mask(self, slot: int) -> np.ndarray:
        """The working agents other than ``slot``."""
        mask = self.working.copy()
        mask[slot] = False
        return mask

    def others(self, slot: int) -> tuple[np.ndarray, np.ndarray]:
        """Rows and columns of the working agents other than ``slot``."""
        mask = self.others_mask(slot)
        return self.rows[mask], self.cols[mask]


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


class TargetSearch:
    """Scratch arrays for ``_search``, reused across calls on one belief."""

    #: Most candidates ``_confirm`` looks at one by one.
    RIVALS = 128
    FEW = 512
    LIST_COST = 8

    def __init__(self, belief: MapBelief) -> None:
        size = len(belief.state)
        self.belief = belief
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
        #: A second ``seen``, ``queue`` and ``parent``, for ``_search``.
        self._spare = tuple(np.zeros(size, dtype=np.int32) for _ in range(3))
        self._pool_mask = np.zeros(size, dtype=np.uint8)
        self._blocked = np.zeros(size, dtype=np.uint8)
        self.home = np.frombuffer(belief.charger_dist, dtype=np.int32)

    def path(
        self, start: int, goal: int, blocked: Iterable[int] = (), longest: int | None = None
    ) -> list[int] | None:
        """The shortest path from ``start`` to ``goal`` over known free cells, not
        entering ``blocked`` cells: the start excluded, the goal included. None
        if there is none, or none of at most ``longest`` moves."""
        if start == goal:
            return []
        marked = list(blocked)
        self._blocked[marked] = 1
        stride = self.belief.stride
        shortest = abs(start // stride - goal // stride) + abs(start % stride - goal % stride)
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
    ) -> tuple[int, int, Sequence[int]] | None:
        """What the search from ``start`` would return, found without it when the
        agent is on ``way`` to ``goal``; None when only the search can tell.

        The search returns the first uncontested candidate it reaches (rank 0)
        or, when there is none, the first of the next rank. ``goal`` ranks so
        at the end of ``way``, so the search returns it or a candidate it
        reaches no later. One pass over the uncovered cells within the way's
        length finds the few that might (``_rivals_listed``); when ``goal`` is
        contested, none anywhere may be uncontested (the horizon pass). Then
        a search bounded to the ways to those few (``_first_among``) finds
        what the search over the map around the agent out to the target
        would, as it would at every step of a long transit. With no rival,
        ``way`` is the answer as it stands if it is still a shortest way
        (``_still_shortest``).
        """
        candidate = self.candidate
        if candidate[goal] == 0:
            return None
        moves = len(way)
        home = self.home
        battery, cost, floor, best_cost, budget = energy
        back = int(home[goal])
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
            # terms, or the search's own proof (``_none_uncontested``) rules them out.
            horizon, kept = _uncontested_horizon(
                candidate, listed, start, stride, rows, cols, margin, self._kept, home
            )
            if kept >= 0 and memo is not None:
                memo.remember(self._kept[:kept], self.belief)
            if horizon >= 0:
                self.stamp += 1
                if not _none_uncontested(
                    self.state, candidate, listed, start, stride, rows, cols, home, energy,
                    self._few, self._spare, 8 * self.stamp,
                ):  # fmt: skip
                    return None
        test = (moves, limit, stride, rows, cols, home, energy, self._rivals[:-1])
        # A listed cell costs about LIST_COST cells of the square around the start
        # read row by row (its row and column are worked out by division; the
        # square's few candidates are then passed over as a list).
        square = 2 * moves * moves
        if rank == 0 and listed.size * self.LIST_COST < square:
            # Cells off ``listed`` are surely contested: rank 0 needs only these.
            count = _rivals_listed(candidate, listed, start, goal, *test)
        elif self.belief.uncovered_count * self.LIST_COST < square:
            full = self.uncovered_list[: self.belief.uncovered_count]
            count = _rivals_listed(candidate, full, start, goal, *test)
        else:
            near = self._near[: _in_square(candidate, start, moves, stride, self._near)]
            count = _rivals_listed(candidate, near, start, goal, *test)
        if count == self.RIVALS:
            return None  # too many to look at one by one: the search is as quick
        if count == 0 and self._still_shortest(start, goal, moves, known_at):
            return rank, goal, way
        self._rivals[count] = goal
        return self._first_among(
            start, self._rivals[: count + 1], moves, rank, hold, others, energy
        )

    def _first_among(
        self,
        start: int,
        targets: np.ndarray,
        bound: int,
        rank: int,
        hold: int,
        others: tuple[np.ndarray, np.ndarray],
        energy: tuple[float, float, float, float, float],
    ) -> tuple[int, int, list[int]] | None:
        """``_first_among`` with this search's scratch arrays: (rank, cell, path)."""
        self.stamp += 1
        rank, cell = _first_among(
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
            self.home,
            energy,
            self.seen,
            self.stamp,
            self.parent,
            self.queue,
        )
        return None if rank < 0 else (rank, cell, self._unwind(start, cell))

    def _all_left_to_others(
        self,
        start: int,
        energy: tuple[float, float, float, float, float],
        others: tuple[np.ndarray, np.ndarray],
        hold: int,
    ) -> tuple[bool, tuple[int, int, list[int]] | None]:
        """``(True, what the search returns)`` when every candidate is surely left
        to another agent (within ``hold`` of one, and nearer to it), else
        ``(False, None)``.

        Then the search, finding no better rank, covers the whole known map
        for the first candidate the agent can afford (rank 2: the coordinator
        holds the agent back). Here a pass over the uncovered cells rules out
        better ranks, a second one lists those the agent might afford, and a
        search bounded to the ways to them finds the first, or that there is
        none. With too many to list, only the search can tell.
        """
        candidate, full = self.candidate, self.uncovered_list[: self.belief.uncovered_count]
        found = self._rivals[:-1]
        team = (self.belief.stride, others[0], others[1], self.home, energy, found)
        if _rivals_listed(candidate, full, start, -1, UNREACHED, hold + 1, *team):
            return False, None  # some may rank better
        count = _rivals_listed(candidate, full, start, -1, UNREACHED, 0, *team)
        if count == self.RIVALS:
            return False, None
        targets = found[:count]
        battery, cost, floor, _, _ = energy
        bound = UNREACHED
        if count and cost > 0:  # the farthest any of them can be afforded, and a move to spare
            bound = int((battery - floor) / cost) - int(self.home[targets].min()) + 1
        return True, self._first_among(
            start, targets, min(bound, UNREACHED), 2, hold, others, energy
        )

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
        bounds of ``_rivals_listed`` (in rooms, many such cells lie within the
        Manhattan bound of a way round a wall, but their distance home, as
        known now, tells that they are too far from one end or the other).
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
        return _none_between(new, start, goal, moves, stride, self.home)

    def run(
        self,
        start: int,
        battery: float,
        cost: float,
        floor: float,
        best_cost: float,
        budget: float,
        others: tuple[np.ndarray, np.ndarray],
        hold: int,
        excluded: list[int],
        pool: Iterable[int] | None = None,
        memo: HorizonMemo | None = None,
        hint: tuple[int, Sequence[int], tuple[int, int] | None] | None = None,
    ) -> tuple[int, int, Sequence[int]] | None:
        """The best target as ``(rank, cell, path)`` among ``pool`` (None: the
        uncovered cells), ranked against the ``others`` (rows, columns) agents;
        ``excluded`` cells (claimed by other agents) are not candidates.
        ``memo``: the searching agent's, when ``pool`` is None. ``hint``: the
        target the agent was heading for, its way there and the
        ``MapBelief.stamp`` when that was last known to be a shortest way, if
        ever (``pool`` None only): when it is certain what the search would
        return, it is returned without one, with a shortest path there
        (perhaps not the one the search finds: the way, when it is as short)."""
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
        energy = (battery, cost, floor, best_cost, budget)
        try:
            if hint is not None and pool is None:
                goal, way, known_at = hint
                sure = self._confirm(
                    start, goal, way, known_at, listed, margin, memo, energy, others, hold
                )
                if sure is not None:
                    return sure
                if margin >= 0 and memo is not None:
                    renewed = memo.shortlist(self.belief)  # by the confirmation
                    if renewed is not None:
                        listed, margin = renewed, -1
            if pool is None and hold > 0 and others[0].size:
                known, found = self._all_left_to_others(start, energy, others, hold)
                if known:
                    return found
            self.stamp += 1
            rank, cell, kept = _search(
                self.state,
                mask,
                listed,
                margin,
                self._kept,
                self.home,
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
        return rank, cell, self._unwind(start, cell)


def _warm_up() -> None:
    """Compile (or load from numba's cache) at import, not in the first decision."""
    belief = MapBelief((1, 2), (0, 0))
    belief.mark_free(belief.index((0, 1)))
    search = TargetSearch(belief)
    nobody = np.zeros(0, dtype=np.int64)
    search.run(belief.index((0, 0)), 100.0, 0.0, 0.0, 0.0, 100.0, (nobody, nobody), 0, [])
    nearest_manhattan(nobody, nobody, 0, 0)
    search.path(belief.index((0, 0)), belief.index((0, 1)))


_warm_up()
