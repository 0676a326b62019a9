"""Searches bounded to the ways to a few candidates, compiled with numba.

A target search (``fast_search``) ranks every candidate against the team; most of
its work is ruling out candidates that cannot come first. Here are the passes that
list the few that might, by lower bounds of their distance (the Manhattan
distance, and the difference of distances from a landmark: ``landmarks``), and
the searches bounded to the ways to those few, which reach them in the same order,
from the same parents, as the search over the whole map: so the plans are the
same, cell for cell.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from planner.belief import UNREACHED
from planner.grid import CellState
from planner.landmarks import HOME

_FREE = int(CellState.FREE)


#: Cells a target search reaches, with no target found but those left to
#: others, before it tries ``first_lesser``.
JUMP_AFTER = 4096
#: Bounds ``first_lesser`` tries before leaving it to the search.
JUMP_TRIES = 4
#: The marks of ``seen`` one ``first_among`` uses (a walk, a search back, a search).
AMONG_MARKS = 3
#: How many times the Manhattan distance a landmark's lower bound of a way must
#: be for ``first_tied`` to search back from the targets (``mostly_away``).
WINDING = 1.25


@njit(cache=True, nogil=True)
def landmark_gap(u: int, v: int, lands: np.ndarray) -> int:
    """The largest difference of the two cells' distances from a landmark
    (``landmarks``: the charger's and the others'), a lower bound of the way
    between them."""
    gap = 0
    for k in range(lands.shape[1]):
        g = abs(lands[u, k] - lands[v, k])
        if g > gap:
            gap = g
    return gap


@njit(cache=True, nogil=True)
def way_at_least(u: int, v: int, stride: int, lands: np.ndarray) -> int:
    """A lower bound of the moves between cells ``u`` and ``v``: a way is at
    least as long as the Manhattan distance, and as the difference of its
    ends' distances from any landmark (the stronger bound where walls make
    the way round long)."""
    apart = abs(u // stride - v // stride) + abs(u % stride - v % stride)
    return max(apart, landmark_gap(u, v, lands))


@njit(cache=True, nogil=True)
def way_within(u: int, v: int, moves: int, stride: int, lands: np.ndarray) -> bool:
    """``way_at_least(u, v) <= moves``, each bound tried in turn (most cells a
    bounded search looks at fail the first, the Manhattan distance)."""
    if abs(u // stride - v // stride) + abs(u % stride - v % stride) > moves:
        return False
    for k in range(lands.shape[1]):  # noqa: SIM110 (a loop is what numba compiles best)
        if abs(lands[u, k] - lands[v, k]) > moves:
            return False
    return True


@njit(cache=True, nogil=True)
def first_lesser(
    state: np.ndarray,
    candidate: np.ndarray,
    everyone: np.ndarray,
    start: int,
    stride: int,
    hold: int,
    others_r: np.ndarray,
    others_c: np.ndarray,
    lands: np.ndarray,
    energy: tuple[float, float, float, float, float],
    found: np.ndarray,
    spare: tuple[np.ndarray, np.ndarray, np.ndarray],
    mark: int,
) -> tuple[int, int, int]:
    """The first candidate ``_search`` reaches that ranks 1 or better (within
    ``hold`` of no other agent nearer to it, or uncontested) as (rank, cell,
    distance); (-1, -1, -1) when it is left to the search. The way there is
    left in ``spare``'s ``parent``; its ``seen`` marked with ``mark`` to
    ``mark + AMONG_MARKS * JUMP_TRIES - 1``.

    In a crowd every candidate near the agent is left to another, and the
    search reaches a great part of the map before it finds one that is not,
    although most of the map's candidates are not (they lie beyond the
    crowd). Their lower bounds (``rivals_listed``) are cheap: the least of
    them, ``B``, among those that may rank so, is where the first can be.
    A search bounded to the ways to the ones within a bound (``first_among``)
    finds the first of them within it, in the search's order, and is the
    search's answer: any other that is nearer is within the bound too. The
    bound widens from ``B`` until one is found (on open maps, nearly always at
    ``B``) or the tries run out, or too many lie within it to list.
    """
    seen, queue, parent = spare
    limit = hold + 1
    closer = 0
    least = UNREACHED
    for k in range(everyone.size):
        v = everyone[k]
        if candidate[v] == 0:
            continue
        mine = way_at_least(v, start, stride, lands)
        if mine >= least:
            continue
        closer = may_rival(v, mine, limit, stride, others_r, others_c, closer, lands, energy)
        if closer < 0:
            least = mine
            closer = 0
    if least == UNREACHED:
        return -1, -1, -1
    slack = 0
    for attempt in range(JUMP_TRIES):
        bound = least + slack
        count = rivals_listed(
            candidate, everyone, start, -1, bound, limit, stride, others_r, others_c,
            lands, energy, found, np.empty(0, dtype=np.int64),
        )[0]  # fmt: skip
        if count == found.size:
            return -1, -1, -1
        rank, cell = first_among(
            state, candidate, found[:count], start, stride, bound, 1, hold,
            others_r, others_c, lands, energy, seen, mark + AMONG_MARKS * attempt, parent, queue,
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
def none_uncontested(
    state: np.ndarray,
    candidate: np.ndarray,
    listed: np.ndarray,
    start: int,
    stride: int,
    others_r: np.ndarray,
    others_c: np.ndarray,
    lands: np.ndarray,
    energy: tuple[float, float, float, float, float],
    found: np.ndarray,
    spare: tuple[np.ndarray, np.ndarray, np.ndarray],
    stamp: int,
) -> bool:
    """Is it certain that no candidate is uncontested (rank 0) for ``_search``?

    A candidate is uncontested when its way from the start is no longer than
    its distance to the nearest other agent. One pass lists the few for which
    the lower bounds of ``rivals_listed`` allow it (the ``listed`` cells
    cover them all, as for the horizon), and a breadth-first search, bounded
    to the cells on a way to one of them short enough, tells whether any is
    (False; also when there are too many to list). ``spare``: a ``seen``, a
    ``queue`` and a ``parent`` of its own, as the search is left as it
    stands, to go on with when this fails.
    """
    count = rivals_listed(
        candidate, listed, start, -1, UNREACHED, UNREACHED, stride, others_r, others_c,
        lands, energy, found, np.empty(0, dtype=np.int64),
    )[0]  # fmt: skip
    if count == found.size or others_r.size == 0:
        return count == 0  # with nobody else, any candidate it can reach is uncontested
    targets = found[:count]
    bounds = np.empty(count, dtype=np.int64)
    for i in range(count):
        t = targets[i]
        bounds[i] = nearest_manhattan(others_r, others_c, t // stride - 1, t % stride - 1)
    seen, queue, parent = spare
    rank, _ = reached_within(
        state, candidate, targets, bounds, start, stride, 0, 0, others_r, others_c, lands,
        energy, seen, stamp, parent, queue,
    )  # fmt: skip
    return rank < 0


@njit(cache=True, nogil=True)
def may_rival(
    v: int,
    mine: int,
    limit: int,
    stride: int,
    others_r: np.ndarray,
    others_c: np.ndarray,
    closer: int,
    lands: np.ndarray,
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
    back = lands[v, HOME]
    if back >= UNREACHED or 2.0 * back * best_cost > budget:
        return closer
    if battery - cost * (mine + back) < floor:
        return closer
    return -1


@njit(cache=True, nogil=True)
def rivals_listed(
    candidate: np.ndarray,
    listed: np.ndarray,
    start: int,
    goal: int,
    reach: int,
    limit: int,
    stride: int,
    others_r: np.ndarray,
    others_c: np.ndarray,
    lands: np.ndarray,
    energy: tuple[float, float, float, float, float],
    found: np.ndarray,
    near: np.ndarray,
) -> tuple[int, int]:
    """The listed candidates but ``goal`` that may be within ``reach`` moves of
    the start (``way_at_least``, its Manhattan part first: it rules most out)
    and ``may_rival``: put in ``found``, and their count (``found.size`` when
    there are more); second, the count of the listed candidates but ``goal``
    within ``reach`` by Manhattan distance, put in ``near`` when it has room for
    every listed cell (else left alone; -1 when the pass stopped at too many
    rivals). ``near`` may be ``listed`` itself: it is written behind the reading."""
    r0 = start // stride
    c0 = start % stride
    keep = near.size >= listed.size
    closer = 0
    count = 0
    kept = 0
    for k in range(listed.size):
        v = listed[k]
        mine = abs(v // stride - r0) + abs(v % stride - c0)
        if mine > reach or v == goal or candidate[v] == 0:
            continue
        if keep:
            near[kept] = v
        kept += 1
        mine = max(mine, landmark_gap(v, start, lands))
        if mine > reach:
            continue
        closer = may_rival(v, mine, limit, stride, others_r, others_c, closer, lands, energy)
        if closer < 0:
            if count == found.size:
                return count, -1
            found[count] = v
            count += 1
            closer = 0
    return count, kept


@njit(cache=True, nogil=True)
def in_square(candidate: np.ndarray, start: int, reach: int, stride: int, out: np.ndarray) -> int:
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
def first_among(
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
    lands: np.ndarray,
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

    The nearest of them by the lower bounds (``way_at_least``) are tried
    first, with the walk of ``first_tied`` out to that bound: in a transit
    the rival that takes the agent's target from it is most often as near
    as its bound says, and the walk, along the ways to it only, is far
    cheaper than the search of everything within ``bound``. Else (or when
    that bound is ``bound``, the only try) the search of everything within
    ``bound``: from the targets back (``first_back``), or when that cannot
    tell, ``first_reached``, breadth-first from the start. The search back
    is the cheaper one wherever the ways go: it tests each cell's lower
    bound to the start alone, where the search forward tests it to each
    target in turn (up to ``TargetSearch.RIVALS``), and on open ground,
    where either covers the rectangle between the ends, it is as quick
    (rooms 1000x1000 with 50 agents, where the ways do not lead away from a
    landmark: 5.1 s for 16392 such searches back against 8.2 s forward,
    the same answers but 125 it could not tell). ``stamp`` to ``stamp + 2``
    mark ``seen``.
    """
    least: int = UNREACHED
    for i in range(targets.size):
        at_least = way_at_least(start, targets[i], stride, lands)
        if at_least < least:
            least = at_least
    if least > bound:
        return -1, -1
    found, cell = first_tied(
        state, candidate, targets, start, stride, least, rank, hold,
        others_r, others_c, lands, energy, seen, stamp, parent, queue,
    )  # fmt: skip
    if found >= 0 or least == bound:
        return found, cell
    found, cell = first_back(
        state, candidate, targets, start, stride, bound, rank, hold,
        others_r, others_c, lands, energy, seen, stamp + 1, parent, queue,
    )  # fmt: skip
    if found >= -1:
        return found, cell
    return first_reached(
        state, candidate, targets, start, stride, bound, rank, hold,
        others_r, others_c, lands, energy, seen, stamp + 2, parent, queue,
    )  # fmt: skip


@njit(cache=True, nogil=True)
def target_rank(
    v: int,
    d: int,
    rank: int,
    hold: int,
    stride: int,
    others_r: np.ndarray,
    others_c: np.ndarray,
    lands: np.ndarray,
    energy: tuple[float, float, float, float, float],
) -> int:
    """The rank of candidate ``v`` reached at ``d`` moves, as ``_search`` ranks it,
    or -1 when it is worse than ``rank`` or the agent cannot afford it there."""
    battery, cost, floor, _, _ = energy
    if battery - cost * (d + lands[v, HOME]) < floor:
        return -1
    near = UNREACHED  # nobody else: uncontested
    if others_r.size:
        near = nearest_manhattan(others_r, others_c, v // stride - 1, v % stride - 1)
    if near >= d:
        found = 0
    elif hold > 0 and near >= min(d, hold + 1):
        found = 1
    else:
        found = 2
    return found if found <= rank else -1


@njit(cache=True, nogil=True)
def first_tied(
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
    lands: np.ndarray,
    energy: tuple[float, float, float, float, float],
    seen: np.ndarray,
    stamp: int,
    parent: np.ndarray,
    stack: np.ndarray,
) -> tuple[int, int]:
    """``first_reached`` when no target is nearer than ``bound`` by the lower
    bounds of ``way_at_least``, without visiting the cells between: the
    targets whose bound is ``bound`` are looked for at that distance.

    The breadth-first search reaches the cells one move farther in the order
    of their parents, and a parent's in the order N, S, E, W: it reaches a
    cell first by the shortest way whose moves come first in that order, and
    of the targets at one distance, first the one at the end of the first of
    these ways. A target ``t`` can then only be reached at ``bound`` moves,
    and a cell ``d`` moves along any way from the start with ``d`` plus its
    lower bound to ``t`` within ``bound`` (as ``first_reached`` admits
    cells) is no nearer than ``d``: else, as the Manhattan distance and each
    landmark's difference obey the triangle inequality, the bound from the
    start to ``t`` would be less than ``bound``. So the walk's depth is each
    cell's distance, and a depth-first walk trying N, S, E, W in turn over
    those cells, never twice over a cell (one that led nowhere leads
    nowhere by any way there), finds the first of these ways: the same
    target, by the same path.
    """
    n = targets.size
    # The targets that may be taken (reached at ``bound`` moves, it is their rank there).
    taken = np.empty(n, dtype=np.int64)
    ranks = np.empty(n, dtype=np.int64)
    count = 0
    for i in range(n):
        t = targets[i]
        if candidate[t] == 0 or way_at_least(start, t, stride, lands) != bound:
            continue
        found = target_rank(t, bound, rank, hold, stride, others_r, others_c, lands, energy)
        if found >= 0:
            taken[count] = t
            ranks[count] = found
            count += 1
    if count == 0:
        return -1, -1
    if mostly_away(taken[:count], start, stride, lands):
        return descent(state, taken[:count], ranks, start, stride, bound, lands, seen, stamp,
                       parent, stack)  # fmt: skip
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
        on_way = -1
        for i in range(count):
            if way_within(v, taken[i], bound - d, stride, lands):
                on_way = i
                break
        if on_way < 0:
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
def mostly_away(targets: np.ndarray, start: int, stride: int, lands: np.ndarray) -> bool:
    """Is the best lower bound of the way to each target a landmark's that it is
    farther from than the start is, and more than ``WINDING`` times its
    Manhattan distance? Then the ways lead away from the landmark round
    walls, and a search back from the targets, bounded by the lower bounds
    to the start, keeps out of the branches beside them, where the walk
    forward from the start enters them all (``descent``, for
    ``first_tied``). On open ground, where the way is as long as the
    Manhattan distance, the forward walk runs straight to the target, and
    the search back would cover the whole rectangle between them; and so in
    rooms off halls, where the ways are a little longer than the Manhattan
    distance: there the search back covers every way between the ends, on
    building 1000x1000 with 50 agents 25 to 30 cells for each move of the
    bound, and the walk forward, following the halls and looking into some
    rooms beside them, 5 or 6 in the median."""
    for i in range(targets.size):
        t = targets[i]
        away = 0
        toward = abs(t // stride - start // stride) + abs(t % stride - start % stride)
        manhattan = toward
        for k in range(lands.shape[1]):
            if lands[start, k] >= UNREACHED or lands[t, k] >= UNREACHED:
                continue
            gap = lands[t, k] - lands[start, k]
            if gap > away:
                away = gap
            elif -gap > toward:
                toward = -gap
        if away <= toward or away <= WINDING * manhattan:
            return False
    return True


@njit(cache=True, nogil=True)
def descent(
    state: np.ndarray,
    taken: np.ndarray,
    ranks: np.ndarray,
    start: int,
    stride: int,
    bound: int,
    lands: np.ndarray,
    seen: np.ndarray,
    stamp: int,
    parent: np.ndarray,
    queue: np.ndarray,
) -> tuple[int, int]:
    """``first_tied``'s answer found from the other end: a breadth-first search
    from the ``taken`` targets (their ranks in ``ranks``) out to the start
    (``search_back``), then a descent from the start (``descend``).

    The walk forward along a way that leads away from a landmark may enter
    every branch that leads away from it too (in a maze, all the rooms
    beyond the start); the search back from the targets only the rooms on
    the ways to them.
    """
    if search_back(state, taken, start, stride, bound, lands, seen, stamp, parent, queue) < 0:
        return -1, -1
    v = descend(start, bound, stride, seen, stamp, parent, queue)
    for i in range(taken.size):
        if taken[i] == v:
            return ranks[i], v
    return -1, -1  # never: the descent ends on a target (depth 0)


@njit(cache=True, nogil=True)
def search_back(
    state: np.ndarray,
    sources: np.ndarray,
    start: int,
    stride: int,
    bound: int,
    lands: np.ndarray,
    seen: np.ndarray,
    stamp: int,
    parent: np.ndarray,
    queue: np.ndarray,
) -> int:
    """The distance from the start to the nearest of the ``sources`` (not the
    start), or -1 when none is within ``bound``: a breadth-first search from
    them all, over the cells whose lower bound to the start is within what is
    left of ``bound`` (every cell of a way that short is). Its depth, each
    cell's distance from the nearest source, is left in ``parent``."""
    steps = (-stride, stride, 1, -1)
    tail = 0
    for i in range(sources.size):
        t = sources[i]
        if seen[t] != stamp and t != start:
            seen[t] = stamp
            parent[t] = 0
            queue[tail] = t
            tail += 1
    head = 0
    level_end = tail
    depth = 0
    while head < tail:
        if head == level_end:
            level_end = tail
            depth += 1
            if depth >= bound:
                break
        u = queue[head]
        head += 1
        for k in range(4):
            w = u + steps[k]
            if state[w] != _FREE or seen[w] == stamp:
                continue
            if not way_within(w, start, bound - depth - 1, stride, lands):
                continue
            seen[w] = stamp
            parent[w] = depth + 1
            if w == start:
                return depth + 1
            queue[tail] = w
            tail += 1
    return -1


@njit(cache=True, nogil=True)
def descend(
    start: int,
    depth: int,
    stride: int,
    seen: np.ndarray,
    stamp: int,
    parent: np.ndarray,
    queue: np.ndarray,
) -> int:
    """After ``search_back`` found the start ``depth`` moves from its sources:
    the source the breadth-first search from the start reaches first at that
    distance, ``parent`` then holding the way there.

    That search reaches a cell first by the shortest way whose moves come
    first in the order N, S, E, W, and of the cells at one distance first
    the one at the end of the first of these ways (``first_tied``); from the
    start, the first of N, S, E, W one move nearer to the sources, in turn,
    is that way, and never a step back: no dead end is entered.
    """
    steps = (-stride, stride, 1, -1)
    v = start
    for d in range(depth):
        want = depth - d - 1
        for k in range(4):
            w = v + steps[k]
            if seen[w] == stamp and parent[w] == want:  # marked here: free
                break
        queue[d] = w
        v = w
    previous = start
    for d in range(depth):
        parent[queue[d]] = previous
        previous = queue[d]
    return v


@njit(cache=True, nogil=True)
def first_back(
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
    lands: np.ndarray,
    energy: tuple[float, float, float, float, float],
    seen: np.ndarray,
    stamp: int,
    parent: np.ndarray,
    queue: np.ndarray,
) -> tuple[int, int]:
    """``first_reached`` found from the other end (``search_back``, ``descend``),
    or (-2, -1) when only ``first_reached`` can tell.

    A target the agent cannot take at its lower bound (``way_at_least``) it
    cannot take farther either: the rank and the battery left only get worse
    with the distance. From the targets it can take at their lower bounds,
    the search back finds the distance to the nearest, and the descent the
    first of those that near: the breadth-first search's answer when the
    agent can take it there. Else (seldom) that search goes on past it, and
    only it can tell.
    """
    sources = np.empty(targets.size, dtype=np.int64)
    count = 0
    for i in range(targets.size):
        t = targets[i]
        if candidate[t] == 0:
            continue
        at_least = way_at_least(start, t, stride, lands)
        if at_least > bound:
            continue
        if target_rank(t, at_least, rank, hold, stride, others_r, others_c, lands, energy) >= 0:
            sources[count] = t
            count += 1
    near = search_back(state, sources[:count], start, stride, bound, lands, seen, stamp,
                       parent, queue)  # fmt: skip
    if near < 0:
        return -1, -1
    v = descend(start, near, stride, seen, stamp, parent, queue)
    found = target_rank(v, near, rank, hold, stride, others_r, others_c, lands, energy)
    return (found, v) if found >= 0 else (-2, -1)


@njit(cache=True, nogil=True)
def first_reached(
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
    lands: np.ndarray,
    energy: tuple[float, float, float, float, float],
    seen: np.ndarray,
    stamp: int,
    parent: np.ndarray,
    queue: np.ndarray,
) -> tuple[int, int]:
    """``first_among``, breadth-first: ``reached_within`` with one bound for all."""
    bounds = np.full(targets.size, bound, dtype=np.int64)
    return reached_within(
        state, candidate, targets, bounds, start, stride, rank, hold,
        others_r, others_c, lands, energy, seen, stamp, parent, queue,
    )  # fmt: skip


@njit(cache=True, nogil=True)
def reached_within(
    state: np.ndarray,
    candidate: np.ndarray,
    targets: np.ndarray,
    bounds: np.ndarray,
    start: int,
    stride: int,
    rank: int,
    hold: int,
    others_r: np.ndarray,
    others_c: np.ndarray,
    lands: np.ndarray,
    energy: tuple[float, float, float, float, float],
    seen: np.ndarray,
    stamp: int,
    parent: np.ndarray,
    queue: np.ndarray,
) -> tuple[int, int]:
    """The first of the ``targets`` that ``_search`` reaches within its bound
    (``bounds``, one each) and that the agent can afford and that ranks
    ``rank`` or better there, as (rank, cell), or (-1, -1); ``parent`` holds
    the path there.

    Breadth-first from the start in the search's order, over the cells whose
    distance plus a lower bound of the way on to some target (``way_at_least``)
    is at most that target's bound: either bound changes by
    at most one a move, so, as in ``_path_search``, every target reached
    within its bound is reached in the same order, from the same parents, as
    by the search over the whole map.
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
            within = False
            for i in range(n):
                j = toward + i
                if j >= n:
                    j -= n
                if way_within(v, targets[j], bounds[j] - d, stride, lands):
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
            found = target_rank(v, d, rank, hold, stride, others_r, others_c, lands, energy)
            if found >= 0:
                return found, v
    return -1, -1


@njit(cache=True, nogil=True)
def surely_affordable(
    targets: np.ndarray,
    start: int,
    lands: np.ndarray,
    energy: tuple[float, float, float, float, float],
) -> bool:
    """Can the agent surely afford one of the ``targets`` by the known ways? So
    when it can by a way through a landmark (the charger's, or another's:
    ``landmarks``), never shorter than the shortest way: an upper bound of
    the moves, as ``way_at_least`` is a lower one."""
    battery, cost, floor, _, _ = energy
    for i in range(targets.size):
        v = targets[i]
        at_most = np.int64(UNREACHED)  # the shortest way through a landmark
        for k in range(lands.shape[1]):
            via = np.int64(lands[start, k]) + np.int64(lands[v, k])
            if via < at_most:
                at_most = via
        if at_most < UNREACHED and battery - cost * (at_most + lands[v, HOME]) >= floor:
            return True
    return False


@njit(cache=True, nogil=True)
def none_between(
    cells: np.ndarray, start: int, goal: int, moves: int, stride: int, lands: np.ndarray
) -> bool:
    """Does no way from ``start`` to ``goal`` through any of ``cells`` come to less
    than ``moves``, by ``way_at_least``?"""
    for k in range(cells.size):
        v = cells[k]
        if way_at_least(start, v, stride, lands) + way_at_least(v, goal, stride, lands) < moves:
            return False
    return True


@njit(cache=True, nogil=True)
def all_beyond(cells: np.ndarray, start: int, reach: int, stride: int, lands: np.ndarray) -> bool:
    """Is every one of ``cells`` more than ``reach`` moves from ``start``, by
    ``way_at_least``?"""
    for k in range(cells.size):  # noqa: SIM110 (a loop is what numba compiles best)
        if way_within(start, cells[k], reach, stride, lands):
            return False
    return True


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
