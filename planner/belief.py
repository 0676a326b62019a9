"""The planner's map belief ``M``: unknown / free / obstacle, and which free cells are covered.

Cells are stored flat in ``bytearray``s with a one-cell border of obstacles
around the map, so that neighbour look-ups need no bounds checks and pure
Python loops stay fast. ``index``/``cell`` convert between ``(row, col)`` and
the flat index. Everything outside the map is an obstacle.

The belief also keeps the distance field from the charging station over the
known free cells. It is updated incrementally as free cells are discovered
(distances only ever shrink when the known free space grows), so the return
cost of any cell is one look-up.
"""

from __future__ import annotations

from array import array
from collections import deque
from collections.abc import Mapping

import numpy as np

from core.cells import Cell, CellState, Direction

UNREACHED = 1 << 30

_FREE = int(CellState.FREE)
_OBSTACLE = int(CellState.OBSTACLE)
_UNKNOWN = int(CellState.UNKNOWN)
_DELTA = {d: d.value for d in Direction}


def with_unknown_side(known: np.ndarray) -> np.ndarray:
    """Cells of a grid of ``CellState`` values with an unknown N, S, E or W neighbour
    (off the grid counts as known): nobody sensed from a covered one of them."""
    unknown = np.pad(known == CellState.UNKNOWN, 1)
    return unknown[:-2, 1:-1] | unknown[2:, 1:-1] | unknown[1:-1, :-2] | unknown[1:-1, 2:]


class MapBelief:
    def __init__(self, shape: tuple[int, int], charger: Cell) -> None:
        rows, cols = shape
        if rows <= 0 or cols <= 0:
            raise ValueError(f"map shape must be positive, got {shape}")
        self.shape = (rows, cols)
        self.stride = cols + 2
        size = (rows + 2) * self.stride
        self.state = bytearray([_UNKNOWN]) * size
        for c in range(self.stride):
            self.state[c] = _OBSTACLE
            self.state[(rows + 1) * self.stride + c] = _OBSTACLE
        for r in range(rows + 2):
            self.state[r * self.stride] = _OBSTACLE
            self.state[r * self.stride + cols + 1] = _OBSTACLE
        self.covered = bytearray(size)
        #: Agent id + 1 of the first agent to cover a cell (0 = not covered, or covered
        #: before a restart: ``Coordinator.restore`` covers with agent -1).
        self.covered_by = array("h", bytes(2 * size))
        self.charger_dist = array("i", [UNREACHED]) * size
        self.charger = charger
        self.charger_index = self.index(charger)
        self.steps = (-self.stride, self.stride, 1, -1)  # N, S, E, W
        #: Flat index offset of each of the 8 neighbours.
        self.offset = {d: dr * self.stride + dc for d, (dr, dc) in _DELTA.items()}
        self.covered_count = 0
        self.free_count = 0
        #: Flat indices of known free cells not covered yet (the frontier), the
        #: same as a mask over the flat cells, and packed in the first
        #: ``uncovered_count`` items of ``uncovered_list`` (for compiled scans).
        self.uncovered: set[int] = set()
        self.uncovered_mask = bytearray(size)
        self.uncovered_list = array("q", bytes(8 * size))
        self.uncovered_count = 0
        #: Every cell that became free, in order (so also every cell that joined
        #: the uncovered ones): the first ``added_count`` items (what joined
        #: since some moment is a slice).
        self.added = array("q", bytes(8 * size))
        self.added_count = 0
        #: The cells that, becoming free, may have shortened a way between cells the
        #: charger reached before (``_may_shorten``), in order: the first
        #: ``shortcut_count`` items. Every other cell that becomes free leaves the
        #: distances between those cells as they were.
        self.shortcuts = array("q", bytes(8 * size))
        self.shortcut_count = 0
        #: How many free cells were blocked for good (``block``), and which.
        self.blocked_count = 0
        self.blocked: list[int] = []
        #: How many cells are known to be impassable (obstacles sensed, cells blocked).
        self.walls_count = 0
        self._listed_at = array("q", bytes(8 * size))
        self._set_free(self.charger_index)

    # -- addressing ---------------------------------------------------------

    def index(self, cell: Cell) -> int:
        return (cell[0] + 1) * self.stride + cell[1] + 1

    def cell(self, index: int) -> Cell:
        r, c = divmod(index, self.stride)
        return (r - 1, c - 1)

    def inside(self, cell: Cell) -> bool:
        return 0 <= cell[0] < self.shape[0] and 0 <= cell[1] < self.shape[1]

    # -- queries ------------------------------------------------------------

    def state_of(self, cell: Cell) -> CellState:
        if not self.inside(cell):
            return CellState.OBSTACLE
        return CellState(self.state[self.index(cell)])

    def is_free(self, cell: Cell) -> bool:
        return self.inside(cell) and self.state[self.index(cell)] == _FREE

    def is_covered(self, cell: Cell) -> bool:
        return self.inside(cell) and bool(self.covered[self.index(cell)])

    def distance_to_charger(self, cell: Cell) -> int:
        """Moves from ``cell`` to the charger over known free cells (UNREACHED if none)."""
        return self.charger_dist[self.index(cell)]

    @property
    def stamp(self) -> tuple[int, int]:
        """How far the map has changed: cells that may have shortened a way
        (``shortcuts``), cells blocked. A shortest path at one stamp is one still
        unless a cell was blocked since, or one of those since opens a shorter way."""
        return self.shortcut_count, self.blocked_count

    # -- updates ------------------------------------------------------------

    def sense(self, cell: Cell, readings: Mapping[Direction, CellState]) -> list[int]:
        """Record what an agent at ``cell`` sensed; return newly known free cells."""
        newly_free: list[int] = []
        state, offset = self.state, self.offset
        here = self.index(cell)
        for direction, observed in readings.items():
            # Neighbours off the map fall on the border, which is known (obstacle).
            i = here + offset[direction]
            if state[i] != _UNKNOWN or observed == _UNKNOWN:
                continue
            if observed == _FREE:
                self._set_free(i)
                newly_free.append(i)
            else:
                state[i] = _OBSTACLE
                self.walls_count += 1
        return newly_free

    def cover(self, cell: Cell, agent: int) -> bool:
        """Mark ``cell`` covered by ``agent`` (it is free: an agent stands on it).

        Returns True when the cell was not covered before.
        """
        i = self.index(cell)
        if self.state[i] != _FREE:
            self._set_free(i)
        if self.covered[i]:
            return False
        self.covered[i] = 1
        self.covered_by[i] = agent + 1
        self.covered_count += 1
        self._drop_uncovered(i)
        return True

    def mark_free(self, i: int) -> None:
        """Record flat index ``i`` as free (known from a prior map), if it was unknown."""
        if self.state[i] == _UNKNOWN:
            self._set_free(i)

    def block(self, i: int) -> None:
        """A known free cell is impassable for good (a lost vehicle stands in it): an
        obstacle from now on. The distances home are computed again from scratch (the
        field only ever shrinks otherwise); cells beyond it may become unreachable."""
        if self.state[i] != _FREE or i == self.charger_index:
            return
        self.state[i] = _OBSTACLE
        self.free_count -= 1
        self.blocked_count += 1
        self.blocked.append(i)
        self.walls_count += 1
        self._drop_uncovered(i)
        dist = self.charger_dist
        np.frombuffer(dist, dtype=np.int32)[:] = UNREACHED  # in place: searches hold views
        dist[self.charger_index] = 0
        self._relax_from(self.charger_index)

    def _may_shorten(self, i: int) -> bool:
        """Could cell ``i``, becoming free, shorten a way between two cells that the
        charger reached before?

        Such a way would run through two of its neighbours that the charger
        reached, and no shorter than before when those two were at most two
        moves apart already: two on the same side of ``i`` (N and E, say) are,
        through the cell in their corner if that is free; two on opposite sides
        never are (but through ``i``). A look at the 3x3 cells around ``i``.
        """
        dist, state = self.charger_dist, self.state
        up, down, right, left = self.steps
        n, s = dist[i + up] < UNREACHED, dist[i + down] < UNREACHED
        e, w = dist[i + right] < UNREACHED, dist[i + left] < UNREACHED
        return (
            (n and s)
            or (e and w)
            or (n and e and state[i + up + right] != _FREE)
            or (n and w and state[i + up + left] != _FREE)
            or (s and e and state[i + down + right] != _FREE)
            or (s and w and state[i + down + left] != _FREE)
        )

    def _set_free(self, i: int) -> None:
        if self._may_shorten(i):
            self.shortcuts[self.shortcut_count] = i
            self.shortcut_count += 1
        self.state[i] = _FREE
        self.free_count += 1
        if not self.covered[i] and not self.uncovered_mask[i]:
            self.uncovered.add(i)
            self.uncovered_mask[i] = 1
            n = self.uncovered_count
            self._listed_at[i] = n
            self.uncovered_list[n] = i
            self.uncovered_count = n + 1
        self.added[self.added_count] = i
        self.added_count += 1
        dist = self.charger_dist
        if i == self.charger_index:
            dist[i] = 0
        else:
            # Cells that are not free are never reached: no need to look at their state.
            up, down, right, left = self.steps
            best = min(dist[i + up], dist[i + down], dist[i + right], dist[i + left])
            if best >= UNREACHED:
                return
            dist[i] = best + 1
        self._relax_from(i)

    def _drop_uncovered(self, i: int) -> None:
        if not self.uncovered_mask[i]:
            return
        self.uncovered.discard(i)
        self.uncovered_mask[i] = 0
        n = self.uncovered_count = self.uncovered_count - 1
        last = self.uncovered_list[n]
        at = self._listed_at[i]
        self.uncovered_list[at] = last
        self._listed_at[last] = at

    def _relax_from(self, start: int) -> None:
        """Propagate a shortened distance outwards (decrease-only BFS)."""
        state, dist, steps = self.state, self.charger_dist, self.steps
        queue = deque([start])
        while queue:
            u = queue.popleft()
            du = dist[u] + 1
            for s in steps:
                v = u + s
                if state[v] == _FREE and du < dist[v]:
                    dist[v] = du
                    queue.append(v)

    # -- export -------------------------------------------------------------

    def _unpad(self, flat: bytearray | array) -> np.ndarray:
        rows, cols = self.shape
        grid = (
            np.frombuffer(flat, dtype=np.uint8) if isinstance(flat, bytearray) else np.asarray(flat)
        )
        return grid.reshape(rows + 2, self.stride)[1 : rows + 1, 1 : cols + 1].copy()

    def state_grid(self) -> np.ndarray:
        """The belief as a ``(rows, cols)`` array of ``CellState`` values."""
        return self._unpad(self.state).astype(np.int8)

    def covered_grid(self) -> np.ndarray:
        return self._unpad(self.covered).astype(bool)

    def covered_by_grid(self) -> np.ndarray:
        """Agent id of the first agent to cover each cell, -1 where uncovered."""
        return self._unpad(self.covered_by).astype(np.int16) - 1
