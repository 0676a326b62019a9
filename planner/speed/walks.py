"""Searches bounded to the ways to a few candidates, compiled with numba.

A target search (``planner.speed.compiled_search``) ranks every candidate against
the team; most of its work is ruling out candidates that cannot come first. The
passes of ``planner.speed.bounds`` list the few that might; the searches here,
bounded to the ways to those few, reach them in the same order, from the same
parents, as the search over the whole map: so the plans are the same, cell for
cell.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from core.cells import CellState
from planner.belief import UNREACHED
from planner.speed.bounds import (
    may_rival,
    nearest_manhattan,
    rivals_listed,
    target_rank,
    way_at_least,
    way_within,
)
from planner.speed.kernel_args import Aside, EnergyTerms, Grid, Rivals, Scratch, Walk
from planner.speed.walk_back import first_back, first_tied

_FREE = int(CellState.FREE)

#: Cells a target search reaches, with no target found but those left to
#: others, before it tries ``first_lesser``.
JUMP_AFTER = 4096
#: Bounds ``first_lesser`` tries before leaving it to the search.
JUMP_TRIES = 4
#: The marks of ``seen`` one ``first_among`` uses (a walk, a search back, a search).
AMONG_MARKS = 3


@njit(cache=True, nogil=True)
def first_lesser(
    grid: Grid,
    candidate: np.ndarray,
    everyone: np.ndarray,
    start: int,
    rivals: Rivals,
    energy: EnergyTerms,
    aside: Aside,
) -> tuple[int, int, int]:
    """The first candidate ``_search`` reaches that ranks 1 or better (within
    ``hold`` of no other agent nearer to it, or uncontested) as (rank, cell,
    distance); (-1, -1, -1) when it is left to the search. The way there is
    left in ``aside``'s ``parent``; its ``seen`` marked with its mark to
    that mark ``+ AMONG_MARKS * JUMP_TRIES - 1``.

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
    found, spare, mark = aside
    seen, queue, parent = spare
    limit = rivals[2] + 1
    least = _least_lesser(grid, candidate, everyone, start, rivals, energy)
    if least == UNREACHED:
        return -1, -1, -1
    slack = 0
    for attempt in range(JUMP_TRIES):
        bound = least + slack
        ask = (start, -1, bound, limit)
        count = rivals_listed(
            candidate, everyone, ask, grid, rivals, energy, (found, np.empty(0, dtype=np.int64))
        )[0]
        if count == found.size:
            return -1, -1, -1
        walk = (start, bound, 1, mark + AMONG_MARKS * attempt)
        rank, cell = first_among(
            grid, candidate, found[:count], walk, rivals, energy, (seen, parent, queue)
        )
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
def _least_lesser(
    grid: Grid,
    candidate: np.ndarray,
    everyone: np.ndarray,
    start: int,
    rivals: Rivals,
    energy: EnergyTerms,
) -> int:
    """The least lower bound (``way_at_least``) of the candidates that may rank 1
    or better (``may_rival``), ``first_lesser``'s first bound; ``UNREACHED`` if none."""
    _, stride, lands = grid
    limit = rivals[2] + 1
    closer = 0
    least = UNREACHED
    for k in range(everyone.size):
        v = everyone[k]
        if candidate[v] == 0:
            continue
        mine = way_at_least(v, start, stride, lands)
        if mine >= least:
            continue
        closer = may_rival(v, mine, limit, grid, rivals, closer, energy)
        if closer < 0:
            least = mine
            closer = 0
    return least


@njit(cache=True, nogil=True)
def none_uncontested(
    grid: Grid,
    candidate: np.ndarray,
    listed: np.ndarray,
    start: int,
    rivals: Rivals,
    energy: EnergyTerms,
    aside: Aside,
) -> bool:
    """Is it certain that no candidate is uncontested (rank 0) for ``_search``?

    A candidate is uncontested when its way from the start is no longer than
    its distance to the nearest other agent. One pass lists the few for which
    the lower bounds of ``rivals_listed`` allow it (the ``listed`` cells
    cover them all, as for the horizon), and a breadth-first search, bounded
    to the cells on a way to one of them short enough, tells whether any is
    (False; also when there are too many to list). ``aside``: a list, and a
    ``seen``, a ``queue`` and a ``parent`` of its own, as the search is left as
    it stands, to go on with when this fails.
    """
    found, spare, stamp = aside
    seen, queue, parent = spare
    others_r, others_c, _ = rivals
    stride = grid[1]
    ask = (start, -1, UNREACHED, UNREACHED)
    count = rivals_listed(
        candidate, listed, ask, grid, rivals, energy, (found, np.empty(0, dtype=np.int64))
    )[0]
    if count == found.size or others_r.size == 0:
        return count == 0  # with nobody else, any candidate it can reach is uncontested
    targets = found[:count]
    bounds = np.empty(count, dtype=np.int64)
    for i in range(count):
        t = targets[i]
        bounds[i] = nearest_manhattan(others_r, others_c, t // stride - 1, t % stride - 1)
    walk = (start, 0, 0, stamp)
    rank, _ = reached_within(
        grid, candidate, targets, bounds, walk, rivals, energy, (seen, parent, queue)
    )
    return rank < 0


@njit(cache=True, nogil=True)
def first_among(
    grid: Grid,
    candidate: np.ndarray,
    targets: np.ndarray,
    walk: Walk,
    rivals: Rivals,
    energy: EnergyTerms,
    scratch: Scratch,
) -> tuple[int, int]:
    """``ranked_search`` when only the ``targets`` (candidates in range, and reached
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
    target in turn (up to ``SearchScratch.RIVALS``), and on open ground,
    where either covers the rectangle between the ends, it is as quick
    (docs/performance.md has the comparison). ``stamp`` to ``stamp + 2``
    mark ``seen``.
    """
    start, bound, rank, stamp = walk
    _, stride, lands = grid
    least: int = UNREACHED
    for i in range(targets.size):
        at_least = way_at_least(start, targets[i], stride, lands)
        if at_least < least:
            least = at_least
    if least > bound:
        return -1, -1
    tied = (start, least, rank, stamp)
    found, cell = first_tied(grid, candidate, targets, tied, rivals, energy, scratch)
    if found >= 0 or least == bound:
        return found, cell
    back = (start, bound, rank, stamp + 1)
    found, cell = first_back(grid, candidate, targets, back, rivals, energy, scratch)
    if found >= -1:
        return found, cell
    forward = (start, bound, rank, stamp + 2)
    return first_reached(grid, candidate, targets, forward, rivals, energy, scratch)


@njit(cache=True, nogil=True)
def first_reached(
    grid: Grid,
    candidate: np.ndarray,
    targets: np.ndarray,
    walk: Walk,
    rivals: Rivals,
    energy: EnergyTerms,
    scratch: Scratch,
) -> tuple[int, int]:
    """``first_among``, breadth-first: ``reached_within`` with one bound for all."""
    bounds = np.full(targets.size, walk[1], dtype=np.int64)
    return reached_within(grid, candidate, targets, bounds, walk, rivals, energy, scratch)


@njit(cache=True, nogil=True)
def reached_within(
    grid: Grid,
    candidate: np.ndarray,
    targets: np.ndarray,
    bounds: np.ndarray,
    walk: Walk,
    rivals: Rivals,
    energy: EnergyTerms,
    scratch: Scratch,
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
    by the search over the whole map. (``walk``'s bound is not read.)
    """
    start, _, rank, stamp = walk
    state, stride, _ = grid
    seen, parent, queue = scratch
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
            on_way = _on_way_to(v, d, targets, bounds, toward, grid)
            if on_way < 0:
                continue
            toward = on_way  # neighbouring cells likely lie on the way to it too
            seen[v] = stamp
            parent[v] = u
            queue[tail] = v
            tail += 1
            if candidate[v] == 0 or not _among(v, targets):
                continue
            found = target_rank(v, d, rank, grid, rivals, energy)
            if found >= 0:
                return found, v
    return -1, -1


@njit(cache=True, nogil=True)
def _on_way_to(
    v: int, d: int, targets: np.ndarray, bounds: np.ndarray, toward: int, grid: Grid
) -> int:
    """The first of the ``targets`` (from the one at ``toward`` on) that cell ``v``,
    ``d`` moves from the start, may lie on a way to within its bound; -1 if none."""
    stride, lands = grid[1], grid[2]
    n = targets.size
    for i in range(n):
        j = toward + i
        if j >= n:
            j -= n
        if way_within(v, targets[j], bounds[j] - d, stride, lands):
            return j
    return -1


@njit(cache=True, nogil=True)
def _among(v: int, targets: np.ndarray) -> bool:
    """Is ``v`` one of the ``targets``?"""
    for i in range(targets.size):  # noqa: SIM110 (numba: a loop, not a generator)
        if targets[i] == v:
            return True
    return False
