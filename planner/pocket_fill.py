"""The fills that find the other agents' pockets (``planner.pockets``), compiled
with numba (a module of its own: numba reads its bytecode, so it stays out of
the mypyc build that ``planner.pockets`` is part of).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from core.cells import CellState

_OBSTACLE = int(CellState.OBSTACLE)


@njit(cache=True, nogil=True)
def fill_pocket(
    start: int,
    limit: int,
    grid: tuple[np.ndarray, np.ndarray, int],
    seen: np.ndarray,
    mark: int,
    queue: np.ndarray,
) -> int:
    """Marks ``mark`` in ``seen`` and lists in ``queue`` the cells not known to be
    covered joined to ``start`` (N, S, E, W), and returns their count, or -1 as
    soon as there are more than ``limit``. ``grid``: the belief's states, its
    covered flags and its stride."""
    state, covered, stride = grid
    steps = (-stride, stride, 1, -1)
    seen[start] = mark
    queue[0] = start
    head, tail = 0, 1
    while head < tail:
        i = queue[head]
        head += 1
        for step in steps:
            j = i + step
            if seen[j] == mark or covered[j] or state[j] == _OBSTACLE:
                continue
            if tail == limit:
                return -1
            seen[j] = mark
            queue[tail] = j
            tail += 1
    return tail


@njit(cache=True, nogil=True)
def _fill_held(
    seed: int,
    limit: int,
    grid: tuple[np.ndarray, np.ndarray, int],
    uncovered: np.ndarray,
    scratch: tuple[np.ndarray, np.ndarray, np.ndarray],
    marks: tuple[int, int, int],
) -> tuple[int, int]:
    """One seed's part of ``pockets_held``: ``marks`` are the call's first mark, its
    last so far and the count held so far; returns the last two after it."""
    seen, queue, held = scratch
    first, mark, count = marks
    if seen[seed] > first:  # an earlier fill of the call reached it: the same part
        return mark, count
    mark += 1
    n = fill_pocket(seed, limit, grid, seen, mark, queue)
    for k in range(n):  # none when over the limit (-1)
        cell = queue[k]
        if uncovered[cell]:
            held[count] = cell
            count += 1
    return mark, count


@njit(cache=True, nogil=True)
def pockets_held(
    owners: tuple[np.ndarray, np.ndarray, np.ndarray, int],
    goals: np.ndarray,
    limit: int,
    grid: tuple[np.ndarray, np.ndarray, int],
    uncovered: np.ndarray,
    scratch: tuple[np.ndarray, np.ndarray, np.ndarray],
    first_mark: int,
) -> tuple[int, int]:
    """Lists in ``held`` the uncovered free cells of the others' pockets and returns
    their count and the last mark used in ``seen``. The pockets' seeds: ``goals``
    (the targets the others chase) and the uncovered free cells beside each other
    agent that sweeps (``owners``: the team's rows, columns and sweeping flags, and
    the asking agent's slot). A seed's pocket is its fill, if at most ``limit``
    cells. Each fill takes a new mark after ``first_mark``, so nothing is cleared
    between calls; a seed an earlier fill of the call reached is in the same part
    and is passed over. ``scratch``: ``seen``, a queue and ``held``, each as long
    as the belief's cells."""
    stride = grid[2]
    rows, cols, sweeping, me = owners
    mark, count = first_mark, 0
    for seed in goals:
        mark, count = _fill_held(seed, limit, grid, uncovered, scratch, (first_mark, mark, count))
    steps = (-stride, stride, 1, -1)
    for slot in range(rows.size):
        if slot == me or not sweeping[slot]:
            continue
        at = (rows[slot] + 1) * stride + cols[slot] + 1
        for step in steps:
            seed = at + step
            if uncovered[seed]:
                marks = (first_mark, mark, count)
                mark, count = _fill_held(seed, limit, grid, uncovered, scratch, marks)
    return count, mark
