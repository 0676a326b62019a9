"""The target search with compiled kernels (``planner.target_search``'s rule).

The full search is ``search_kernels.ranked_search``; most decisions are answered
without it: on the way to a target by a confirmation (``_confirm``: a pass over
the few candidates that might come first, and a search bounded to the ways to
them), by a target carried on while nothing it rests on changed
(``SettledTarget``), or, when every candidate is left to other agents, by
``_all_left_to_others`` (for an agent held back, with its distances from where it
stands: ``StillField``). Each shortcut can be switched off
(``PlannerSettings.search_shortcuts``): the answers are the same.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

import numpy as np

from planner.belief import MapBelief
from planner.settings import SearchShortcuts
from planner.speed.bounds import (
    nearest_manhattan,
    way_at_least,
)
from planner.speed.confirmation import Confirmations
from planner.speed.kernel_args import EnergyTerms, Pool, Rivals
from planner.speed.memory import AgentMemory, HorizonMemo, WayMemo
from planner.speed.search_kernels import (
    path_search,
    ranked_search,
)
from planner.speed.search_scratch import SearchCounts
from planner.speed.settled_target import SettledTarget
from planner.speed.still_field import StillField
from planner.target_search import (
    HELD_BACK,
    Energy,
    Found,
    SearchMemory,
    SearchRequest,
    rival_first,
)
from planner.team import Team

ALL_SHORTCUTS = SearchShortcuts()

__all__ = ["ALL_SHORTCUTS", "AgentMemory", "CompiledSearch", "SearchCounts", "warm_up"]


class CompiledSearch(Confirmations):
    """The target search with compiled kernels (``planner.target_search``)."""

    def __init__(self, belief: MapBelief, shortcuts: SearchShortcuts = ALL_SHORTCUTS) -> None:
        super().__init__(belief)
        self.shortcuts_taken = shortcuts

    def path(
        self, start: int, goal: int, blocked: Iterable[int] = (), longest: int | None = None
    ) -> list[int] | None:
        """The shortest path from ``start`` to ``goal`` over known free cells, not
        entering ``blocked`` cells: the start excluded, the goal included. None
        if there is none, or none of at most ``longest`` moves."""
        if start == goal:
            return []
        stride = self.belief.stride
        self.update_lands()
        shortest = int(way_at_least(start, goal, stride, self.lands))
        if longest is not None and longest < shortest:
            return None  # surely none (a bound under 1 would also read as found)
        marked = list(blocked)
        self._blocked[marked] = 1
        bound, slack = (shortest, 1) if longest is None else (longest, 0)
        try:
            while True:
                # Widen the bound until the goal is in: the slack doubles, so the
                # searches that fall short cost no more than the last one.
                self.stamp += 1
                found = path_search(
                    self.grid, self._blocked, start, goal, bound, self._scratch, self.stamp
                )
                if found <= 1 or longest is not None:
                    break
                slack = max(2 * slack, found - shortest)
                bound = shortest + slack
        finally:
            self._blocked[marked] = 0
        return self._unwind(start, goal) if found == 1 else None

    def memory(self, team: Team, slot: int) -> AgentMemory:
        return AgentMemory(HorizonMemo(team, slot), WayMemo(), SettledTarget(), StillField())

    def run(self, request: SearchRequest, memory: SearchMemory | None = None) -> Found | None:
        """The answer of ``planner.target_search`` (``memory``: an ``AgentMemory``,
        read and renewed when ``request.pool`` is None).

        When it is certain what the search would return, that is returned
        without one: on the way to the ``hint``'s target (``_confirm``, with
        a shortest path there, perhaps the hint's way rather than the one the
        search finds), or as the settled target carried along the hint's way
        while nothing it rests on changed (``SettledTarget``, while no other
        agent works). With ``hold`` > 0, rank 2 is always ``HELD_BACK``, and so is a
        rank 1 answer that ``rival_first`` holds back."""
        taken = self.shortcuts_taken
        kept = memory if isinstance(memory, AgentMemory) and request.pool is None else None
        horizon = kept.horizon if kept is not None and taken.shortlist else None
        way_memo = kept.way if kept is not None and taken.way_memo else None
        settled = kept.settled if kept is not None and taken.settled else None
        still = kept.still if kept is not None and taken.still_field else None
        used = (horizon, way_memo, still)
        self.update_lands()
        energy = (*request.energy,)  # a plain tuple: numba types it from its C fast path
        start, hint, excluded = request.start, request.hint, request.excluded
        if settled is None or request.pool is not None or request.others[0].size:
            # Ranked against others: nothing is settled (``_carried`` would refuse it).
            if settled is not None and settled.goal >= 0:
                settled.forget()
            found = self._search(request, energy, used)
            if found is None:
                return None
            if rival_first(request, found, self.belief.cell(found.cell), nearest_manhattan):
                return HELD_BACK
            return found
        on_way = hint is not None and settled.goal == hint.goal
        if on_way and hint is not None and self._carried(start, hint, energy, excluded, settled):
            self.counts.carried += 1
            return Found(0, hint.goal, hint.way)
        found = self._search(request, energy, used)
        self._settle(settled, start, found, energy, excluded)
        return found

    def _search(
        self,
        request: SearchRequest,
        energy: EnergyTerms,
        used: tuple[HorizonMemo | None, WayMemo | None, StillField | None],
    ) -> Found | None:
        """``run`` without the settled target: ``used``, the agent's memos in use."""
        self._alone = False
        memo, way_memo, still = used
        start, others, hold, pool = request.start, request.others, request.hold, request.pool
        rivals = (others[0], others[1], hold)
        hint = request.hint if pool is None else None
        mask, listed, margin, cells = self._candidates(pool, memo)
        claimed = np.array(request.excluded, dtype=np.int64)
        saved = mask[claimed]
        mask[claimed] = 0
        # The shortcuts read the uncovered cells' mask (``self.candidate``) with
        # the claimed cells masked out, as the search does.
        try:
            if hint is not None and self.shortcuts_taken.confirm:
                shortlist = (listed, margin, memo)
                sure = self._confirm(start, hint, shortlist, energy, rivals, (claimed, way_memo))
                if sure is not None:
                    self.counts.confirmed += 1
                    return sure
                if margin >= 0 and memo is not None:
                    renewed = memo.shortlist(self.belief)  # by the confirmation
                    if renewed is not None:
                        listed, margin = renewed, -1
            if pool is None and hold > 0 and others[0].size and self.shortcuts_taken.left_to_others:
                pace = request.rival_pace
                known, found = self._all_left_to_others(start, energy, rivals, pace, still)
                if known:
                    return found
            rank, cell, kept = self._ranked(start, energy, rivals, (mask, listed, cells), margin)
        finally:
            mask[claimed] = saved
            if pool is not None:
                mask[cells] = 0
        if kept >= 0 and memo is not None:
            memo.remember(self._kept[:kept], self.belief)
        if rank < 0:
            return None
        if rank == HELD_BACK[0] and hold > 0:
            return HELD_BACK
        return Found(rank, cell, self._way_to(start, cell, hint[1] if hint is not None else ()))

    def _candidates(
        self, pool: Iterable[int] | None, memo: HorizonMemo | None
    ) -> tuple[np.ndarray, np.ndarray, int, np.ndarray]:
        """The candidates' mask, the cells the horizon pass reads (the memo's
        shortlist, if it has one), its margin (-1: keep nothing), and every
        candidate. ``pool`` (None: every uncovered cell) is marked in the pool's
        mask, to be unmarked after the search."""
        uncovered = self.uncovered_list[: self.belief.uncovered_count]
        if pool is None:
            listed = memo.shortlist(self.belief) if memo is not None else None
            if listed is not None:
                return self.candidate, listed, -1, uncovered
            margin = memo.MARGIN if memo is not None else -1
            return self.candidate, uncovered, margin, uncovered
        cells = np.array(list(pool), dtype=np.int64)
        self._pool_mask[cells] = 1
        return self._pool_mask, cells, -1, cells

    def _ranked(
        self,
        start: int,
        energy: EnergyTerms,
        rivals: Rivals,
        pool: Pool,
        margin: int,
    ) -> tuple[int, int, int]:
        """The full search (``ranked_search``): (rank, cell, cells kept)."""
        self.stamp += 1
        self.counts.searches += 1
        return ranked_search(  # type: ignore[no-any-return]
            self.grid,
            pool,
            start,
            energy,
            rivals,
            self._scratch,
            self.stamp,
            (margin, self._kept, self._few, self._spare),
        )

    def _carried(
        self,
        start: int,
        hint: tuple[int, Sequence[int], tuple[int, int] | None],
        energy: EnergyTerms,
        excluded: Sequence[int] | np.ndarray,
        settled: SettledTarget,
    ) -> bool:
        """Is the hint's target, by the hint's way, what the search would return,
        as ``settled`` proves (see ``planner.speed.settled_target``)? Carries it on if so."""
        goal, way, _ = hint
        battery, cost, floor = energy[0], energy[1], energy[2]
        at = settled.step(start, goal, battery, cost)
        if at < 0:
            return False
        moves = settled.cells.size - 1 - at
        belief = self.belief
        if (
            len(way) != moves
            or settled.stamp != belief.stamp
            or settled.terms != energy[1:]
            or not self.candidate[goal]
            or goal in excluded
            or battery - cost * (moves + int(self.home[goal])) < floor
            or not settled.none_found_within(belief, start, moves, self.lands)
        ):
            return False
        claimed = settled.claimed
        if claimed.size:
            released = claimed[self.candidate[claimed] != 0]
            if released.size and not np.isin(released, excluded).all():
                return False
        settled.carry_on(at, battery, belief)
        return True

    def _settle(
        self,
        settled: SettledTarget,
        start: int,
        found: Found | None,
        energy: EnergyTerms,
        excluded: Sequence[int] | np.ndarray,
    ) -> None:
        """Keep what the check just proved (while no other agent works)."""
        if settled.goal >= 0:
            settled.forget()
        if found is None or found[0] != 0 or not found[2]:
            return
        path = found[2]
        # Any shortest way keeps a target no other candidate was as near as
        # (``_alone``); else only the search's first way does.
        cells = self._way_cells(start, len(path), path if self._alone else None)
        settled.keep(cells, energy[0], energy[1:], self.belief, np.array(excluded, np.int64))


def warm_up() -> None:
    """Compile this module's kernels (or load them from numba's cache) now, not in
    the first decision: a program calls it before it times or flies anything."""
    belief = MapBelief((1, 2), (0, 0))
    belief.mark_free(belief.index((0, 1)))
    search = CompiledSearch(belief)
    nobody = np.zeros(0, dtype=np.int64)
    energy = Energy(100.0, 0.0, 0.0, 0.0, 100.0)
    search.run(SearchRequest(belief.index((0, 0)), energy, (nobody, nobody), 0))
    nearest_manhattan(nobody, nobody, 0, 0)
    search.path(belief.index((0, 0)), belief.index((0, 1)))
