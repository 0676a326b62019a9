"""The staying alive policy (paper, Algorithm 2): what an agent's battery allows.

Before every move an agent must keep enough charge to reach the charger from
where it will be, over known free cells, and arrive with the reserve
(``can_afford``). A cell is in range when a fully charged agent can go there
and come back (``in_range``); coverage is complete when no uncovered cell is
(``coverage_complete``). Going to charge is a move like any other, made by
``Traffic.go_charge``; this module only judges.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import ndimage

from core.cells import CellState
from planner.agent import LOST, AgentRecord, EventKind, Fleet, PlannerEvent
from planner.belief import UNREACHED, MapBelief
from planner.settings import PlannerSettings

_OBSTACLE = int(CellState.OBSTACLE)
EPS = 1e-9


class StayingAlive:
    """The battery judgements, with the caches they share (the cheapest move of the
    fleet, the cells still open to the charger after a loss, the uncovered cell in
    range that shows coverage is not complete)."""

    def __init__(
        self,
        *,
        belief: MapBelief,
        settings: PlannerSettings,
        agents: Fleet,
        events: list[PlannerEvent],
    ) -> None:
        self.belief = belief
        self.settings = settings
        self._agents = agents
        self._events = events
        self._best_cost: float | None = None  # cache of best_move_cost()
        #: After a loss: the cells the charger may still reach through free or unknown
        #: cells (``in_range``), as of ``_open_at`` (the belief's ``walls_count``);
        #: None before.
        self._open: np.ndarray | None = None
        self._open_at = -1
        self._complete = False
        self._witness: int | None = None  # see ``coverage_complete``
        self._witness_key: tuple[float | None, int] | None = None
        #: Cells found cut off behind lost vehicles when coverage ended (``CUT_OFF``).
        self.cut_off_cells = 0

    # -- one agent's battery ----------------------------------------------------

    def move_cost(self, a: AgentRecord) -> float:
        return a.spec.energy_per_m_pct * self.settings.cell_size_m

    def can_afford(self, a: AgentRecord, moves: int, there: int) -> bool:
        """After ``moves`` moves to ``there``, can the agent still reach the charger
        over known free cells and arrive with at least the reserve?"""
        cost = self.move_cost(a)
        home = self.belief.charger_dist[there]
        if home >= UNREACHED:
            return False
        return a.battery_pct - cost * (moves + home) >= self.settings.reserve_pct - EPS

    def can_afford_home_after(self, a: AgentRecord, moves: int) -> bool:
        """For an agent going home: does the battery last ``moves`` moves (a way that
        ends at the charger) with the reserve left?"""
        return a.battery_pct - self.move_cost(a) * moves >= self.settings.reserve_pct - EPS

    def worth_topping_up(self, a: AgentRecord, moves: int) -> bool:
        """``top_up_ratio``: with a target found ``moves`` away, is a charge first worth
        its trip? When the charger is nearer than the target (the agent walks far
        anyway), and the trip there and back costs little of what the charge gives.
        Only once the agent has covered a cell since it last charged: a crowd
        jostling at the charger's door spends a little charge without covering
        anything, and would go back to the pad for it again and again."""
        ratio = self.settings.top_up_ratio
        home = self.belief.charger_dist[a.index]
        if not ratio or not a.swept or home == 0 or moves <= home:
            return False
        gain = self.settings.resume_pct - a.battery_pct
        if gain <= EPS:
            return False  # full already (or no battery model): nothing to gain
        return 2 * home * self.move_cost(a) <= ratio * gain

    def needs_charge(self, a: AgentRecord) -> bool:
        """Is a charging agent still below ``resume_pct``?"""
        return a.battery_pct < self.settings.resume_pct - EPS

    # -- the fleet's range ------------------------------------------------------

    def best_move_cost(self) -> float:
        """The cheapest move of any agent still in the mission (inf when none is)."""
        if self._best_cost is None:
            self._best_cost = min(
                (self.move_cost(b) for b in self._agents.values() if b.mode != LOST),
                default=math.inf,
            )
        return self._best_cost

    def forget_costs(self) -> None:
        """An agent's consumption changed, or an agent was lost: the cheapest move is
        worked out again when next needed."""
        self._best_cost = None

    @property
    def range_budget_pct(self) -> float:
        """Battery a full charge leaves for a round trip above the reserve."""
        return self.settings.resume_pct - self.settings.reserve_pct + EPS

    def in_range(self, index: int) -> bool:
        """Can a fully charged agent go to ``index`` and come back (for some agent)?"""
        home = self.belief.charger_dist[index]
        if home >= UNREACHED:
            # Not connected to what we know yet: keep it, unless walls and lost
            # vehicles cut it off from the charger even through unknown cells
            # (walls found since the last look may have closed the way).
            return self._open is None or bool(self.open_from_charger()[index])
        return 2 * home * self.best_move_cost() <= self.range_budget_pct

    def open_from_charger(self) -> np.ndarray:
        """Cells the charger may still reach through free or unknown cells, worked
        out again only when walls were found since the last time."""
        belief = self.belief
        if self._open is None or self._open_at != belief.walls_count:
            passable = np.frombuffer(belief.state, dtype=np.uint8) != _OBSTACLE
            parts, _ = ndimage.label(passable.reshape(-1, belief.stride))
            parts = parts.ravel()
            self._open, self._open_at = parts == parts[belief.charger_index], belief.walls_count
        return self._open

    # -- coverage complete ------------------------------------------------------

    def coverage_complete(self) -> bool:
        """Nothing is left that any agent can reach and come back from.

        Judged afresh every time: online, a better estimate of the agents'
        consumption can bring cells judged out of range back into range.
        """
        belief, witness = self.belief, self._witness
        if (
            witness is not None
            and belief.uncovered_mask[witness]
            and self._witness_key == (self._best_cost, belief.blocked_count)
        ):
            # Judged in range under the same costs, and reachable: its way home can only
            # have become shorter since (unless a cell was blocked).
            self._complete = False
            return False
        if witness is None or not belief.uncovered_mask[witness] or not self.in_range(witness):
            # An uncovered cell in range, kept while it stays one: most calls need no scan.
            witness = self._witness = self._uncovered_in_range()
        if witness is not None and belief.charger_dist[witness] < UNREACHED:
            self._witness_key = (self._best_cost, belief.blocked_count)
        else:
            self._witness_key = None
        complete = witness is None
        if complete and not self._complete:
            self.cut_off_cells = self._cut_off_by_lost()
            if self.cut_off_cells:
                where = self.belief.cell(self.belief.blocked[0])
                self._events.append(PlannerEvent(EventKind.CUT_OFF, -1, where))
            else:
                self._events.append(PlannerEvent(EventKind.COVERAGE_COMPLETE, -1))
        self._complete = complete
        return complete

    def _uncovered_in_range(self) -> int | None:
        """An uncovered cell that some agent can reach and come back from, or None.

        Read from the packed list: a set emptied by covering keeps its table, and
        iterating it reads every slot, which once coverage is complete would
        happen at every call."""
        belief = self.belief
        listed = belief.uncovered_list
        for k in range(belief.uncovered_count):
            if self.in_range(listed[k]):
                return listed[k]
        return None

    def _cut_off_by_lost(self) -> int:
        """Cells not known to be walls that the charger could reach if the lost vehicles
        were not in the way, and cannot while they are (0 without lost vehicles)."""
        belief = self.belief
        if not belief.blocked:
            return 0
        state = np.frombuffer(belief.state, dtype=np.uint8)
        passable = state != _OBSTACLE
        passable_without = passable.copy()
        passable_without[belief.blocked] = True
        parts, _ = ndimage.label(passable_without.reshape(-1, belief.stride))
        parts = parts.ravel()
        beyond = (parts == parts[belief.charger_index]) & ~self.open_from_charger()
        beyond[belief.blocked] = False
        return int(beyond.sum())
