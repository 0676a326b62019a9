"""Target choice of a blocked agent (paper, Algorithm 3, with an exact search).

A blocked agent looks for a target in tiers (``TargetPolicy``): its own BTPs,
then everyone's, then the safety net (every uncovered cell), or every
uncovered cell at once. In each tier it takes the nearest target it can afford
and come back from, that nobody else chases, preferring those no other working
agent is nearer to (``_Rank``). When every target is about to be swept by a
nearer agent, it waits (``HELD``), and looks again after a pause that doubles.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Collection, Iterable, Sequence
from enum import IntEnum
from typing import NamedTuple

import numpy as np

from planner import btp
from planner.agent import (
    EXPLORING,
    IDLE,
    TRANSIT,
    WAIT,
    Action,
    AgentRecord,
    EventKind,
    PlannerEvent,
)
from planner.belief import MapBelief
from planner.pockets import PocketClaims
from planner.prm import Roadmap
from planner.regions import RegionClaims
from planner.settings import BtpChoice, PlannerSettings, TargetPolicy
from planner.staying_alive import EPS as _EPS
from planner.staying_alive import StayingAlive
from planner.sweep import Sweep
from planner.target_search import Energy, Found, Hint, SearchRequest, TargetSearch
from planner.team import Team
from planner.traffic import Traffic


class _Rank(IntEnum):
    """How good a target is for an agent, when spreading the team out."""

    UNCONTESTED = 0  # no other working agent is closer
    BEYOND_HOLD = 1  # another is closer, but not about to sweep it
    CONTESTED = 2  # within hold_radius of another working agent


class _Tier(IntEnum):
    OWN = 0
    GLOBAL = 1
    NET = 2
    FRONTIER = 3


#: Where a blocked agent looks for a target, in order.
_TIERS: dict[TargetPolicy, tuple[_Tier, ...]] = {
    TargetPolicy.OWN_FIRST: (_Tier.OWN, _Tier.GLOBAL, _Tier.NET),
    TargetPolicy.NEAREST: (_Tier.GLOBAL, _Tier.NET),
    TargetPolicy.FRONTIER: (_Tier.FRONTIER,),
}


class _Held:
    """Every target is being swept by a nearer agent: wait."""


HELD = _Held()
_NO_CELLS = np.zeros(0, dtype=np.int64)
_NOBODY = (_NO_CELLS, _NO_CELLS)

_Found = tuple[int, Sequence[int]] | _Held | None


class Finders(NamedTuple):
    """How a blocked agent's target is found: the target search, ranking it against
    the ``team``, or the ``roadmap`` (the paper's way) when there is one."""

    search: TargetSearch
    team: Team
    roadmap: Roadmap | None


class Targets:
    """Finds a blocked agent its next target, claims it and sets the agent on its way."""

    def __init__(
        self,
        *,
        belief: MapBelief,
        settings: PlannerSettings,
        stacks: btp.BtpStacks,
        traffic: Traffic,
        alive: StayingAlive,
        finders: Finders,
        sweep: Sweep,
        events: list[PlannerEvent],
    ) -> None:
        self.belief = belief
        self.settings = settings
        self._stacks = stacks
        self._traffic = traffic
        self._alive = alive
        self._search, self._team, self._roadmap = finders
        self._sweep = sweep
        #: With ``region_claims``: the other agents' regions, left to them first.
        size = settings.region_claims
        self._regions = RegionClaims(belief, traffic.fleet, size) if size else None
        #: With ``pocket_claims``: the pockets other agents sweep beside or chase a
        #: target in, left to them.
        limit = settings.pocket_claims
        self._pockets = PocketClaims(belief, self._team, limit) if limit else None
        self._claims = traffic.claims
        self._events = events
        self._tiers = _TIERS[settings.target_policy]
        #: A BTP is taken by ``btp_choice`` rather than by the ranked search.
        self._by_choice = settings.btp_choice != BtpChoice.PATH
        self.safety_net_fires = 0

    def take(self, a: AgentRecord) -> Action:
        """The blocked agent's next action: on its way to a new target (or the one it
        was heading for), to charge first, or a wait."""
        if a.held_for > 0:
            # Held back from targets others are about to sweep: look again only
            # after a pause that doubles while nothing frees up (each look is a
            # search of the known map).
            a.held_for -= 1
            return WAIT
        previous, old_path = a.was_heading_for, a.path
        a.was_heading_for = None
        self._traffic.drop_claim(a)
        uncovered = self.belief.uncovered
        hint = self._hint(a, previous, old_path)
        any_candidate = False
        found: _Found
        for tier in self._tiers:
            pool = self._pool(tier, a)
            if tier == _Tier.NET and self.settings.net_when_alone and self._others_working(a):
                continue  # wait for a BTP while the others may still find one
            if self._by_choice and tier in (_Tier.OWN, _Tier.GLOBAL):
                found = self._chosen_btp(a, pool)
                if found is None:
                    any_candidate = any_candidate or self._any_in_range(pool)
                    continue
                any_candidate = True
            elif self._roadmap is None:
                found = self._nearest_affordable(
                    a, None if pool is uncovered else pool, hint, previous
                )
                if found is None:
                    any_candidate = any_candidate or self._any_in_range(pool)
                    continue
                any_candidate = True
            else:
                candidates = {i for i in pool if i not in self._claims and self._alive.in_range(i)}
                if not candidates:
                    continue
                any_candidate = True
                found = self._nearest_on_roadmap(a, candidates)
            if isinstance(found, _Held):
                return self._hold(a)
            a.held_backoff = 0
            if found is None:
                continue
            return self._set_out(a, tier, found, previous, hint is not None, old_path)
        if any_candidate and (a.index != self.belief.charger_index or self._alive.needs_charge(a)):
            return self._traffic.go_charge(a)  # what is left needs more battery than it has
        a.mode = IDLE
        return WAIT

    def transit_ends(self, a: AgentRecord) -> bool:
        """In transit: is the target reached or swept, or (``replan_transit``) is it
        time to decide again? Then the agent drops its claim and explores."""
        goal = a.goal
        assert goal is not None
        # Re-deciding needs consistent shortest paths: with the roadmap a
        # fresh path from one step on can be longer than the rest of the
        # old one, and the agent would turn back before every arrival.
        replan = self.settings.replan_transit and self._roadmap is None
        if not (
            a.index == goal
            or not self.belief.uncovered_mask[goal]
            # An uncovered cell beside the way is swept at once.
            or (replan and (a.recheck_in <= 0 or self._sweep.next_cell(a) is not None))
        ):
            return False
        a.was_heading_for = goal
        self._traffic.drop_claim(a)
        a.mode = EXPLORING
        return True

    def _hint(self, a: AgentRecord, previous: int | None, old_path: deque[int]) -> Hint | None:
        """Still on the way to ``previous``: the search may be skipped when it would
        surely return it again (``TargetSearch.run``)."""
        if (
            previous is not None
            and old_path
            and old_path[-1] == previous
            and abs(old_path[0] - a.index) in (1, self.belief.stride)
        ):
            return Hint(previous, old_path, a.path_known_at)
        return None

    def _pool(self, tier: _Tier, a: AgentRecord) -> Collection[int]:
        if tier == _Tier.OWN:
            return self._stacks.own(a.id)
        if tier == _Tier.GLOBAL:
            return self._stacks.owner
        return self.belief.uncovered

    def _any_in_range(self, pool: Iterable[int]) -> bool:
        """Is a target of ``pool`` left that nobody chases and a full charge reaches?"""
        claims, in_range = self._claims, self._alive.in_range
        return any(i not in claims and in_range(i) for i in pool)

    def _others_working(self, a: AgentRecord) -> bool:
        working = self._team.working
        return bool(working.sum() - working[a.slot])

    def _chosen_btp(self, a: AgentRecord, pool: Collection[int]) -> _Found:
        """The BTP of ``pool`` that ``btp_choice`` names first (nearest by straight line,
        or the last found) among those nobody chases and the agent can afford, with
        a shortest way there (or the roadmap's)."""
        belief, claims, alive = self.belief, self._claims, self._alive
        if self.settings.btp_choice == BtpChoice.LAST:
            order: Iterable[int] = reversed(list(pool))
        else:
            r, c = belief.cell(a.index)

            def line(i: int) -> tuple[int, int]:
                dr, dc = belief.cell(i)
                return (dr - r) ** 2 + (dc - c) ** 2, i

            order = sorted(pool, key=line)
        for goal in order:
            if goal in claims or not alive.in_range(goal):
                continue
            if self._roadmap is not None:
                path = self._roadmap.path(belief, a.index, goal)
            else:
                path = self._search.path(a.index, goal)
            if path and alive.can_afford(a, len(path), goal):
                return goal, path
        return None

    def _nearest_on_roadmap(self, a: AgentRecord, candidates: set[int]) -> _Found:
        """The paper's way: the nearest affordable candidate along the roadmap."""
        assert self._roadmap is not None
        return self._roadmap.nearest(
            self.belief, a.index, candidates, lambda i, d: self._alive.can_afford(a, d, i)
        )

    def _hold(self, a: AgentRecord) -> Action:
        """Every target is left to a nearer agent: wait, longer each time."""
        a.mode = IDLE
        a.held_backoff = min(2 * a.held_backoff + 1, self.settings.held_backoff_max)
        a.held_for = a.held_backoff
        return WAIT

    def _set_out(
        self,
        a: AgentRecord,
        tier: _Tier,
        found: tuple[int, Sequence[int]],
        previous: int | None,
        hinted: bool,
        old_path: deque[int],
    ) -> Action:
        """Claim the target found and take the first step there (or charge first)."""
        goal, path = found
        if self._alive.worth_topping_up(a, len(path)):
            return self._traffic.go_charge(a)
        if hinted and goal == previous and len(old_path) <= len(path):
            # Re-deciding in transit: keep a detour around other agents
            # that is no longer than the fresh path, or the two alternate
            # and the agent paces between them for ever.
            path = old_path
        self._claims[goal] = a.id
        a.goal, a.mode = goal, TRANSIT
        a.path = path if path is old_path else deque(path)
        a.path_known_at = self.belief.stamp
        if self.settings.far_transit_recheck:
            a.recheck_in = max(0, (len(path) - self.settings.far_transit_recheck) // 2)
        if goal != previous:  # a choice, not the target confirmed on the way to it
            kind = EventKind.SAFETY_NET if tier == _Tier.NET else EventKind.TARGET
            if tier == _Tier.NET:
                self.safety_net_fires += 1
            self._events.append(PlannerEvent(kind, a.id, self.belief.cell(goal)))
        return self._traffic.follow(a, goal)

    # -- the ranked search (the call the target search's rework changes) ----------

    def _others_pockets(self, a: AgentRecord, pool: Iterable[int] | None) -> np.ndarray:
        """The uncovered cells of the other agents' pockets (``pocket_claims``): none
        when off, or when the search is of a ``pool``."""
        pockets = self._pockets
        if pockets is None or pool is not None:
            return _NO_CELLS
        return pockets.held_by_others(a, self._claims)

    def _run(self, a: AgentRecord, request: SearchRequest, pockets: np.ndarray) -> Found | None:
        """The search's answer with the cells of ``pockets`` excluded."""
        if pockets.size:
            excluded = np.concatenate((np.asarray(request.excluded, dtype=np.int64), pockets))
            request = request._replace(excluded=excluded)
        return self._search.run(request, a.search_memory)

    def _move_cost(self, a: AgentRecord) -> float:
        return self._alive.move_cost(a)

    def _best_move_cost(self) -> float:
        return self._alive.best_move_cost()

    @property
    def _range_budget_pct(self) -> float:
        return self._alive.range_budget_pct

    def _nearest_affordable(
        self,
        a: AgentRecord,
        pool: Iterable[int] | None,
        hint: Hint | None = None,
        previous: int | None = None,
    ) -> tuple[int, Sequence[int]] | _Held | None:
        """The closest target of ``pool`` (None: every uncovered cell) that the agent
        can afford, preferring those no other working agent is closer to (they are
        likely to be swept by that agent). Claimed and out-of-range cells are not
        targets.

        With ``hold_radius``, when every candidate is nearer to another working
        agent, those within ``hold_radius`` cells of such an agent are left to it
        (it is about to sweep them: chasing them only walks beside it), and
        ``HELD`` says that all of them are, or (``rival_pace``) that the nearest
        candidate is one another agent would come within ``hold_radius`` of
        before this one got there. One compiled search ranks them all
        (or confirms ``hint``: the target on the way to, the way there, and
        when it was last known to be a shortest way).

        With ``regions``, the cells of the regions other agents own are left to
        them first (the agent was heading for ``previous``); only when no other
        candidate is affordable are they searched too. With ``pockets``, the
        other agents' pockets are left to them: no target outside them is
        ``HELD`` (``planner.pockets``).
        """
        spread = self.settings.spread
        hold = self.settings.hold_radius if spread else 0
        pace = self.settings.rival_pace if hold else 0.0
        # Positional: a keyword costs more than the field it names, once a decision.
        floor, best_cost = self.settings.reserve_pct - _EPS, self._best_move_cost()
        energy = Energy(a.battery_pct, self._move_cost(a), floor, best_cost, self._range_budget_pct)
        others = self._team.others(a.slot) if spread else _NOBODY
        heading = hint if pool is None else None
        claimed = list(self._claims)
        found = None
        pockets = self._others_pockets(a, pool)  # once: both searches leave them out
        if self._regions is not None:
            held = self._regions.held_by_others(a, self._claims, previous)
            if held.size:
                excluded = np.concatenate((np.array(claimed, dtype=np.int64), held))
                ask = SearchRequest(a.index, energy, others, hold, excluded, pool, heading, pace)
                found = self._run(a, ask, pockets)
        if found is None:
            request = SearchRequest(a.index, energy, others, hold, claimed, pool, heading, pace)
            found = self._run(a, request, pockets)
        if found is None:
            # What is left lies in the others' pockets: theirs to sweep, wait.
            return HELD if pockets.size else None
        level, goal, path = found
        if hold and level == _Rank.CONTESTED:
            return HELD
        return goal, path
