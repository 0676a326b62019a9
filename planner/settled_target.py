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
"""

from __future__ import annotations

import numpy as np

from planner.belief import MapBelief


class SettledTarget:
    """One agent's target proved by the last full check, and where the agent is
    on the way there. Kept and read by ``TargetSearch``."""

    def __init__(self) -> None:
        #: The agent's cell at the check, then the way, the target last.
        self.cells = np.zeros(0, dtype=np.int64)
        self.goal = -1  # the target; -1: none kept
        #: Where the agent stood at its last decision (an index into ``cells``).
        self.at = 0
        self.battery = 0.0
        #: The move cost, reserve floor, best move cost and range budget of the check.
        self.terms: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
        self.added = 0  # ``MapBelief.added_count`` when last carried
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
        self.cells, self.goal, self.at = cells, int(cells[-1]), 0
        self.battery, self.terms = battery, terms
        self.added, self.stamp, self.claimed = belief.added_count, belief.stamp, claimed

    def forget(self) -> None:
        self.goal = -1

    def step(self, start: int, goal: int, battery: float, cost: float) -> int:
        """How far the agent is along the kept way, when it stands where it stood
        at its last decision or one cell on, with the battery it should have:
        the index into ``cells``; -1 when it is not on it that way."""
        cells, at = self.cells, self.at
        if goal != self.goal:
            return -1
        if cells[at] == start:
            spent = 0.0
        elif at + 1 < cells.size and cells[at + 1] == start:
            at, spent = at + 1, cost
        else:
            return -1
        if battery > self.battery - spent:
            return -1
        return at

    def carry(self, at: int, battery: float, belief: MapBelief) -> None:
        """The agent is at ``cells[at]`` and the target still settled."""
        self.at, self.battery, self.added = at, battery, belief.added_count
