"""A target that a full check proved, carried along the way to it without another.

The target search of an agent in transit (``TargetSearch.run``) returns the
first candidate it reaches, breadth-first in the order N, S, E, W: of the
candidates at one distance, the one at the end of the way whose moves come
first in that order. Say from cell ``s`` it returns ``g``, ``m`` moves away,
and the agent steps to the first cell ``s'`` of that first way. From ``s'``
the search returns ``g`` again, when the candidates, the ways between the
cells within ``m`` moves, the ranks and what the agent can afford are as they
were:

- ``g`` is ``m - 1`` moves away, and no candidate is nearer than that: every
  cell is at most one move nearer than from ``s``, and one nearer than ``g``
  from ``s'`` would have been nearer than ``g`` from ``s`` too;
- a candidate ``c`` as near as ``g`` from ``s'`` was as near as ``g`` from
  ``s``, through ``s'``. The first way from ``s`` to ``c`` begins with the move
  to ``s'`` as well (a way that begins with an earlier move would come before
  ``g``'s, which begins with that move), so the two ways from ``s'`` are the
  rest of the two from ``s``, in the same order: ``g`` still comes first.

When no other candidate lay within ``m`` moves (the check found none), each
step along any shortest way keeps them all farther than ``g``: any shortest
way will do then, not only the first.

So the agent can walk on without a check while nothing of that changed, which
is the rule in a transit while no other agent works (one agent, or the
last one out):

- no cell became free that could shorten a way (``MapBelief.shortcuts``), none
  was blocked, and each cell that became free since lies beyond the way's
  length by the lower bounds (a new candidate, farther than ``g``);
- no cell claimed by another agent then is a candidate now (a released claim);
- no other agent works, now as then: no candidate is contested;
- the move costs and the range are as they were, and the battery fell by at
  least a move's cost for each move: a candidate the agent could not afford
  then it cannot afford now.

The second point holds for two cells alone, whatever the ranks: when the
search reaches ``g`` before a rival ``r`` as far, then from the next cell of
``g``'s first way, with ``r`` still as far as ``g``, it reaches ``g`` first
again, so long as the ways within their distance are as they were (no cell
blocked, none found since within the way's length). A transit check with
other agents at work that finds such a rival (``CompiledSearch._confirm``)
needs no second search to tell the two apart while that holds
(``SettledTie``).
"""

from __future__ import annotations

import numpy as np

from planner.belief import MapBelief
from planner.speed.bounds import all_beyond


class OnFirstWay:
    """Where an agent is on the search's first way to a cell, from one decision
    to the next."""

    def __init__(self) -> None:
        #: The agent's cell when it was kept, then the way, the cell at its end last.
        self.cells = np.zeros(0, dtype=np.int64)
        self.goal = -1  # the cell at its end; -1: none kept
        #: Where the agent stood at its last decision (an index into ``cells``).
        self.at = 0
        self.added = 0  # ``MapBelief.added_count`` at that decision

    def keep_way(self, cells: np.ndarray, belief: MapBelief) -> None:
        self.cells, self.goal, self.at, self.added = cells, int(cells[-1]), 0, belief.added_count

    def forget(self) -> None:
        self.goal = -1

    def where(self, start: int, goal: int) -> int:
        """The index into ``cells`` of ``start``, when the agent stands where it
        stood at its last decision or one cell on, heading for ``goal``; else -1."""
        cells, at = self.cells, self.at
        if goal != self.goal:
            return -1
        if cells[at] == start:
            return at
        if at + 1 < cells.size and cells[at + 1] == start:
            return at + 1
        return -1

    def none_found_within(
        self, belief: MapBelief, start: int, moves: int, lands: np.ndarray
    ) -> bool:
        """Does every cell found since the last decision lie more than ``moves``
        from ``start``, by the lower bounds (``lands``: the landmarks' distances)?"""
        if belief.added_count == self.added:
            return True
        new = np.frombuffer(belief.added, dtype=np.int64)[self.added : belief.added_count]
        return all_beyond(new, start, moves, belief.stride, lands)

    def carry(self, at: int, belief: MapBelief) -> None:
        """The agent is at ``cells[at]`` and what was kept still holds."""
        self.at, self.added = at, belief.added_count


class SettledTarget(OnFirstWay):
    """One agent's target proved by the last full check, and where the agent is
    on the way there. Kept and read by ``CompiledSearch``."""

    def __init__(self) -> None:
        super().__init__()
        self.battery = 0.0
        #: The move cost, reserve floor, best move cost and range budget of the check.
        self.terms: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
        self.stamp: tuple[int, int] = (0, 0)  # ``MapBelief.stamp`` of the check
        self.claimed = np.zeros(0, dtype=np.int64)

    def keep(
        self,
        cells: np.ndarray,
        battery: float,
        terms: tuple[float, float, float, float],
        belief: MapBelief,
        claimed: np.ndarray,
    ) -> None:
        self.keep_way(cells, belief)
        self.battery, self.terms, self.stamp, self.claimed = battery, terms, belief.stamp, claimed

    def step(self, start: int, goal: int, battery: float, cost: float) -> int:
        """``where``, when the battery fell by a move's cost for each move since."""
        at = self.where(start, goal)
        if at < 0 or battery > self.battery - (cost if at > self.at else 0.0):
            return -1
        return at

    def carry_on(self, at: int, battery: float, belief: MapBelief) -> None:
        self.carry(at, belief)
        self.battery = battery


class SettledTie(OnFirstWay):
    """A rival that the search reaches as far as the target but after it, for an
    agent on the target's first way. Kept and read by ``CompiledSearch._confirm``."""

    def __init__(self) -> None:
        super().__init__()
        self.rival = -1
        self.blocked = 0  # ``MapBelief.blocked_count`` when kept

    def keep(self, cells: np.ndarray, rival: int, belief: MapBelief) -> None:
        self.keep_way(cells, belief)
        self.rival, self.blocked = rival, belief.blocked_count
