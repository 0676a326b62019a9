"""Pocket claims: small enclosed parts of the work left whole to the agent at them
(``pocket_claims``).

A pocket is a connected part (N, S, E, W) of the cells not known to be covered
(uncovered free cells and unknown ones) of at most ``limit`` cells, enclosed by
walls and covered cells. An agent that sweeps beside a pocket, or chases a
target in one, owns all of it: it sweeps it on its own, and any other agent
that set out for a cell of it would only walk over covered cells to arrive
beside it. So a target search leaves out the other agents' pockets, and an
agent with nothing else left waits (``Targets``). On the paper's bar maps most
doubled moves were such walks near the end of the mission, several agents
converging on the last few pockets (docs/performance.md).

Every search of a crowd fills from dozens of seeds, up to ``limit`` cells
each: one call a search to the compiled fills of ``planner.pocket_fill``, which
read the team's arrays.
"""

from __future__ import annotations

import numpy as np

from planner.agent import AgentRecord
from planner.belief import MapBelief
from planner.pocket_fill import pockets_held
from planner.team import Team

#: Marks of ``seen`` before it is cleared and they start again.
_MARKS = 1 << 30


class PocketClaims:
    """Which uncovered cells lie in the pockets the other agents own."""

    def __init__(self, belief: MapBelief, team: Team, limit: int) -> None:
        self._team = team
        self.limit = limit
        size = len(belief.state)
        state = np.frombuffer(belief.state, dtype=np.uint8)
        covered = np.frombuffer(belief.covered, dtype=np.uint8)
        self._grid = (state, covered, belief.stride)
        self._uncovered = np.frombuffer(belief.uncovered_mask, dtype=np.uint8)
        self._seen = np.zeros(size, dtype=np.int32)
        self._held = np.zeros(size, dtype=np.int64)
        self._scratch = (self._seen, np.zeros(size, dtype=np.int64), self._held)
        self._mark = 0

    def held_by_others(self, a: AgentRecord, claims: dict[int, int]) -> np.ndarray:
        """The uncovered free cells of every pocket an agent other than ``a`` owns
        (``claims``: target cell -> the agent chasing it). A view: valid until the
        next call."""
        if self._mark > _MARKS:
            self._seen[:] = 0
            self._mark = 0
        me = a.id
        goals = np.array([goal for goal, owner in claims.items() if owner != me], dtype=np.int64)
        team = self._team
        owners = (team.rows, team.cols, team.sweeping, a.slot)
        count, self._mark = pockets_held(
            owners, goals, self.limit, self._grid, self._uncovered, self._scratch, self._mark
        )
        return self._held[:count]
