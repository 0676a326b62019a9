"""Region claims: dividing a crowd between the parts of the map (``region_claims``).

The map is cut into square regions of ``size`` cells a side. A working agent owns
the region it sweeps in and the region of the target it heads for; the uncovered
cells of regions that other agents own are no targets for an agent looking for
one, unless nothing else is left for it (``Targets`` searches again without
them). In a maze of rooms a crowd would otherwise pour into the same branch,
each agent after the nearest cell no other agent is nearer to, and walk back
out of it together once it is swept.

Who owns what is surveyed again once as many searches as there are agents have
gone by (about an iteration of the fleet), and a region's uncovered cells are
listed again at most every ``_REFRESH`` searches: a cell covered since is
excluded for nothing, a cell found since is left out until the next listing.
That keeps a search's share of the work to a few array slices.
"""

from __future__ import annotations

import numpy as np

from planner.agent import EXPLORING, AgentRecord, Fleet
from planner.belief import MapBelief

#: Searches between two listings of a region's uncovered cells.
_REFRESH = 64

_NONE = np.zeros(0, dtype=np.int64)

Region = tuple[int, int]


class RegionClaims:
    """Which uncovered cells the other agents' regions hold, for one agent's search."""

    def __init__(self, belief: MapBelief, agents: Fleet, size: int) -> None:
        self.belief = belief
        self._agents = agents
        self._size = size
        stride = belief.stride
        self._grid = np.frombuffer(belief.uncovered_mask, dtype=np.uint8).reshape(-1, stride)
        #: Region -> its uncovered cells (flat indices) and the search they were listed at.
        self._listed: dict[Region, tuple[np.ndarray, int]] = {}
        self._searches = 0
        self._survey_due = 0
        #: The owned regions' cells, one after another, and where each region's are.
        self._held = _NONE
        self._slices: dict[Region, tuple[int, int]] = {}

    def region(self, index: int) -> Region:
        r, c = divmod(index, self.belief.stride)
        return r // self._size, c // self._size

    def held_by_others(
        self, a: AgentRecord, claims: dict[int, int], heading: int | None
    ) -> np.ndarray:
        """The uncovered cells of the regions that agents own (where they sweep, and
        where the targets they chase, ``claims``, lie), but for those ``a`` stands in
        or heads for (``heading``): two agents sharing a region do not both leave it."""
        self._searches += 1
        if self._searches >= self._survey_due:
            self._survey(claims)
        cut = [self._slices[r] for r in self._own(a, heading) if r in self._slices]
        if not cut:
            return self._held
        cut.sort()
        pieces, at = [], 0
        for begin, end in cut:
            pieces.append(self._held[at:begin])
            at = end
        pieces.append(self._held[at:])
        return np.concatenate(pieces)

    def _own(self, a: AgentRecord, heading: int | None) -> set[Region]:
        own = {self.region(a.index)}
        if heading is not None:
            own.add(self.region(heading))
        return own

    def _survey(self, claims: dict[int, int]) -> None:
        """Who owns which region now: the agents sweeping, and the targets chased."""
        self._survey_due = self._searches + len(self._agents)
        owned = {self.region(g) for g in claims}
        owned.update(self.region(b.index) for b in self._agents.values() if b.mode == EXPLORING)
        pieces, self._slices, at = [], {}, 0
        for region in sorted(owned):
            cells = self._cells(region)
            pieces.append(cells)
            self._slices[region] = (at, at + cells.size)
            at += cells.size
        self._held = np.concatenate(pieces) if pieces else _NONE

    def _cells(self, region: Region) -> np.ndarray:
        listed = self._listed.get(region)
        if listed is not None and self._searches - listed[1] < _REFRESH:
            return listed[0]
        size, stride = self._size, self.belief.stride
        r0, c0 = region[0] * size, region[1] * size
        rows, cols = np.nonzero(self._grid[r0 : r0 + size, c0 : c0 + size])
        cells = ((rows + r0) * stride + cols + c0).astype(np.int64)
        self._listed[region] = (cells, self._searches)
        return cells
