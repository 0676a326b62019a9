"""Answers of the compiled target search found without its full search: on the way
to a target (``_confirm``), and when every candidate is left to other agents
(``_all_left_to_others``)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from planner.belief import UNREACHED
from planner.speed.bounds import (
    in_square,
    nearest_manhattan,
    none_between,
    rivals_listed,
    surely_affordable,
)
from planner.speed.kernel_args import EnergyTerms, Rivals
from planner.speed.memory import HorizonMemo, WayMemo
from planner.speed.search_kernels import (
    SPARE_MARKS,
    uncontested_horizon,
)
from planner.speed.search_scratch import SearchScratch
from planner.speed.settled_target import SettledTie
from planner.speed.still_field import HELD, SEARCH, StillField, all_held
from planner.speed.walks import (
    none_uncontested,
)
from planner.target_search import (
    HELD_BACK,
    Found,
    Hint,
)

#: The cells the horizon pass reads, its margin (-1: keep nothing) and the agent's memo.
Shortlist = tuple[np.ndarray, int, HorizonMemo | None]


class Confirmations(SearchScratch):
    """The confirmations of ``CompiledSearch``, over its scratch arrays."""

    def _confirm(
        self,
        start: int,
        hint: Hint,
        shortlist: Shortlist,
        energy: EnergyTerms,
        rivals: Rivals,
        kept_along: tuple[np.ndarray, WayMemo | None],
    ) -> Found | None:
        """What the search from ``start`` would return, found without it when the
        agent is on the ``hint``'s way to its goal; None when only the search can
        tell. ``shortlist``: the cells the horizon pass reads, its margin and the
        agent's ``HorizonMemo``; ``kept_along``: the cells masked out as claimed by
        others, and the agent's candidates near its way (``WayMemo``), used and
        renewed here.

        The search returns the first uncontested candidate it reaches (rank 0)
        or, when there is none, the first of the next rank. ``goal`` ranks so
        at the end of ``way``, so the search returns it or a candidate it
        reaches no later. One pass over the uncovered cells within the way's
        length finds the few that might (``rivals_listed``); when ``goal`` is
        contested, none anywhere may be uncontested (the horizon pass). Then
        a search bounded to the ways to those few (``first_among``) finds
        what the search over the map around the agent out to the target
        would, as it would at every step of a long transit. With no rival,
        ``way`` is the answer as it stands if it is still a shortest way
        (``_still_shortest``).
        """
        goal, way, known_at = hint
        moves = len(way)
        ranked = self._rank_at_end(goal, moves, energy, rivals)
        if ranked is None:
            return None
        rank, limit = ranked
        if rank > 0 and not self._none_uncontested(start, shortlist, energy, rivals):
            return None
        ask = (start, goal, moves, limit)
        count = self._rivals_near(ask, shortlist[0], rank == 0, energy, rivals, kept_along)
        if count == self.rivals_most:
            return None  # too many to look at one by one: the search is as quick
        if self._still_shortest(start, goal, moves, known_at):
            way_memo = kept_along[1]
            tie = None if way_memo is None else way_memo.tie
            return self._first_on_way(start, goal, way, count, rank, rivals, energy, tie)
        self._rivals[count] = goal
        return self._first_among(start, self._rivals[: count + 1], moves, rank, rivals, energy, way)

    def _rank_at_end(
        self,
        goal: int,
        moves: int,
        energy: EnergyTerms,
        rivals: Rivals,
    ) -> tuple[int, int] | None:
        """``goal``'s rank ``moves`` away, and the ``limit`` of the rivals that may
        outrank it (``rivals_listed``); None when only the search can tell."""
        if self.candidate[goal] == 0:
            return None
        battery, cost, floor, best_cost, budget = energy
        back = int(self.home[goal])
        if back >= UNREACHED or 2.0 * back * best_cost > budget:
            return None
        if battery - cost * (moves + back) < floor:
            return None  # perhaps a shorter way now: let the search tell
        stride = self.belief.stride
        rows, cols, hold = rivals
        near = nearest_manhattan(rows, cols, goal // stride - 1, goal % stride - 1)
        if rows.size == 0 or near >= moves:
            return 0, UNREACHED
        if hold == 0:
            return 2, 0
        if near > hold:
            return 1, hold + 1
        return None  # left to the agent beside it: the search looks for another

    def _none_uncontested(
        self,
        start: int,
        shortlist: Shortlist,
        energy: EnergyTerms,
        rivals: Rivals,
    ) -> bool:
        """Is no candidate uncontested, however far? The search's horizon pass
        (which also renews the memo's shortlist) finds none in Manhattan terms, or
        the search's own proof (``none_uncontested``) rules them out."""
        listed, margin, memo = shortlist
        candidate = self.candidate
        horizon, kept = uncontested_horizon(
            candidate, listed, start, self.grid, rivals, margin, self._kept
        )
        if kept >= 0 and memo is not None:
            memo.remember(self._kept[:kept], self.belief)
        if horizon < 0:
            return True
        self.stamp += 1
        aside = (self._few, self._spare, SPARE_MARKS * self.stamp)
        return bool(none_uncontested(self.grid, candidate, listed, start, rivals, energy, aside))

    def _rivals_near(
        self,
        ask: tuple[int, int, int, int],
        listed: np.ndarray,
        uncontested: bool,
        energy: EnergyTerms,
        rivals: Rivals,
        kept_along: tuple[np.ndarray, WayMemo | None],
    ) -> int:
        """How many candidates might come before the goal (``rivals_listed``), put
        in ``_rivals``; ``rivals_most`` when there are too many. ``kept_along``: the
        cells claimed now and the agent's ``WayMemo`` (read and renewed)."""
        start, goal, moves, _ = ask
        candidate, found_in = self.candidate, self._rivals[:-1]
        # A listed cell costs about LIST_COST cells of the square around the start
        # read row by row (its row and column are worked out by division; the
        # square's few candidates are then passed over as a list).
        square = 2 * moves * moves
        if uncontested and listed.size * self.LIST_COST < square:
            # Cells off ``listed`` are surely contested: rank 0 needs only these.
            out = (found_in, self._no_near)
            return int(rivals_listed(candidate, listed, ask, self.grid, rivals, energy, out)[0])
        claimed, way_memo = kept_along
        # The memo's cells, unless the uncovered cells or the square are fewer.
        most = min(self.belief.uncovered_count, square // self.LIST_COST)
        pool = None
        if way_memo is not None:
            pool = way_memo.listed(start, goal, moves, self.belief, most)
            self.counts.way_listed += pool is not None
        if pool is None:
            if self.belief.uncovered_count * self.LIST_COST < square:
                pool = self.uncovered_list[: self.belief.uncovered_count]
            else:
                stride = self.belief.stride
                pool = self._near[: in_square(candidate, start, moves, stride, self._near)]
        room = self._no_near if way_memo is None else way_memo.room(pool.size)
        out = (found_in, room)
        count, kept = rivals_listed(candidate, pool, ask, self.grid, rivals, energy, out)
        if way_memo is not None:
            way_memo.keep(kept, start, goal, moves, self.belief, claimed)
        return int(count)

    def _first_on_way(
        self,
        start: int,
        goal: int,
        way: Sequence[int],
        count: int,
        rank: int,
        rivals: Rivals,
        energy: EnergyTerms,
        tie: SettledTie | None,
    ) -> Found | None:
        """The answer when ``way`` is still a shortest way to ``goal`` and ``count``
        rivals (in ``_rivals``) might come first."""
        moves = len(way)
        if count == 0:
            self._alone = True
            return Found(rank, goal, way)
        # ``goal`` is as far as ``way``: only a rival nearer comes first, or one
        # as near whose way comes first in the search's order (left to the
        # search below). Bounded to the ways to the rivals alone, the search
        # leaves out the cells near the way to the target.
        found = self._first_among(start, self._rivals[:count], moves, rank, rivals, energy)
        if found is None:
            self._alone = True
            return Found(rank, goal, way)
        if len(found[2]) < moves:
            return found
        # As far as the goal: the rivals after it come later still, so only
        # which of the two comes first is left to tell, by the ways to them alone.
        rival = found[1]
        if tie is not None and self._tie_holds(start, goal, rival, moves, tie):
            return Found(rank, goal, way)
        self._rivals[:2] = rival, goal
        pair = self._rivals[:2]
        found = self._first_among(start, pair, moves, rank, rivals, energy, way)
        if tie is not None:
            if found is not None and found[1] == goal:
                tie.keep(self._way_cells(start, moves), rival, self.belief)
            else:
                tie.forget()
        return found

    def _tie_holds(self, start: int, goal: int, rival: int, moves: int, tie: SettledTie) -> bool:
        """Does ``goal`` still come before ``rival``, as far, as ``tie`` proves (see
        ``planner.speed.settled_target``)? Carries it on if so."""
        if tie.rival != rival:
            return False
        at = tie.where(start, goal)
        belief = self.belief
        if (
            at < 0
            or tie.cells.size - 1 - at != moves
            or tie.blocked != belief.blocked_count
            or not tie.none_found_within(belief, start, moves, self.lands)
        ):
            return False
        tie.carry(at, belief)
        return True

    def _all_left_to_others(
        self,
        start: int,
        energy: EnergyTerms,
        rivals: Rivals,
        pace: float,
        still: StillField | None,
    ) -> tuple[bool, Found | None]:
        """``(True, what the search returns)`` when every candidate is surely left
        to another agent (within ``hold`` of one, and nearer to it; or, with a
        rival ``pace``, nearer to it and one it would come within ``hold`` of
        before this agent got there, however long the way: ``rival_first``),
        else ``(False, None)``.

        Then the search, finding no better rank, covers the whole known map
        for a candidate the agent can afford (rank 2: the coordinator holds
        the agent back, so which one does not matter: ``HELD_BACK``). Here a
        pass over the uncovered cells rules out better ranks, a second one
        lists those the agent might afford; when a way through a landmark
        affords one (``surely_affordable``), that is the answer, else a
        search bounded to the ways to them finds one, or that there is none.
        A held agent searching again from where it stands (``still``) is told
        by one pass over the candidates at their exact distances instead,
        which tells all the bounds tell, and more.
        """
        candidate, full = self.candidate, self.uncovered_list[: self.belief.uncovered_count]
        dist = self._still_distances(start, still)
        if dist is not None:
            verdict = all_held(candidate, full, dist, self.grid, rivals, energy, pace)
            if verdict == SEARCH:
                return False, None
            self.counts.held_still += 1
            return True, HELD_BACK if verdict == HELD else None
        found = self._rivals[: self.LEFT_TO_OTHERS]
        grid, hold, out = self.grid, rivals[2], (found, self._no_near)
        better = (start, -1, UNREACHED, hold + 1)
        if rivals_listed(candidate, full, better, grid, rivals, energy, out, pace)[0]:
            return False, None  # some may rank better
        left = (start, -1, UNREACHED, 0)
        count = rivals_listed(candidate, full, left, grid, rivals, energy, out)[0]
        if count == self.LEFT_TO_OTHERS:
            return False, None
        targets = found[:count]
        if count == 0:
            return True, None
        if surely_affordable(targets, start, self.lands, energy):
            return True, HELD_BACK
        battery, cost, floor, _, _ = energy
        bound = UNREACHED
        if cost > 0:  # the farthest any of them can be afforded, and a move to spare
            bound = int((battery - floor) / cost) - int(self.home[targets].min()) + 1
        rank, _ = self._first_reached(start, targets, min(bound, UNREACHED), 2, rivals, energy)
        return True, None if rank < 0 else HELD_BACK

    def _still_distances(self, start: int, still: StillField | None) -> np.ndarray | None:
        """The exact distances from ``start`` when the agent searched from there
        last time too (``StillField``), on a map whose ways are long beside the
        Manhattan distance (where landmarks are kept): elsewhere the bounds tell
        nearly as much, and the distances from a new cell, a search of the known
        map, cost more than they spare. Else None."""
        if still is None or len(self.landmarks.cells) == 1:
            return None
        return still.distances(self.belief, start, self.queue)

    def _still_shortest(
        self, start: int, goal: int, moves: int, known_at: tuple[int, int] | None
    ) -> bool:
        """Is there surely no way from ``start`` to ``goal`` shorter than ``moves``?

        So when ``moves`` is the Manhattan distance. So too when a way that
        long was a shortest way at ``known_at`` (``MapBelief.stamp``, and the
        agent has kept to it since), no cell was blocked since, and none of
        the cells that may have shortened a way since (``MapBelief.shortcuts``:
        every other new cell leaves the distances between the cells known
        before as they were) lies where a shorter way could pass: by the
        bounds of ``rivals_listed`` (in rooms, many such cells lie within the
        Manhattan bound of a way round a wall, but their distances from the
        landmarks, as known now, tell that they are too far from one end or the other).
        """
        stride = self.belief.stride
        r0, c0, r1, c1 = start // stride, start % stride, goal // stride, goal % stride
        if moves == abs(r0 - r1) + abs(c0 - c1):
            return True
        if known_at is None:
            return False
        since, blocked = known_at
        belief = self.belief
        if blocked != belief.blocked_count:
            return False
        new = self.shortcuts[since : belief.shortcut_count]
        return none_between(new, start, goal, moves, stride, self.lands)
