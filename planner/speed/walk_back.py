"""The bounded searches that walk back from the targets to the start, compiled
with numba: where the ways wind far beyond the Manhattan distance (in rooms),
searching back from a few targets visits fewer cells than searching out to
them, and reaches them in the same order (``first_tied``, ``first_back``).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from core.cells import CellState
from planner.belief import UNREACHED
from planner.speed.bounds import target_rank, way_at_least, way_within
from planner.speed.kernel_args import EnergyTerms, Grid, Rivals, Scratch, Walk

_FREE = int(CellState.FREE)

#: How many times the Manhattan distance a landmark's lower bound of a way must
#: be for ``first_tied`` to search back from the targets (``mostly_away``).
WINDING = 1.25


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
    grid: Grid, taken: np.ndarray, ranks: np.ndarray, walk: Walk, scratch: Scratch
) -> tuple[int, int]:
    """``first_tied``'s answer found from the other end: a breadth-first search
    from the ``taken`` targets (their ranks in ``ranks``) out to the start
    (``search_back``), then a descent from the start (``descend``).

    The walk forward along a way that leads away from a landmark may enter
    every branch that leads away from it too (in a maze, all the rooms
    beyond the start); the search back from the targets only the rooms on
    the ways to them.
    """
    start, bound, _, stamp = walk
    if search_back(grid, taken, walk, scratch) < 0:
        return -1, -1
    v = descend(start, bound, grid[1], scratch, stamp)
    for i in range(taken.size):
        if taken[i] == v:
            return ranks[i], v
    return -1, -1  # never: the descent ends on a target (depth 0)


@njit(cache=True, nogil=True)
def search_back(grid: Grid, sources: np.ndarray, walk: Walk, scratch: Scratch) -> int:
    """The distance from the start to the nearest of the ``sources`` (not the
    start), or -1 when none is within ``bound``: a breadth-first search from
    them all, over the cells whose lower bound to the start is within what is
    left of ``bound`` (every cell of a way that short is). Its depth, each
    cell's distance from the nearest source, is left in ``parent``. (``walk``'s
    rank is not read.)"""
    start, bound, _, stamp = walk
    state, stride, lands = grid
    seen, parent, queue = scratch
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
def descend(start: int, depth: int, stride: int, scratch: Scratch, stamp: int) -> int:
    """After ``search_back`` found the start ``depth`` moves from its sources:
    the source the breadth-first search from the start reaches first at that
    distance, ``parent`` then holding the way there.

    That search reaches a cell first by the shortest way whose moves come
    first in the order N, S, E, W, and of the cells at one distance first
    the one at the end of the first of these ways (``first_tied``); from the
    start, the first of N, S, E, W one move nearer to the sources, in turn,
    is that way, and never a step back: no dead end is entered.
    """
    seen, parent, queue = scratch
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
    grid: Grid,
    candidate: np.ndarray,
    targets: np.ndarray,
    walk: Walk,
    rivals: Rivals,
    energy: EnergyTerms,
    scratch: Scratch,
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
    start, bound, rank, stamp = walk
    _, stride, lands = grid
    sources = np.empty(targets.size, dtype=np.int64)
    count = 0
    for i in range(targets.size):
        t = targets[i]
        if candidate[t] == 0:
            continue
        at_least = way_at_least(start, t, stride, lands)
        if at_least > bound:
            continue
        if target_rank(t, at_least, rank, grid, rivals, energy) >= 0:
            sources[count] = t
            count += 1
    near = search_back(grid, sources[:count], walk, scratch)
    if near < 0:
        return -1, -1
    v = descend(start, near, stride, scratch, stamp)
    found = target_rank(v, near, rank, grid, rivals, energy)
    return (found, v) if found >= 0 else (-2, -1)


@njit(cache=True, nogil=True)
def first_tied(
    grid: Grid,
    candidate: np.ndarray,
    targets: np.ndarray,
    walk: Walk,
    rivals: Rivals,
    energy: EnergyTerms,
    scratch: Scratch,
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
    start, stride, lands = walk[0], grid[1], grid[2]
    taken, ranks = _taken_at(grid, candidate, targets, walk, rivals, energy)
    if taken.size == 0:
        return -1, -1
    if mostly_away(taken, start, stride, lands):
        return descent(grid, taken, ranks, walk, scratch)  # type: ignore[no-any-return]
    return _walk_tied(grid, taken, ranks, walk, scratch)


@njit(cache=True, nogil=True)
def _taken_at(
    grid: Grid,
    candidate: np.ndarray,
    targets: np.ndarray,
    walk: Walk,
    rivals: Rivals,
    energy: EnergyTerms,
) -> tuple[np.ndarray, np.ndarray]:
    """The targets ``first_tied`` may take (by the lower bounds ``bound`` moves away,
    affordable and ranking ``rank`` or better there) and their ranks there."""
    start, bound, rank, _ = walk
    stride, lands = grid[1], grid[2]
    n = targets.size
    taken = np.empty(n, dtype=np.int64)
    ranks = np.empty(n, dtype=np.int64)
    count = 0
    for i in range(n):
        t = targets[i]
        if candidate[t] == 0 or way_at_least(start, t, stride, lands) != bound:
            continue
        found = target_rank(t, bound, rank, grid, rivals, energy)
        if found >= 0:
            taken[count] = t
            ranks[count] = found
            count += 1
    return taken[:count], ranks[:count]


@njit(cache=True, nogil=True)
def _walk_tied(
    grid: Grid, taken: np.ndarray, ranks: np.ndarray, walk: Walk, scratch: Scratch
) -> tuple[int, int]:
    """``first_tied``'s depth-first walk to the ``taken`` targets, ``bound`` moves
    away, over the cells on a way to one of them that short."""
    start, bound, _, stamp = walk
    state, stride, lands = grid
    seen, parent, stack = scratch
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
        for i in range(taken.size):
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
