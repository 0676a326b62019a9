"""The distances from where an agent stands still, for the searches of an agent held back.

An agent held back (every target left to another agent, or to be reached by one first)
searches again from the same cell after each pause. In a maze most of those searches end
held back again, and each covers the whole known map to prove it (most of the planning
of a crowd there). The lower bounds of ``planner.speed.bounds`` cannot tell a target 20
cells away as the crow flies from one 300 moves away round the walls, but the distances
from the agent's cell can, and while the agent stands still they change only as the
known map does: kept in a column from the second search from one cell on, brought up to
date with the cells found since (as the landmarks' columns are), they give every
candidate's exact distance. When at those distances the search's answer is held back,
whichever of the nearest candidates of its rank it reached first, or there is none the
agent can afford (``all_held``), the search is spared.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from planner.belief import UNREACHED, MapBelief
from planner.speed.bounds import nearest_manhattan
from planner.speed.kernel_args import EnergyTerms, Grid, Rivals
from planner.speed.landmarks import fill_column, join_added
from planner.speed.search_kernels import affordable_rank

#: ``all_held``'s verdicts: the search must tell; nothing the agent can afford; held back.
SEARCH, NONE_AFFORDABLE, HELD = -1, 0, 1


@njit(cache=True, nogil=True)
def all_held(
    candidate: np.ndarray,
    listed: np.ndarray,
    dist: np.ndarray,
    grid: Grid,
    rivals: Rivals,
    energy: EnergyTerms,
    pace: float,
) -> int:
    """With ``dist`` the exact distances from the start, is the search's answer
    among the ``listed`` candidates held back? The search returns the first
    candidate the agent can afford of the best rank (``affordable_rank``): with
    none of rank 0, the first of rank 1 it reaches, one of those nearest; the
    agent is held back when that one is one its nearest other agent, drawing
    nearer by ``pace`` cells a move, would come within the hold radius of first
    (``planner.target_search.rival_first``, the same sum), or when all rank 2.
    ``HELD`` when so whichever of the nearest it reaches first,
    ``NONE_AFFORDABLE`` when it can afford none, else ``SEARCH``."""
    _, stride, _ = grid
    others_r, others_c, hold = rivals
    affordable = False
    nearest = UNREACHED  # the distance of the nearest candidates of rank 1
    held = True  # are all of those held back?
    for k in range(listed.size):
        v = listed[k]
        d = dist[v]
        if candidate[v] == 0 or d >= UNREACHED or d == 0:
            continue  # not a candidate, not reached, or the start: the search skips them
        rank = affordable_rank(v, d, grid, rivals, energy)
        if rank < 0:
            continue
        affordable = True
        if rank == 0:
            return SEARCH
        if rank == 1 and d <= nearest:
            near = nearest_manhattan(others_r, others_c, v // stride - 1, v % stride - 1)
            first = pace > 0.0 and near - hold < pace * d
            held = first if d < nearest else held and first
            nearest = d
    if nearest < UNREACHED and not held:
        return SEARCH
    return HELD if affordable else NONE_AFFORDABLE


class StillField:
    """One agent's distances from the cell of its last search, once it searched
    from there twice running (a column of four bytes a cell, dropped when it
    searches from elsewhere)."""

    def __init__(self) -> None:
        self.source = -1  # the cell of the last search
        self._dist: np.ndarray | None = None  # (cells, 1): the distances from ``source``
        self._joined = 0  # ``MapBelief.added_count`` when brought up to date
        self._blocked = 0  # ``MapBelief.blocked_count`` then

    def distances(self, belief: MapBelief, start: int, queue: np.ndarray) -> np.ndarray | None:
        """The distances from ``start`` over the known free cells, when the last
        search was from ``start`` too; else None, and ``start`` remembered.
        ``queue``: scratch room for a cell each."""
        if start != self.source:
            self.source, self._dist = start, None
            return None
        state = np.frombuffer(belief.state, dtype=np.uint8)
        dist = self._dist
        if dist is None or belief.blocked_count != self._blocked:
            if dist is None:
                dist = self._dist = np.empty((state.size, 1), dtype=np.int32)
            fill_column(state, dist, 0, start, belief.stride, queue)
        elif belief.added_count != self._joined:
            added = np.frombuffer(belief.added, dtype=np.int64)[self._joined : belief.added_count]
            join_added(state, dist, added, belief.stride, queue)
        self._joined, self._blocked = belief.added_count, belief.blocked_count
        return dist[:, 0]
