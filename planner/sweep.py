"""The boustrophedon motion (paper, Algorithm 1): the next cell of an agent's sweep."""

from __future__ import annotations

from typing import Final

from core.cells import CellState
from planner.agent import AgentRecord
from planner.belief import MapBelief
from planner.settings import BmRule, PlannerSettings
from planner.speed.bounds import nearest_manhattan
from planner.team import Team

_FREE: Final = int(CellState.FREE)
_OBSTACLE: Final = int(CellState.OBSTACLE)


class Sweep:
    """Chooses the next cell of the sweep among the free, uncovered cells beside an
    agent that no agent holds (``occupant``: the reservations of ``Traffic``)."""

    def __init__(
        self,
        *,
        belief: MapBelief,
        settings: PlannerSettings,
        occupant: dict[int, int],
        team: Team,
    ) -> None:
        self.belief = belief
        self._occupant = occupant
        self._team = team
        self._paper_sweep = settings.bm_rule in (BmRule.PAPER, BmRule.FORWARD)
        self._forward = settings.bm_rule == BmRule.FORWARD
        self._spread = settings.bm_spread

    def blocked(self, a: AgentRecord) -> bool:
        """Is there no cell to sweep beside the agent (``next_cell`` would be None)?
        Asked of every held agent at every decision, so it builds nothing."""
        state, covered, occupant = self.belief.state, self.belief.covered, self._occupant
        here = a.index
        north, south, east, west = self.belief.steps
        return not (
            self._open(state, covered, occupant, here + north)
            or self._open(state, covered, occupant, here + south)
            or self._open(state, covered, occupant, here + east)
            or self._open(state, covered, occupant, here + west)
        )

    @staticmethod
    def _open(state: bytearray, covered: bytearray, occupant: dict[int, int], v: int) -> bool:
        return state[v] == _FREE and not covered[v] and v not in occupant

    def next_cell(self, a: AgentRecord) -> int | None:
        """The next cell of the boustrophedon motion (Algorithm 1), or None when blocked.

        The paper takes the first of N, S, E, W that is free, uncovered and not
        taken. ``BmRule.TIGHT`` ranks those candidates first by how many
        uncovered ways on they leave (fewest first, unknown counting as open),
        then by the paper's order: it sweeps into dead ends and narrow strips
        before leaving them, so fewer pockets are left behind to come back for.
        ``BmRule.FORWARD`` goes straight on when it can, else as the paper.
        With ``bm_spread``, equally tight moves are ranked by the distance to the
        nearest other working agent, farthest first, so that sweeps move apart
        instead of cutting into each other's area.
        """
        state, covered, occupant = self.belief.state, self.belief.covered, self._occupant
        steps = self.belief.steps
        here = a.index
        candidates = []
        for s in steps:
            v = here + s
            if self._open(state, covered, occupant, v):
                candidates.append(v)
        if len(candidates) <= 1 or self._paper_sweep:
            if self._forward and a.heading is not None and len(candidates) > 1:
                ahead = here + self.belief.offset[a.heading]
                if ahead in candidates:
                    return ahead
            return candidates[0] if candidates else None
        counts = []
        for v in candidates:
            n = 0
            for s in steps:
                w = v + s
                if w != here and state[w] != _OBSTACLE and not covered[w]:
                    n += 1
            counts.append(n)
        tightest = min(counts)
        tied = [v for v, n in zip(candidates, counts, strict=True) if n == tightest]
        if len(tied) == 1 or not self._spread:
            return tied[0]
        rows, cols = self._team.others(a.slot)
        cell_of = self.belief.cell

        def crowding(v: int) -> int:
            return -nearest_manhattan(rows, cols, *cell_of(v))

        return min(tied, key=crowding)
