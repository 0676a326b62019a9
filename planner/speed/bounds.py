"""Lower bounds of the ways to candidates, and the passes that rank and list them,
compiled with numba.

The bounds are the Manhattan distance and the difference of distances from a
landmark (``planner.speed.landmarks``); the passes list the few candidates that
might come first in a target search (``rivals_listed``), and rank a candidate
as the search does (``target_rank``).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from core.cells import CellState
from planner.belief import UNREACHED
from planner.speed.kernel_args import EnergyTerms, Grid, Rivals
from planner.speed.landmarks import HOME

_FREE = int(CellState.FREE)


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
def may_rival(
    v: int,
    mine: int,
    limit: int,
    grid: Grid,
    rivals: Rivals,
    closer: int,
    energy: EnergyTerms,
    pace: float = 0.0,
) -> int:
    """Could candidate ``v``, ``mine`` moves or more away, be a target that no
    other agent is nearer to than ``min(its distance, limit)``? Not when
    another agent is nearer than ``min(mine, limit)``: then the index of that
    agent (ask about the next cell from there: neighbouring cells likely share
    it). Not when it is out of range or cannot be afforded even at ``mine``
    moves (``_search``'s tests, with ``energy`` its battery, cost, floor,
    best_cost and budget): ``closer``. Else -1.

    With a rival ``pace`` (``limit`` then the hold radius plus one), not either
    when another agent nearer than ``mine`` is nearer than the hold radius plus
    ``pace * mine``: at ``d`` moves a candidate of rank 1 whose nearest other
    agent is nearer than the hold radius plus ``pace * d`` is held back
    (``planner.target_search.rival_first``, the same sum), and so it is at any
    ``d`` from ``mine`` on."""
    _, stride, lands = grid
    others_r, others_c, _ = rivals
    bar = min(mine, limit)
    hold = limit - 1
    r = v // stride - 1
    c = v % stride - 1
    n = others_r.size
    for i in range(n):
        j = closer + i
        if j >= n:
            j -= n
        near = abs(r - others_r[j]) + abs(c - others_c[j])
        if near < bar or (pace > 0.0 and near < mine and near - hold < pace * mine):
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
    ask: tuple[int, int, int, int],
    grid: Grid,
    rivals: Rivals,
    energy: EnergyTerms,
    out: tuple[np.ndarray, np.ndarray],
    pace: float = 0.0,
) -> tuple[int, int]:
    """The listed candidates but ``goal`` that may be within ``reach`` moves of the start
    (``way_at_least``, its Manhattan part first: it rules most out) and ``may_rival`` (with the
    rival ``pace``): put in ``found``, and their count (``found.size`` when there are more);
    second, the count of the listed candidates but ``goal`` within ``reach`` by Manhattan
    distance, put in ``near`` when it has room for every listed cell (else left alone; -1 when
    the pass stopped at too many rivals). ``near`` may be ``listed`` itself: it is written
    behind the reading. ``ask``: the start, ``goal``, ``reach`` and the ``limit`` of
    ``may_rival``; ``out``: ``found`` and ``near``."""
    start, goal, reach, limit = ask
    found, near = out
    _, stride, lands = grid
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
        closer = may_rival(v, mine, limit, grid, rivals, closer, energy, pace)
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
def target_rank(v: int, d: int, rank: int, grid: Grid, rivals: Rivals, energy: EnergyTerms) -> int:
    """The rank of candidate ``v`` reached at ``d`` moves, as ``_search`` ranks it,
    or -1 when it is worse than ``rank`` or the agent cannot afford it there."""
    _, stride, lands = grid
    others_r, others_c, hold = rivals
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


@njit(cache=True, nogil=True)
def moved_within(
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
