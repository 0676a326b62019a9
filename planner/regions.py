"""Region claims: dividing a crowd between the parts of the map (``region_claims``).

The map is cut into square regions of ``size`` cells a side. A working agent owns
the region it sweeps in and the region of the target it heads for; the uncovered
cells of regions that other agents own are no targets for an agent looking for
one, unless nothing else is left for it (``Targets`` searches again without
them). In a maze of rooms a crowd would otherwise pour into the same branch,
each agent after the nearest cell no other agent is nearer to, and walk back
out of it together once it is swept.

The uncovered cells of each region are listed when first asked for and again
once ``_REFRESH`` searches have gone by: a cell covered since is excluded for
nothing, and a cell found since is left out until the next listing.
"""

from __future__ import annotations

import numpy as np

from planner.agent import EXPLORING, AgentRecord, Fleet
from planner.belief import MapBelief

#: Searches between two listings of a region's uncovered cells.
_REFRESH = 64

_NONE = np.zeros(0, dtype=np.int64)


class RegionClaims:
    """Which uncovered cells the other agents' regions hold, for one agent's search."""

    def __init__(self, belief: MapBelief, agents: Fleet, size: int) -> None:
        self.belief = belief
        self._agents = agents
        self._size = size
        stride = belief.stride
        self._grid = np.frombuffer(belief.uncovered_mask, dtype=np.uint8).reshape(-1, stride)
        #: Region -> its uncovered cells (flat indices) and the search they were listed at.
        self._listed: dict[tuple[int, int], tuple[np.ndarray, int]] = {}
        self._searches = 0

    def region(self, index: int) -> tuple[int, int]:
        r, c = divmod(index, self.belief.stride)
        return r // self._size, c // self._size

    def held_by_others(
        self, a: AgentRecord, claims: dict[int, int], heading: int | None
    ) -> np.ndarray:
        """The uncovered cells of the regions that agents other than ``a`` own: where
        they sweep, and where the targets they chase (``claims``) lie. The regions
        ``a`` stands in and heads for (``heading``) stay its own too, so that two
        agents sharing a region do not both leave it."""
        self._searches += 1
        own = {self.region(a.index)}
        if heading is not None:
            own.add(self.region(heading))
        owned: set[tuple[int, int]] = set()
        for other in self._agents.values():
            if other is not a and other.mode == EXPLORING:
                owned.add(self.region(other.index))
        for goal, agent in claims.items():
            if agent != a.id:
                owned.add(self.region(goal))
        owned -= own
        if not owned:
            return _NONE
        return np.concatenate([self._cells(region) for region in owned])

    def _cells(self, region: tuple[int, int]) -> np.ndarray:
        listed = self._listed.get(region)
        if listed is not None and self._searches - listed[1] < _REFRESH:
            return listed[0]
        size, stride = self._size, self.belief.stride
        r0, c0 = region[0] * size, region[1] * size
        rows, cols = np.nonzero(self._grid[r0 : r0 + size, c0 : c0 + size])
        cells = (rows + r0) * stride + cols + c0
        self._listed[region] = (cells.astype(np.int64), self._searches)
        return cells
