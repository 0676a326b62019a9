"""The target search's breadth-first kernels, compiled with numba.

A blocked agent ranks every reachable uncovered cell against the rest of the
team (``planner.target_search``); in a large team most searches cover the whole
known map, which in pure Python is most of the planner's time. ``ranked_search``
is the same breadth-first search (same N, S, E, W order, same ranks, same
tie-breaks, so the same plans) over the belief's flat arrays, compiled to
machine code; ``path_search`` finds the first shortest way to one cell.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from core.cells import CellState
from planner.belief import UNREACHED
from planner.speed.bounds import (
    landmark_gap,
    target_rank,
    way_at_least,
)
from planner.speed.kernel_args import EnergyTerms, Grid, Pool, Rivals, Scratch, SearchAside
from planner.speed.landmarks import HOME
from planner.speed.walks import (
    AMONG_MARKS,
    JUMP_AFTER,
    JUMP_TRIES,
    first_lesser,
    none_uncontested,
)

_FREE = int(CellState.FREE)
#: The marks of the spare ``seen`` one ``ranked_search`` may use: ``first_lesser``'s,
#: and one for each ``none_uncontested``.
SPARE_MARKS = AMONG_MARKS * JUMP_TRIES + 2


@njit(cache=True, nogil=True)
def uncontested_horizon(
    candidate: np.ndarray,
    listed: np.ndarray,
    start: int,
    grid: Grid,
    rivals: Rivals,
    margin: int,
    kept: np.ndarray,
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
    _, stride, lands = grid
    others_r, others_c, _ = rivals
    if others_r.size == 0:
        return UNREACHED, -1
    r0 = start // stride - 1
    c0 = start % stride - 1
    horizon = -1
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
        nearest_other, closer = _nearest_unless_under(r, c, rivals, closer, floor)
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
def _nearest_unless_under(
    r: int, c: int, rivals: Rivals, closer: int, floor: int
) -> tuple[int, int]:
    """The Manhattan distance from (``r``, ``c``) to the nearest other agent, tried
    from the one at ``closer`` on, and ``closer``; as soon as one is nearer than
    ``floor``, that one's distance and index."""
    others_r, others_c, _ = rivals
    n = others_r.size
    nearest_other = UNREACHED
    for i in range(n):
        j = closer + i
        if j >= n:
            j -= n
        m = abs(r - others_r[j]) + abs(c - others_c[j])
        if m < nearest_other:
            nearest_other = m
            if m < floor:
                return m, j
    return nearest_other, closer


@njit(cache=True, nogil=True)
def ranked_search(
    grid: Grid,
    pool: Pool,
    start: int,
    energy: EnergyTerms,
    rivals: Rivals,
    scratch: Scratch,
    stamp: int,
    aside: SearchAside,
) -> tuple[int, int, int]:
    """(rank, cell) of the best target, or (-1, -1), and the count of cells
    ``uncontested_horizon`` kept (-1: none kept). ``pool``: ``kernel_args.Pool``;
    ``aside``: the horizon pass's ``margin`` and ``kept`` (``HorizonMemo``), and the
    shortcuts' scratch (``_settled_at``, ``_lesser_first``), a list and a second
    ``seen``, ``queue`` and ``parent`` whose marks are ``SPARE_MARKS * stamp`` and up."""
    candidate = pool[0]
    seen, parent, queue = scratch
    hold = rivals[2]
    best1, best2 = -1, -1
    # Beyond ``horizon`` (worked out when first needed) no target can be uncontested:
    # once the best lesser target is known, the search stops there.
    horizon, kept_count = UNREACHED, -1
    seen[start], queue[0] = stamp, start
    # ``distance``: the cells' being expanded; ``level_end``: where those one farther start.
    head, tail, level_end, distance = 0, 1, 1, 0
    jumped = False
    while head < tail:
        if head == level_end:
            level_end, distance = tail, distance + 1
            if distance + 1 > horizon and (best1 >= 0 or (hold == 0 and best2 >= 0)):
                break
            if not jumped and best1 < 0 and hold > 0 and tail > JUMP_AFTER:
                jumped = True
                rank, v, horizon, kept_count = _lesser_first(
                    grid, pool, start, energy, rivals, parent, stamp, aside
                )
                if rank >= 0:
                    return rank, v, kept_count
        first, tail = tail, _expand(queue[head], grid, scratch, tail, stamp)
        head += 1
        for i in range(first, tail):
            v = queue[i]
            rank = affordable_rank(v, distance + 1, grid, rivals, energy) if candidate[v] else -1
            if rank < 0 or (rank == 1 and best1 >= 0) or (rank == 2 and best2 >= 0):
                continue
            if rank == 0:
                return 0, v, kept_count
            best1, best2 = (v, best2) if rank == 1 else (best1, v)
            if rank == 2 and hold > 0:
                continue  # left to others: the answer only if nothing ranks better
            # The first of the next rank: search on only as far as the horizon,
            # or not at all when no candidate within it is uncontested.
            horizon, kept_count, settled = _settled_at(
                grid, pool, start, energy, rivals, aside, distance + 1, stamp
            )
            if settled:
                return rank, v, kept_count
    return (1, best1, kept_count) if best1 >= 0 else (2 if best2 >= 0 else -1, best2, kept_count)


@njit(cache=True, nogil=True, inline="always")
def _expand(u: int, grid: Grid, scratch: Scratch, tail: int, stamp: int) -> int:
    """Queue the free neighbours of ``u`` not yet seen (N, S, E, W), from ``u``;
    returns the queue's new end."""
    state, stride, _ = grid
    seen, parent, queue = scratch
    for step in (-stride, stride, 1, -1):
        v = u + step
        if state[v] != _FREE or seen[v] == stamp:
            continue
        seen[v] = stamp
        parent[v] = u
        queue[tail] = v
        tail += 1
    return tail


@njit(cache=True, nogil=True, inline="always")
def affordable_rank(v: int, d: int, grid: Grid, rivals: Rivals, energy: EnergyTerms) -> int:
    """Candidate ``v``'s rank ``d`` moves away (``target_rank``), or -1 when it is
    out of range for every agent or the agent cannot afford it there."""
    battery, cost, floor, best_cost, budget = energy
    back = grid[2][v, HOME]
    if back < UNREACHED and 2.0 * back * best_cost > budget:
        return -1  # out of range for every agent
    if back >= UNREACHED or battery - cost * (d + back) < floor:
        return -1  # cannot afford it
    return target_rank(v, d, 2, grid, rivals, energy)  # type: ignore[no-any-return]


@njit(cache=True, nogil=True)
def _settled_at(
    grid: Grid,
    pool: Pool,
    start: int,
    energy: EnergyTerms,
    rivals: Rivals,
    aside: SearchAside,
    d: int,
    stamp: int,
) -> tuple[int, int, bool]:
    """``uncontested_horizon``'s (horizon, kept count), and whether a lesser target
    ``d`` moves away is the answer: beyond the horizon, or no candidate at all is
    uncontested (``none_uncontested``, its mark the last of ``stamp``'s spare marks)."""
    mark = SPARE_MARKS * (stamp + 1) - 1
    candidate, listed, _ = pool
    margin, kept, found, spare = aside
    horizon, kept_count = uncontested_horizon(candidate, listed, start, grid, rivals, margin, kept)
    if d > horizon:
        return horizon, kept_count, True
    none = none_uncontested(grid, candidate, listed, start, rivals, energy, (found, spare, mark))
    return horizon, kept_count, none


@njit(cache=True, nogil=True)
def _lesser_first(
    grid: Grid,
    pool: Pool,
    start: int,
    energy: EnergyTerms,
    rivals: Rivals,
    parent: np.ndarray,
    stamp: int,
    aside: SearchAside,
) -> tuple[int, int, int, int]:
    """The shortcut of a search gone far in a crowd: the first lesser target
    (``first_lesser``) as (rank, cell) when it is the search's answer, else rank
    -1; then the horizon and the kept count as the search goes on with them.
    The way to it is written into ``parent`` as the search would leave it."""
    candidate, listed, everyone = pool
    margin, kept, found, spare = aside
    marks = (found, spare, SPARE_MARKS * stamp)
    rank, v, d = first_lesser(grid, candidate, everyone, start, rivals, energy, marks)
    if rank < 0:
        return -1, -1, UNREACHED, -1
    ours = spare[2]
    w = v
    while w != start:  # the way there, as this search would leave it
        parent[w] = ours[w]
        w = ours[w]
    if rank == 0:
        return 0, v, UNREACHED, -1
    horizon, kept_count = uncontested_horizon(candidate, listed, start, grid, rivals, margin, kept)
    mark = SPARE_MARKS * stamp + AMONG_MARKS * JUMP_TRIES
    if d > horizon or none_uncontested(
        grid, candidate, listed, start, rivals, energy, (found, spare, mark)
    ):
        return 1, v, horizon, kept_count
    # Not proved: search on, as without the shortcut (and find it again).
    return -1, -1, horizon, kept_count


@njit(cache=True, nogil=True)
def path_search(
    grid: Grid, blocked: np.ndarray, start: int, goal: int, bound: int, scratch: Scratch, stamp: int
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
    state, stride, lands = grid
    seen, parent, queue = scratch
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
def unwind(parent: np.ndarray, start: int, goal: int, way: np.ndarray) -> int:
    """Write the path to ``goal`` that a search from ``start`` left in ``parent``
    into ``way``, goal first and the start left out; return its length."""
    length = 0
    v = goal
    while v != start:
        way[length] = v
        length += 1
        v = parent[v]
    return length
