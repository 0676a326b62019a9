"""What the compiled target search keeps of each agent from one decision to the
next: the cells that may still be uncontested (``HorizonMemo``), the candidates
near its way (``WayMemo``), the target the last check proved
(``SettledTarget``) and the distances from where it stands still
(``StillField``), together one ``AgentMemory``.
"""

from __future__ import annotations

from typing import Final

import numpy as np

from planner.belief import MapBelief
from planner.speed.bounds import moved_within
from planner.speed.settled_target import SettledTarget, SettledTie
from planner.speed.still_field import StillField
from planner.target_search import (
    SearchMemory,
)
from planner.team import Team


class HorizonMemo:
    """One agent's shortlist for the horizon pass of its target searches.

    The pass over every uncovered cell costs as much as the search itself on a
    large map, yet only cells near the agent's own Manhattan region can count.
    A full pass keeps the cells that no other agent was more than ``MARGIN``
    nearer to; until the agent and the others it was ranked against have
    moved more than ``MARGIN`` between them (and while none of those stopped
    working), no other cell can have become uncontested, so the shortlist
    plus the cells that became uncovered since gives the same horizon.
    """

    MARGIN: Final = 16

    def __init__(self, team: Team, slot: int) -> None:
        self._team = team
        self._slot = slot
        #: The team when the cells were kept (rows, columns, the others ranked against);
        #: None while nothing is kept.
        self._at: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
        self._since = 0  # ``MapBelief.added_count`` when they were kept
        #: The shortlist: the ``_kept`` cells, then those added since, in the first
        #: ``_listed`` items (grown by what was added in between, when handed out).
        self._buffer = np.zeros(0, dtype=np.int64)
        self._kept = 0
        self._listed = 0

    def shortlist(self, belief: MapBelief) -> np.ndarray | None:
        """The cells to pass over, or None when a full pass is due."""
        if self._at is None:
            return None
        team = self._team
        rows0, cols0, others0 = self._at
        if not moved_within(
            rows0, cols0, others0, team.rows, team.cols, team.working, self._slot, self.MARGIN
        ):
            return None
        size = self._kept + belief.added_count - self._since
        if size > self._buffer.size:
            grown = np.zeros(max(size, 2 * self._buffer.size), dtype=np.int64)
            grown[: self._listed] = self._buffer[: self._listed]
            self._buffer = grown
        if size > self._listed:
            added = np.frombuffer(belief.added, dtype=np.int64)
            first = self._since + self._listed - self._kept
            self._buffer[self._listed : size] = added[first : belief.added_count]
            self._listed = size
        return self._buffer[:size]

    def remember(self, kept: np.ndarray, belief: MapBelief) -> None:
        team = self._team
        self._at = (team.rows.copy(), team.cols.copy(), team.others_mask(self._slot))
        self._since = belief.added_count
        if kept.size > self._buffer.size:
            self._buffer = np.zeros(2 * kept.size, dtype=np.int64)
        self._buffer[: kept.size] = kept
        self._kept = self._listed = kept.size


class WayMemo:
    """One agent's candidates near its way, carried along a transit from one
    check of its target (``CompiledSearch._confirm``) to the next.

    The check lists the candidates within the way's length of the agent by
    Manhattan distance before it tests their lower bounds. Later, on the way
    to the same target, a cell that was farther than the way then is farther
    still when the agent has come no farther, by Manhattan distance, than the
    way has shortened: the distance to it falls by at most what the agent
    moved. So the cells listed then, those that became free since
    (``MapBelief.added``) and those claimed then (a claim may be released:
    claimed cells are no candidates while it lasts) hold every candidate
    within reach now, and the check passes over them instead of over the
    uncovered cells of the whole map or of the square around the agent.
    """

    def __init__(self) -> None:
        self._goal = -1  # none kept
        self._start = 0
        self._moves = 0
        self._since = 0  # ``MapBelief.added_count`` when they were kept
        self._claimed = np.zeros(0, dtype=np.int64)
        #: The cells kept, in the first ``_kept`` items, and room behind them.
        self._cells = np.zeros(64, dtype=np.int64)
        self._kept = 0
        #: A tie the last check settled on the way (``SettledTie``).
        self.tie = SettledTie()

    def listed(
        self, start: int, goal: int, moves: int, belief: MapBelief, most: int
    ) -> np.ndarray | None:
        """Every candidate within ``moves`` of ``start`` by Manhattan distance, and
        others, on the way to ``goal``; None when what is kept cannot tell, or
        would hand out more than ``most`` cells."""
        if goal != self._goal:
            return None
        stride = belief.stride
        came = abs(start // stride - self._start // stride) + abs(
            start % stride - self._start % stride
        )
        if came > self._moves - moves:
            return None
        kept, added = self._kept, belief.added_count - self._since
        size = kept + added + self._claimed.size
        if size > most:
            return None
        if size > self._cells.size:
            grown = np.zeros(max(size, 2 * self._cells.size), dtype=np.int64)
            grown[:kept] = self._cells[:kept]
            self._cells = grown
        cells = self._cells
        new = np.frombuffer(belief.added, dtype=np.int64)
        cells[kept : kept + added] = new[self._since : belief.added_count]
        cells[kept + added : size] = self._claimed
        return cells[:size]

    def room(self, size: int) -> np.ndarray:
        """Where the next cells to keep are to be written: at least ``size`` items
        (the cells ``listed`` handed out, when they are read: the pass writes
        behind its reading)."""
        if size > self._cells.size:
            self._cells = np.zeros(max(size, 2 * self._cells.size), dtype=np.int64)
        return self._cells

    def keep(
        self, kept: int, start: int, goal: int, moves: int, belief: MapBelief, claimed: np.ndarray
    ) -> None:
        """``kept`` cells were written at ``room``'s (-1: the pass stopped short)."""
        if kept < 0:
            self._goal = -1
            return
        self._goal, self._start, self._moves = goal, start, moves
        self._since, self._kept, self._claimed = belief.added_count, kept, claimed


class AgentMemory(SearchMemory):
    """What the compiled search keeps of one agent (each part may be None: not kept)."""

    def __init__(
        self,
        horizon: HorizonMemo | None = None,
        way: WayMemo | None = None,
        settled: SettledTarget | None = None,
        still: StillField | None = None,
    ) -> None:
        self.horizon = horizon
        self.way = way
        self.settled = settled
        self.still = still
