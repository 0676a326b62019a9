"""Distances from a few landmarks over the known free cells: lower bounds of ways.

For any cell ``L``, the way between two cells is at least the difference of
their distances from ``L`` (the triangle inequality). The target searches
(``planner.speed.bounds``) bound the ways to their candidates so, and with the
charger as the only landmark the bound is weak wherever the way does not run
towards or away from it: in a maze of rooms the ways are several times the
Manhattan distance, and a bounded search then visits most of the map within
the way's length. A few landmarks spread over the map's edges (each the
known cell farthest from those before it) make the bound tight in most
directions. The bounds only rule cells out of a search that would not have
taken them: the plans are the same with any landmarks, or none.

The distances are kept exact for the map as it is known, as the charger's
(``MapBelief.charger_dist``), but brought up to date only when a search is
about to read them, in one compiled pass over the cells that became free
since: the known free space only grows (distances only shrink), but for a
cell blocked for good, after which every column is worked out again.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from core.cells import CellState
from planner.belief import UNREACHED, MapBelief

_FREE = int(CellState.FREE)

#: The charger's column: its distances are those of ``MapBelief.charger_dist``.
HOME = 0
#: Landmarks besides the charger.
MOST = 8
#: The ways from the charger, over the Manhattan distance, beyond which the
#: landmarks are kept.
DETOUR = 1.25
#: Known free cells before the first landmarks are chosen; they are chosen again
#: each time the known free cells have grown ``REGROWTH`` times over since (or by
#: as many again, while the charger reaches too few cells for all of them).
FIRST_CHOICE = 256
#: The growth of the known free cells after which the landmarks are chosen again:
#: as the map is explored, the farthest cells move out with the frontier, and
#: landmarks left behind it bound the ways to the new targets out there poorly
#: (rooms 1000x1000 with 50 agents: transits of 4000 moves with bounds 600 short
#: of it). Choosing again costs a search of the known map for each landmark: on
#: that map, the decisions to iteration 18000 took 118 / 88 / 108 s with
#: 1.1 / 1.05 / 1.02 (291 s with 2, before ``first_back``).
REGROWTH = 1.05


@njit(cache=True, nogil=True)
def _relax(state: np.ndarray, lands: np.ndarray, col: int, start: int, stride: int,
           queue: np.ndarray) -> None:  # fmt: skip
    """Carry a shortened distance of ``start`` outwards in column ``col``
    (breadth-first and decrease-only: each cell is queued at most once)."""
    steps = (-stride, stride, 1, -1)
    queue[0] = start
    head = 0
    tail = 1
    while head < tail:
        u = queue[head]
        head += 1
        du = lands[u, col] + 1
        for k in range(4):
            v = u + steps[k]
            if state[v] == _FREE and du < lands[v, col]:
                lands[v, col] = du
                queue[tail] = v
                tail += 1


@njit(cache=True, nogil=True)
def join_added(state: np.ndarray, lands: np.ndarray, added: np.ndarray, stride: int,
               queue: np.ndarray) -> None:  # fmt: skip
    """Bring the columns up to date with the ``added`` cells (in the order they
    became free): each takes one more than its nearest neighbour, and what it
    shortens is carried on."""
    steps = (-stride, stride, 1, -1)
    for i in range(added.size):
        v = added[i]
        for col in range(lands.shape[1]):
            best = lands[v, col]
            for k in range(4):
                w = v + steps[k]
                if lands[w, col] + 1 < best:  # cells not free are never reached
                    best = lands[w, col] + 1
            if best < lands[v, col]:
                lands[v, col] = best
                _relax(state, lands, col, v, stride, queue)


@njit(cache=True, nogil=True)
def fill_column(state: np.ndarray, lands: np.ndarray, col: int, source: int, stride: int,
                queue: np.ndarray) -> None:  # fmt: skip
    """Column ``col`` afresh: the distances from ``source``."""
    lands[:, col] = UNREACHED
    lands[source, col] = 0
    _relax(state, lands, col, source, stride, queue)


@njit(cache=True, nogil=True)
def _detour(home: np.ndarray, stride: int, charger: int) -> float:
    """How much longer the ways from the charger are than the Manhattan distance,
    over every cell it reaches (1 on open ground)."""
    ways = 0
    apart = 0
    r0 = charger // stride
    c0 = charger % stride
    for v in range(home.size):
        if home[v] < UNREACHED:
            ways += home[v]
            apart += abs(v // stride - r0) + abs(v % stride - c0)
    return ways / apart if apart else 1.0


@njit(cache=True, nogil=True)
def _spread(state: np.ndarray, lands: np.ndarray, stride: int, queue: np.ndarray,
            cells: np.ndarray) -> int:  # fmt: skip
    """Columns 1 on of ``lands`` afresh, column ``HOME`` as it is: each landmark
    the cell the charger reaches whose nearest of the charger and the landmarks
    before it is the farthest (the first such cell), its distances in the next
    column and the cell in ``cells``. How many were chosen: fewer than the
    columns when none is farther than 0.

    Each search runs in a column of its own (``dist``: four bytes a cell, where a
    row of ``lands`` is nine times that), copied into ``lands`` in the pass that
    also brings each cell's nearest landmark (``near``) up to date: the choice
    reads each column once, where it read all those before for each landmark."""
    size = lands.shape[0]
    near = lands[:, HOME].copy()  # UNREACHED where the charger does not reach
    dist = np.empty((size, 1), dtype=np.int32)
    far = _farthest(near)
    chosen = 0
    while chosen < lands.shape[1] - 1 and far >= 0:
        chosen += 1
        cells[chosen - 1] = far
        fill_column(state, dist, 0, far, stride, queue)
        for v in range(size):
            d = dist[v, 0]
            lands[v, chosen] = d
            if d < near[v]:
                near[v] = d
        far = _farthest(near)
    return chosen


@njit(cache=True, nogil=True)
def _farthest(near: np.ndarray) -> int:
    """The first cell of the greatest ``near`` short of ``UNREACHED``, or -1 when
    none is greater than 0."""
    best = 0
    found = -1
    for v in range(near.size):
        if near[v] < UNREACHED and near[v] > best:
            best = near[v]
            found = v
    return found


class Landmarks:
    """The distance columns of one belief: ``lands[cell, k]``, column ``HOME`` the
    charger's, then those of the landmarks (``cells``), if any: only where the ways
    are long beside the Manhattan distance (``DETOUR``) do they earn their cost;
    on open ground the charger's column alone is kept, as that bound needs no
    help there."""

    def __init__(self, belief: MapBelief) -> None:
        size = len(belief.state)
        self.belief = belief
        self.lands = np.full((size, 1), UNREACHED, dtype=np.int32)
        self.lands[belief.charger_index, HOME] = 0
        self.cells: list[int] = [belief.charger_index]
        self._state = np.frombuffer(belief.state, dtype=np.uint8)
        self._added = np.frombuffer(belief.added, dtype=np.int64)
        self._queue = np.zeros(size, dtype=np.int64)
        self._joined = 0  # ``belief.added_count`` when last brought up to date
        self._blocked = belief.blocked_count
        self._choose_at = FIRST_CHOICE

    def update(self) -> np.ndarray:
        """``lands``, brought up to date with the belief."""
        belief = self.belief
        if belief.blocked_count != self._blocked:
            self._blocked = belief.blocked_count
            self._joined = belief.added_count
            if all(self._state[c] == _FREE for c in self.cells):
                for col, source in enumerate(self.cells):
                    fill_column(self._state, self.lands, col, source, belief.stride, self._queue)
            else:  # a landmark was blocked
                fill_column(self._state, self.lands, HOME, belief.charger_index, belief.stride,
                            self._queue)  # fmt: skip
                self._choose()
        elif belief.added_count != self._joined:
            added = self._added[self._joined : belief.added_count]
            self._joined = belief.added_count
            join_added(self._state, self.lands, added, belief.stride, self._queue)
        if belief.free_count >= self._choose_at:
            # Fewer than wanted: the charger reaches few cells of what is known yet.
            few = self._choose() < MOST
            self._choose_at = (
                belief.free_count + FIRST_CHOICE if few else int(REGROWTH * belief.free_count)
            )
        return self.lands

    def _choose(self) -> int:
        """Choose the landmarks again, each the cell farthest from the charger and
        those chosen before it, or none on open ground; how many could be (as
        many as wanted on open ground)."""
        home = self.lands[:, HOME]
        if _detour(home, self.belief.stride, self.belief.charger_index) < DETOUR:
            if len(self.cells) > 1:
                self.lands = np.ascontiguousarray(self.lands[:, :1])
                self.cells = self.cells[:1]
            return MOST
        lands = self.lands
        if lands.shape[1] != 1 + MOST:
            lands = np.empty((home.size, 1 + MOST), dtype=np.int32)
            lands[:, HOME] = home
        # In place, where it has its columns: a copy of a million rows cost a
        # sixth of the choice (rooms 1000x1000).
        found = np.empty(MOST, dtype=np.int64)
        chosen = _spread(self._state, lands, self.belief.stride, self._queue, found)
        self.lands = lands if chosen == MOST else np.ascontiguousarray(lands[:, : 1 + chosen])
        self.cells = self.cells[:1] + found[:chosen].tolist()
        return chosen
