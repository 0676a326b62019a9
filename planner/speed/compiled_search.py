"""The target search with compiled kernels (``planner.target_search``'s rule).

The full search is ``search_kernels.ranked_search``; most decisions are answered
without it: on the way to a target by a confirmation (``_confirm``: a pass over
the few candidates that might come first, and a search bounded to the ways to
them), by a target carried on while nothing it rests on changed
(``SettledTarget``), or, when every candidate is left to other agents, by
``_all_left_to_others``. Each shortcut can be switched off
(``PlannerSettings.search_shortcuts``): the answers are the same.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np

from planner.belief import UNREACHED, MapBelief
from planner.grid import CellState
from planner.settings import SearchShortcuts
from planner.speed.bounds import (
    in_square,
    nearest_manhattan,
    none_between,
    rivals_listed,
    surely_affordable,
    way_at_least,
)
from planner.speed.kernel_args import Grid, Scratch
from planner.speed.landmarks import Landmarks
from planner.speed.memory import AgentMemory, HorizonMemo, WayMemo
from planner.speed.search_kernels import (
    SPARE_MARKS,
    path_search,
    ranked_search,
    uncontested_horizon,
    unwind,
)
from planner.speed.settled_target import SettledTarget, SettledTie
from planner.speed.walks import (
    AMONG_MARKS,
    first_among,
    none_uncontested,
)
from planner.target_search import (
    HELD_BACK,
    Energy,
    Found,
    SearchMemory,
    SearchRequest,
)
from planner.team import Team

_FREE = int(CellState.FREE)

ALL_SHORTCUTS = SearchShortcuts()


@dataclass
class SearchCounts:
    """How often the compiled search took each way to an answer (for the tests and
    the benches: the shortcuts must be taken to be worth their code)."""

    searches: int = 0  # full breadth-first searches (``ranked_search``)
    confirmed: int = 0  # answers of ``_confirm``
    carried: int = 0  # settled targets carried on
    way_listed: int = 0  # confirmations that passed over the way memo's cells


class CompiledSearch:
    """The target search with compiled kernels (``planner.target_search``): scratch
    arrays for ``ranked_search``, reused across calls on one belief."""

    #: Most candidates ``_confirm`` looks at one by one. On a long way in rooms
    #: the lower bounds leave hundreds, all farther than the target, and the
    #: bounded walks to them (``first_among``, mostly the search back) cost
    #: far less than the search of everything within the way's length (rooms
    #: 1000x1000 with 10 agents: 20 thousand such searches, 2.3 ms each, at 128).
    RIVALS = 1024
    #: Most candidates ``_all_left_to_others`` lists; it passes over every
    #: uncovered cell, and a longer list only makes it give up later.
    LEFT_TO_OTHERS = 128
    FEW = 512
    LIST_COST = 8

    def __init__(self, belief: MapBelief, shortcuts: SearchShortcuts = ALL_SHORTCUTS) -> None:
        size = len(belief.state)
        self.belief = belief
        self.shortcuts_taken = shortcuts
        self.counts = SearchCounts()
        self.seen = np.zeros(size, dtype=np.int32)
        self.parent = np.zeros(size, dtype=np.int32)
        self.queue = np.zeros(size, dtype=np.int32)
        self.stamp = 0
        self.state = np.frombuffer(belief.state, dtype=np.uint8)
        self.candidate = np.frombuffer(belief.uncovered_mask, dtype=np.uint8)
        self.uncovered_list = np.frombuffer(belief.uncovered_list, dtype=np.int64)
        self.shortcuts = np.frombuffer(belief.shortcuts, dtype=np.int64)
        self._kept = np.zeros(size, dtype=np.int64)
        self._way = np.zeros(size, dtype=np.int64)
        self._near = np.zeros(size, dtype=np.int64)
        #: Candidates that might outrank the target on the way (``_confirm``),
        #: with a place for the target.
        self._rivals = np.zeros(self.RIVALS + 1, dtype=np.int64)
        #: The candidates ``ranked_search``'s shortcuts look at one by one (at most its size).
        self._few = np.zeros(self.FEW, dtype=np.int64)
        self._no_near = np.zeros(0, dtype=np.int64)  # ``rivals_listed`` keeps none
        #: A second ``seen``, ``queue`` and ``parent``, for ``ranked_search``.
        self._spare = (
            np.zeros(size, dtype=np.int32),
            np.zeros(size, dtype=np.int32),
            np.zeros(size, dtype=np.int32),
        )
        self._pool_mask = np.zeros(size, dtype=np.uint8)
        self._blocked = np.zeros(size, dtype=np.uint8)
        self.home = np.frombuffer(belief.charger_dist, dtype=np.int32)
        #: Set by ``_confirm`` when no other candidate the agent could take lay
        #: within the way's length: any shortest way keeps the target (``SettledTarget``).
        self._alone = False
        self.landmarks = Landmarks(belief)
        #: The distances from the landmarks (``Landmarks.lands``), brought up to
        #: date at the start of each ``run`` and ``path``.
        self.lands = self.landmarks.lands
        #: The map as the kernels read it (``kernel_args.Grid``), with ``lands``.
        self.grid: Grid = (self.state, belief.stride, self.lands)
        self._scratch: Scratch = (self.seen, self.parent, self.queue)

    def update_lands(self) -> np.ndarray:
        """Bring the distances from the landmarks up to date (``lands``, ``grid``)."""
        self.lands = self.landmarks.update()
        self.grid = (self.state, self.belief.stride, self.lands)
        return self.lands

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

    def _unwind(self, start: int, goal: int) -> list[int]:
        length = unwind(self.parent, start, goal, self._way)
        return self._way[length - 1 :: -1].tolist()

    def _way_to(self, start: int, cell: int, way: Sequence[int]) -> Sequence[int]:
        """The way the last search left from ``start`` to ``cell``, or ``way`` itself
        when it ends there and is as long: the coordinator keeps the way it is on
        then (``Coordinator._take_target``), and a fresh list of a way of
        thousands of moves cost more than the check that found it."""
        if way and way[-1] == cell and unwind(self.parent, start, cell, self._way) == len(way):
            return way
        return self._unwind(start, cell)

    def _confirm(
        self,
        start: int,
        goal: int,
        way: Sequence[int],
        known_at: tuple[int, int] | None,
        listed: np.ndarray,
        margin: int,
        memo: HorizonMemo | None,
        energy: tuple[float, float, float, float, float],
        others: tuple[np.ndarray, np.ndarray],
        hold: int,
        claimed: np.ndarray,
        way_memo: WayMemo | None,
    ) -> Found | None:
        """What the search from ``start`` would return, found without it when the
        agent is on ``way`` to ``goal``; None when only the search can tell.
        ``claimed``: the cells masked out as claimed by others; ``way_memo``: the
        agent's candidates near its way, used and renewed here.

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
        candidate = self.candidate
        if candidate[goal] == 0:
            return None
        moves = len(way)
        battery, cost, floor, best_cost, budget = energy
        back = int(self.home[goal])
        if back >= UNREACHED or 2.0 * back * best_cost > budget:
            return None
        if battery - cost * (moves + back) < floor:
            return None  # perhaps a shorter way now: let the search tell
        stride = self.belief.stride
        rows, cols = others
        rivals = (rows, cols, hold)
        near = nearest_manhattan(rows, cols, goal // stride - 1, goal % stride - 1)
        if rows.size == 0 or near >= moves:
            rank, limit = 0, UNREACHED
        elif hold == 0:
            rank, limit = 2, 0
        elif near > hold:
            rank, limit = 1, hold + 1
        else:
            return None  # left to the agent beside it: the search looks for another
        if rank > 0:
            # No candidate may be uncontested, however far. The search's horizon
            # pass (which also renews the memo's shortlist) finds none in Manhattan
            # terms, or the search's own proof (``none_uncontested``) rules them out.
            horizon, kept = uncontested_horizon(
                candidate, listed, start, self.grid, rivals, margin, self._kept
            )
            if kept >= 0 and memo is not None:
                memo.remember(self._kept[:kept], self.belief)
            if horizon >= 0:
                self.stamp += 1
                aside = (self._few, self._spare, SPARE_MARKS * self.stamp)
                if not none_uncontested(self.grid, candidate, listed, start, rivals, energy, aside):
                    return None
        ask = (start, goal, moves, limit)
        found_in = self._rivals[:-1]
        # A listed cell costs about LIST_COST cells of the square around the start
        # read row by row (its row and column are worked out by division; the
        # square's few candidates are then passed over as a list).
        square = 2 * moves * moves
        if rank == 0 and listed.size * self.LIST_COST < square:
            # Cells off ``listed`` are surely contested: rank 0 needs only these.
            out = (found_in, self._no_near)
            count = rivals_listed(candidate, listed, ask, self.grid, rivals, energy, out)[0]
        else:
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
                    pool = self._near[: in_square(candidate, start, moves, stride, self._near)]
            room = self._no_near if way_memo is None else way_memo.room(pool.size)
            out = (found_in, room)
            count, kept = rivals_listed(candidate, pool, ask, self.grid, rivals, energy, out)
            if way_memo is not None:
                way_memo.keep(kept, start, goal, moves, self.belief, claimed)
        if count == self.RIVALS:
            return None  # too many to look at one by one: the search is as quick
        if self._still_shortest(start, goal, moves, known_at):
            if count == 0:
                self._alone = True
                return Found(rank, goal, way)
            # ``goal`` is as far as ``way``: only a rival nearer comes first, or one
            # as near whose way comes first in the search's order (left to the
            # search below). Bounded to the ways to the rivals alone, the search
            # leaves out the cells near the way to the target.
            found = self._first_among(
                start, self._rivals[:count], moves, rank, hold, others, energy
            )
            if found is None:
                self._alone = True
                return Found(rank, goal, way)
            if len(found[2]) < moves:
                return found
            # As far as the goal: the rivals after it come later still, so only
            # which of the two comes first is left to tell, by the ways to them alone.
            rival = found[1]
            tie = None if way_memo is None else way_memo.tie
            if tie is not None and self._tie_holds(start, goal, rival, moves, tie):
                return Found(rank, goal, way)
            self._rivals[:2] = rival, goal
            pair = self._rivals[:2]
            found = self._first_among(start, pair, moves, rank, hold, others, energy, way)
            if tie is not None:
                if found is not None and found[1] == goal:
                    tie.keep(self._way_cells(start, moves), rival, self.belief)
                else:
                    tie.forget()
            return found
        self._rivals[count] = goal
        return self._first_among(
            start, self._rivals[: count + 1], moves, rank, hold, others, energy, way
        )

    def _way_cells(self, start: int, moves: int, way: Sequence[int] | None = None) -> np.ndarray:
        """The start, then ``way`` (None: the search's first way, as ``_way_to``
        just unwound it), ``moves`` cells."""
        cells = np.empty(moves + 1, dtype=np.int64)
        cells[0] = start
        if way is None:
            cells[1:] = self._way[moves - 1 :: -1]
        else:
            cells[1:] = np.fromiter(way, dtype=np.int64, count=moves)
        return cells

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

    def _first_among(
        self,
        start: int,
        targets: np.ndarray,
        bound: int,
        rank: int,
        hold: int,
        others: tuple[np.ndarray, np.ndarray],
        energy: tuple[float, float, float, float, float],
        way: Sequence[int] = (),
    ) -> Found | None:
        """``first_among`` with this search's scratch arrays: (rank, cell, path),
        the path ``way`` when that is one as short (``_way_to``)."""
        rank, cell = self._first_reached(start, targets, bound, rank, hold, others, energy)
        return None if rank < 0 else Found(rank, cell, self._way_to(start, cell, way))

    def _first_reached(
        self,
        start: int,
        targets: np.ndarray,
        bound: int,
        rank: int,
        hold: int,
        others: tuple[np.ndarray, np.ndarray],
        energy: tuple[float, float, float, float, float],
    ) -> tuple[int, int]:
        """``first_among`` with this search's scratch arrays: (rank, cell), the way
        there left in ``parent``."""
        stamp = self.stamp + 1
        self.stamp += AMONG_MARKS
        walk = (start, bound, rank, stamp)
        rivals = (others[0], others[1], hold)
        return first_among(self.grid, self.candidate, targets, walk, rivals, energy, self._scratch)

    def _all_left_to_others(
        self,
        start: int,
        energy: tuple[float, float, float, float, float],
        others: tuple[np.ndarray, np.ndarray],
        hold: int,
    ) -> tuple[bool, Found | None]:
        """``(True, what the search returns)`` when every candidate is surely left
        to another agent (within ``hold`` of one, and nearer to it), else
        ``(False, None)``.

        Then the search, finding no better rank, covers the whole known map
        for a candidate the agent can afford (rank 2: the coordinator holds
        the agent back, so which one does not matter: ``HELD_BACK``). Here a
        pass over the uncovered cells rules out better ranks, a second one
        lists those the agent might afford; when a way through a landmark
        affords one (``surely_affordable``), that is the answer, else a
        search bounded to the ways to them finds one, or that there is none.
        With too many to list, only the search can tell.
        """
        candidate, full = self.candidate, self.uncovered_list[: self.belief.uncovered_count]
        found = self._rivals[: self.LEFT_TO_OTHERS]
        grid, rivals, out = self.grid, (others[0], others[1], hold), (found, self._no_near)
        better = (start, -1, UNREACHED, hold + 1)
        if rivals_listed(candidate, full, better, grid, rivals, energy, out)[0]:
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
        rank, _ = self._first_reached(
            start, targets, min(bound, UNREACHED), 2, hold, others, energy
        )
        return True, None if rank < 0 else HELD_BACK

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

    def memory(self, team: Team, slot: int) -> AgentMemory:
        return AgentMemory(HorizonMemo(team, slot), WayMemo(), SettledTarget())

    def run(self, request: SearchRequest, memory: SearchMemory | None = None) -> Found | None:
        """The answer of ``planner.target_search`` (``memory``: an ``AgentMemory``)."""
        taken = self.shortcuts_taken
        kept = memory if isinstance(memory, AgentMemory) and request.pool is None else None
        horizon = kept.horizon if kept is not None and taken.shortlist else None
        way = kept.way if kept is not None and taken.way_memo else None
        settled = kept.settled if kept is not None and taken.settled else None
        hint = request.hint if request.pool is None else None
        battery, cost, floor, best_cost, budget = request.energy
        found = self._run_all(
            request.start, battery, cost, floor, best_cost, budget, request.others,
            request.hold, request.excluded, request.pool, horizon, hint, way, settled,
        )  # fmt: skip
        return found

    def _run_all(
        self,
        start: int,
        battery: float,
        cost: float,
        floor: float,
        best_cost: float,
        budget: float,
        others: tuple[np.ndarray, np.ndarray],
        hold: int,
        excluded: Sequence[int],
        pool: Iterable[int] | None = None,
        memo: HorizonMemo | None = None,
        hint: tuple[int, Sequence[int], tuple[int, int] | None] | None = None,
        way_memo: WayMemo | None = None,
        settled: SettledTarget | None = None,
    ) -> Found | None:
        """The best target as ``(rank, cell, path)`` among ``pool`` (None: the
        uncovered cells), ranked against the ``others`` (rows, columns) agents;
        ``excluded`` cells (claimed by other agents) are not candidates.
        ``memo`` and ``way_memo``: the searching agent's, when ``pool`` is None
        (``way_memo`` serves the ``hint``). ``hint``: the
        target the agent was heading for, its way there and the
        ``MapBelief.stamp`` when that was last known to be a shortest way, if
        ever (``pool`` None only): when it is certain what the search would
        return, it is returned without one, with a shortest path there
        (perhaps not the one the search finds: the way, when it is as short).
        ``settled``: the agent's target as the last check proved it, carried
        along the ``hint`` while nothing it rests on changed, and renewed by
        each check (``pool`` None only).
        With ``hold`` > 0, rank 2 is always ``HELD_BACK``."""
        self.update_lands()
        energy = (battery, cost, floor, best_cost, budget)
        if settled is None or pool is not None or others[0].size:
            # Ranked against others: nothing is settled (``_carried`` would refuse it).
            if settled is not None and settled.goal >= 0:
                settled.forget()
            return self._run(start, energy, others, hold, excluded, pool, memo, hint, way_memo)
        if (
            hint is not None
            and settled.goal == hint[0]
            and self._carried(start, hint, energy, excluded, settled)
        ):
            self.counts.carried += 1
            return Found(0, hint[0], hint[1])
        found = self._run(start, energy, others, hold, excluded, pool, memo, hint, way_memo)
        self._settle(settled, start, found, energy, excluded)
        return found

    def _run(
        self,
        start: int,
        energy: tuple[float, float, float, float, float],
        others: tuple[np.ndarray, np.ndarray],
        hold: int,
        excluded: Sequence[int],
        pool: Iterable[int] | None,
        memo: HorizonMemo | None,
        hint: tuple[int, Sequence[int], tuple[int, int] | None] | None,
        way_memo: WayMemo | None,
    ) -> Found | None:
        """``run`` without the settled target."""
        self._alone = False
        margin = -1
        if pool is None:
            mask = self.candidate
            listed = memo.shortlist(self.belief) if memo is not None else None
            if listed is None:
                listed = self.uncovered_list[: self.belief.uncovered_count]
                margin = HorizonMemo.MARGIN if memo is not None else -1
        else:
            mask = self._pool_mask
            pool = list(pool)
            mask[pool] = 1
            listed = np.array(pool, dtype=np.int64)
        claimed = np.array(excluded, dtype=np.int64)
        saved = mask[claimed]
        mask[claimed] = 0
        # The shortcuts read the uncovered cells' mask (``self.candidate``) with
        # the claimed cells masked out, as the search does.
        try:
            if hint is not None and pool is None and self.shortcuts_taken.confirm:
                goal, way, known_at = hint
                sure = self._confirm(
                    start, goal, way, known_at, listed, margin, memo, energy, others, hold,
                    claimed, way_memo,
                )  # fmt: skip
                if sure is not None:
                    self.counts.confirmed += 1
                    return sure
                if margin >= 0 and memo is not None:
                    renewed = memo.shortlist(self.belief)  # by the confirmation
                    if renewed is not None:
                        listed, margin = renewed, -1
            if pool is None and hold > 0 and others[0].size and self.shortcuts_taken.left_to_others:
                known, found = self._all_left_to_others(start, energy, others, hold)
                if known:
                    return found
            self.stamp += 1
            self.counts.searches += 1
            everyone = (
                self.uncovered_list[: self.belief.uncovered_count] if pool is None else listed
            )
            rank, cell, kept = ranked_search(
                self.grid,
                (mask, listed, everyone),
                start,
                energy,
                (others[0], others[1], hold),
                self._scratch,
                self.stamp,
                (margin, self._kept, self._few, self._spare),
            )
        finally:
            mask[claimed] = saved
            if pool is not None:
                mask[pool] = 0
        if kept >= 0 and memo is not None:
            memo.remember(self._kept[:kept], self.belief)
        if rank < 0:
            return None
        if rank == HELD_BACK[0] and hold > 0:
            return HELD_BACK
        return Found(rank, cell, self._way_to(start, cell, hint[1] if hint is not None else ()))

    def _carried(
        self,
        start: int,
        hint: tuple[int, Sequence[int], tuple[int, int] | None],
        energy: tuple[float, float, float, float, float],
        excluded: Sequence[int],
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
        energy: tuple[float, float, float, float, float],
        excluded: Sequence[int],
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
