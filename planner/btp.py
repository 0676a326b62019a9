"""Backtracking points (BTPs): detection from the 8 sensor readings, and the stacks.

Our reading of the paper's Figure 2: after a move along one axis, a side cell
X (perpendicular to the motion) is a BTP when X is free and not covered and
one of the two cells diagonal to the agent on X's side is an obstacle. That is
an opening beside a wall: the region behind the wall would be left behind by
the boustrophedon sweep. Each agent keeps its own stack; the union of the
stacks is the global stack (``owner`` maps a BTP to the agent whose stack
holds it). A BTP leaves the stacks as soon as any agent covers it (eq. 3).
"""

from __future__ import annotations

from typing import Final

from core.cells import CellState, Direction
from planner.belief import MapBelief

_FREE = int(CellState.FREE)
_OBSTACLE = int(CellState.OBSTACLE)

_SIDES: dict[Direction, tuple[Direction, Direction]] = {
    Direction.N: (Direction.E, Direction.W),
    Direction.S: (Direction.E, Direction.W),
    Direction.E: (Direction.N, Direction.S),
    Direction.W: (Direction.N, Direction.S),
}


def detect(belief: MapBelief, index: int, heading: Direction) -> list[int]:
    """BTPs seen by an agent at flat ``index`` that has just moved towards ``heading``."""
    state, covered, offset = belief.state, belief.covered, belief.offset
    ahead = offset[heading]
    found = []
    for side in _SIDES[heading]:
        x = index + offset[side]
        if state[x] != _FREE or covered[x]:
            continue
        if state[x + ahead] == _OBSTACLE or state[x - ahead] == _OBSTACLE:
            found.append(x)
    return found


class BtpStacks:
    """The local stacks of every agent; together they form the global stack."""

    POOL: Final = -1  # owner of BTPs handed back by lost agents

    def __init__(self) -> None:
        self.owner: dict[int, int] = {}
        self._stacks: dict[int, dict[int, None]] = {self.POOL: {}}

    def push(self, agent: int, index: int) -> bool:
        """Put a BTP on ``agent``'s stack unless some stack already holds it."""
        if index in self.owner:
            return False
        self.owner[index] = agent
        self._stacks.setdefault(agent, {})[index] = None
        return True

    def remove(self, index: int) -> bool:
        """Drop a BTP from whatever stack holds it (it was covered)."""
        agent = self.owner.pop(index, None)
        if agent is None:
            return False
        del self._stacks[agent][index]
        return True

    def own(self, agent: int) -> dict[int, None]:
        return self._stacks.get(agent, {})

    def release(self, agent: int) -> None:
        """Hand every BTP of ``agent`` to the global pool (the agent is lost)."""
        for index in self._stacks.pop(agent, {}):
            self.owner[index] = self.POOL
            self._stacks[self.POOL][index] = None

    def __contains__(self, index: object) -> bool:
        return index in self.owner

    def __len__(self) -> int:
        return len(self.owner)
