"""The compiled target search's scratch arrays over one belief, and the bounded
searches and ways that use them (the base of ``CompiledSearch``)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Final

import numpy as np

from planner.belief import MapBelief
from planner.speed.kernel_args import EnergyTerms, Grid, Rivals, Scratch
from planner.speed.landmarks import Landmarks
from planner.speed.search_kernels import (
    unwind,
)
from planner.speed.walks import (
    AMONG_MARKS,
    first_among,
)
from planner.target_search import (
    Found,
)


@dataclass
class SearchCounts:
    """How often the compiled search took each way to an answer (for the tests and
    the benches: the shortcuts must be taken to be worth their code)."""

    searches: int = 0  # full breadth-first searches (``ranked_search``)
    confirmed: int = 0  # answers of ``_confirm``
    carried: int = 0  # settled targets carried on
    way_listed: int = 0  # confirmations that passed over the way memo's cells
    bounded: int = 0  # searches bounded to the ways to a few targets (``first_among``)
    held_still: int = 0  # held agents' answers told by their distances (``StillField``)


class SearchScratch:
    """The compiled target search's arrays over one belief, reused across calls,
    and the bounded searches and ways that read them."""

    #: Most candidates ``_confirm`` looks at one by one. On a long way in rooms
    #: the lower bounds leave hundreds, all farther than the target, and the
    #: bounded walks to them (``first_among``, mostly the search back) cost
    #: far less than the search of everything within the way's length (a limit
    #: of 128 left thousands of full searches on a 1000x1000 maze).
    RIVALS: Final = 1024
    #: Most candidates ``_all_left_to_others`` lists; it passes over every
    #: uncovered cell, and a longer list only makes it give up later.
    LEFT_TO_OTHERS: Final = 128
    FEW: Final = 512
    LIST_COST: Final = 8

    def __init__(self, belief: MapBelief) -> None:
        size = len(belief.state)
        self.belief = belief
        self.counts = SearchCounts()
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
        #: ``RIVALS`` for this search (with ``_rivals`` to match, a test looks at fewer).
        self.rivals_most = self.RIVALS
        #: The candidates ``ranked_search``'s shortcuts look at one by one (at most its size).
        self._few = np.zeros(self.FEW, dtype=np.int64)
        self._no_near = np.zeros(0, dtype=np.int64)  # ``rivals_listed`` keeps none
        #: A second ``seen``, ``queue`` and ``parent``, for ``ranked_search``.
        self._spare = (
            np.zeros(size, dtype=np.int32),
            np.zeros(size, dtype=np.int32),
            np.zeros(size, dtype=np.int32),
        )
        self._pool_mask = np.zeros(size, dtype=np.uint8)
        self._blocked = np.zeros(size, dtype=np.uint8)
        self.home = np.frombuffer(belief.charger_dist, dtype=np.int32)
        #: Set by ``_confirm`` when no other candidate the agent could take lay
        #: within the way's length: any shortest way keeps the target (``SettledTarget``).
        self._alone = False
        self.landmarks = Landmarks(belief)
        #: The distances from the landmarks (``Landmarks.lands``), brought up to
        #: date at the start of each ``run`` and ``path``.
        self.lands = self.landmarks.lands
        #: The belief's counts when ``lands`` was last brought up to date: while
        #: they stand, ``Landmarks.update`` has nothing to do.
        self._lands_at = (-1, -1, -1)
        #: The map as the kernels read it (``kernel_args.Grid``), with ``lands``.
        self.grid: Grid = (self.state, belief.stride, self.lands)
        self._scratch: Scratch = (self.seen, self.parent, self.queue)

    def update_lands(self) -> np.ndarray:
        """Bring the distances from the landmarks up to date (``lands``, ``grid``)."""
        belief = self.belief
        added, blocked, free = self._lands_at
        if (
            belief.added_count != added
            or belief.blocked_count != blocked
            or belief.free_count != free
        ):
            self.lands = self.landmarks.update()
            self.grid = (self.state, belief.stride, self.lands)
            self._lands_at = (belief.added_count, belief.blocked_count, belief.free_count)
        return self.lands

    def _unwind(self, start: int, goal: int) -> list[int]:
        length = unwind(self.parent, start, goal, self._way)
        return self._way[length - 1 :: -1].tolist()

    def _way_to(self, start: int, cell: int, way: Sequence[int]) -> Sequence[int]:
        """The way the last search left from ``start`` to ``cell``, or ``way`` itself
        when it ends there and is as long: the coordinator keeps the way it is on
        then (``Targets.take``), and a fresh list of a way of
        thousands of moves cost more than the check that found it."""
        if way and way[-1] == cell and unwind(self.parent, start, cell, self._way) == len(way):
            return way
        return self._unwind(start, cell)

    def _way_cells(self, start: int, moves: int, way: Sequence[int] | None = None) -> np.ndarray:
        """The start, then ``way`` (None: the search's first way, as ``_way_to``
        just unwound it), ``moves`` cells."""
        cells = np.empty(moves + 1, dtype=np.int64)
        cells[0] = start
        if way is None:
            cells[1:] = self._way[moves - 1 :: -1]
        else:
            cells[1:] = np.fromiter(way, dtype=np.int64, count=moves)
        return cells

    def _first_among(
        self,
        start: int,
        targets: np.ndarray,
        bound: int,
        rank: int,
        rivals: Rivals,
        energy: EnergyTerms,
        way: Sequence[int] = (),
    ) -> Found | None:
        """``first_among`` with this search's scratch arrays: (rank, cell, path),
        the path ``way`` when that is one as short (``_way_to``)."""
        rank, cell = self._first_reached(start, targets, bound, rank, rivals, energy)
        return None if rank < 0 else Found(rank, cell, self._way_to(start, cell, way))

    def _first_reached(
        self,
        start: int,
        targets: np.ndarray,
        bound: int,
        rank: int,
        rivals: Rivals,
        energy: EnergyTerms,
    ) -> tuple[int, int]:
        """``first_among`` with this search's scratch arrays: (rank, cell), the way
        there left in ``parent``."""
        stamp = self.stamp + 1
        self.stamp += AMONG_MARKS
        self.counts.bounded += 1
        walk = (start, bound, rank, stamp)
        return first_among(self.grid, self.candidate, targets, walk, rivals, energy, self._scratch)
