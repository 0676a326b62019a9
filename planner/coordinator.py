"""Multi-agent exploration and coverage with the staying alive policy (paper, Algorithm 4).

The coordinator owns the shared map belief, the BTP stacks and every agent's
plan. It is driven from outside, one agent at a time, which serves both the
lockstep simulation (``gcs plan``: every agent decides once per iteration)
and a live mission (each vehicle asks for its next move when it has arrived):

* ``observe(agent, cell, readings, battery_pct)`` after the agent arrived
  somewhere and sensed its 8 neighbours;
* ``decide(agent) -> Action``: move to a neighbour cell, wait, or charge.

A move reserves the target cell at once, so that no two agents ever head for
the same cell and no two agents swap cells. The charging station is a depot
with room for the whole fleet: agents standing on it occupy nothing.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Collection, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field, replace
from enum import IntEnum, StrEnum
from typing import Final

import numpy as np
from scipy import ndimage

from planner import btp
from planner.belief import UNREACHED, MapBelief, with_unknown_side
from planner.grid import MOVES, Cell, CellState, Direction, manhattan
from planner.paths import path_to_charger, path_to_known
from planner.prm import Roadmap
from planner.settings import (
    AgentSpec,
    BmRule,
    PathPlannerKind,
    PlannerSettings,
    TargetPolicy,
)
from planner.speed.bounds import nearest_manhattan
from planner.target_search import Energy, Hint, SearchMemory, SearchRequest, target_search
from planner.team import Team

_FREE = int(CellState.FREE)
_OBSTACLE = int(CellState.OBSTACLE)
_EPS = 1e-9


class AgentMode(StrEnum):
    EXPLORE = "exploring"  # boustrophedon motion
    TRANSIT = "transit"  # on the way to a BTP
    RETURN = "returning"  # on the way to charge (staying alive policy)
    CHARGE = "charging"
    IDLE = "idle"  # nothing to take: waits for a BTP
    HOMING = "homing"  # coverage complete: back to the charger
    DONE = "done"
    LOST = "lost"


class ActionKind(StrEnum):
    MOVE = "move"
    WAIT = "wait"
    CHARGE = "charge"


class Action:
    """What an agent does next; ``to`` is the cell of a move.

    A value, but not a frozen dataclass: compiled, this class builds one in a
    fifth of the time, and ``decide`` builds one per move. Its fields are
    ``Final``: mypy keeps them read only, and the compiled class refuses writes.
    """

    __slots__ = ("kind", "to")

    def __init__(self, kind: ActionKind, to: Cell | None = None) -> None:
        self.kind: Final = kind
        self.to: Final = to

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Action) and (self.kind, self.to) == (other.kind, other.to)

    def __hash__(self) -> int:
        return hash((self.kind, self.to))

    def __repr__(self) -> str:
        return f"Action({self.kind!s}, {self.to})"


WAIT = Action(ActionKind.WAIT)
CHARGE = Action(ActionKind.CHARGE)


class EventKind(StrEnum):
    BTP_DETECTED = "btp_detected"
    BTP_COVERED = "btp_covered"
    TARGET = "target"  # a blocked agent took a BTP
    SAFETY_NET = "safety_net"  # no BTP left: took a frontier cell
    RETURN = "return_to_charge"
    CHARGED = "charged"
    OUT_OF_RANGE = "out_of_range"
    COVERAGE_COMPLETE = "coverage_complete"
    #: Nothing left in reach, but only because lost vehicles stand in the way: what
    #: lies beyond them is cut off, not covered (the event's cell: one of them).
    CUT_OFF = "cut_off"
    LOST = "lost"


@dataclass(frozen=True)
class PlannerEvent:
    kind: EventKind
    agent: int
    cell: Cell | None = None


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


class _Held:
    """Every target is being swept by a nearer agent: wait."""


HELD = _Held()
_NOBODY = (np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64))

_PRIORITY = {AgentMode.RETURN: 3, AgentMode.HOMING: 2, AgentMode.TRANSIT: 1}


#: The modes and the move kind, for the decisions: in Python 3.11 every look-up of
#: an enum member on its class (``AgentMode.EXPLORE``) goes through
#: ``EnumType.__getattr__``, about 80 ns, and each decision makes dozens.
_EXPLORE, _TRANSIT, _RETURN = AgentMode.EXPLORE, AgentMode.TRANSIT, AgentMode.RETURN
_CHARGE, _IDLE, _HOMING = AgentMode.CHARGE, AgentMode.IDLE, AgentMode.HOMING
_DONE, _LOST = AgentMode.DONE, AgentMode.LOST
_MOVE = ActionKind.MOVE
_STOPPED = frozenset({_DONE, _LOST})
_AT_REST = frozenset({_DONE, _HOMING})  # nothing left to do, unless coverage is incomplete

_WORKING = frozenset({_EXPLORE, _TRANSIT})
_HOMEWARD = frozenset({_RETURN, _HOMING})
#: An agent going home held up this many times ``patience`` is given the cell it
#: waits for (``_kept_waiting_for``), and the agent it asks to make way goes home
#: with it (``_make_way``): late enough to leave ordinary crossings to the order
#: of decisions, as before, and to settle a jam.
_GIVEN_WAY_AFTER = 8


@dataclass
class _Agent:
    spec: AgentSpec
    index: int
    team: Team
    slot: int
    #: What the target search keeps of the agent (``TargetSearch.memory``).
    search_memory: SearchMemory
    battery_pct: float = 100.0
    _mode: AgentMode = _EXPLORE
    path: deque[int] = field(default_factory=deque)  # remaining moves, next first
    goal: int | None = None
    heading: Direction | None = None
    pending: int | None = None  # reserved target of the move under way
    trailing: int | None = None  # the cell just left, held until the next decision
    charges: int = 0
    #: Covered a cell since it last charged (``top_up_ratio`` needs it).
    swept: bool = False
    waited: int = 0
    make_way_for: int | None = None
    #: After stepping aside: (agent let through, cell given up, decisions left to wait).
    letting_pass: tuple[int, int, int] | None = None
    #: The target of the transit being re-decided (``replan_transit``).
    was_heading_for: int | None = None
    #: Transit moves left before the target is searched for again (``replan_transit``).
    recheck_in: int = 0
    #: ``MapBelief.stamp`` when ``path`` was last known to be a shortest path.
    path_known_at: tuple[int, int] | None = None
    held_for: int = 0  # decisions to wait before searching for a target again
    held_backoff: int = 0
    #: Asked to make way by an agent that is itself making way (see ``_make_way``).
    pushed: bool = False
    #: ``mode in _WORKING``, as last written to ``team.working`` (which starts all True).
    _working: bool = True
    id: int = field(init=False)

    def __post_init__(self) -> None:
        self.id = self.spec.id

    @property
    def mode(self) -> AgentMode:
        return self._mode

    @mode.setter
    def mode(self, mode: AgentMode) -> None:
        self._mode = mode
        working = mode in _WORKING
        if working != self._working:  # a write to the array costs more than the test
            self._working = working
            self.team.working[self.slot] = working

    def begin_charge(self) -> None:
        self.charges += 1
        self.swept = False

    def stand(self, index: int, cell: Cell) -> None:
        self.index = index
        self.team.rows[self.slot], self.team.cols[self.slot] = cell


class Coordinator:
    def __init__(
        self,
        shape: tuple[int, int],
        charger: Cell,
        agents: Sequence[AgentSpec],
        settings: PlannerSettings | None = None,
        prior: np.ndarray | None = None,
    ) -> None:
        """``prior``: a known map (``CellState`` values, UNKNOWN where not known) for
        agents that are given the map instead of sensing it."""
        self.settings = settings or PlannerSettings()
        ids = [a.id for a in agents]
        if len(set(ids)) != len(ids):
            raise ValueError("agent ids must be unique")
        self.belief = MapBelief(shape, charger)
        if prior is not None:
            self._load_prior(prior)
        self.stacks = btp.BtpStacks()
        self._team = Team(len(agents), charger)
        self._search = target_search(self.belief, self.settings)
        self._agents = {
            a.id: _Agent(
                a,
                self.belief.charger_index,
                self._team,
                slot,
                self._search.memory(self._team, slot),
            )
            for slot, a in enumerate(agents)
        }
        self._occupant: dict[int, int] = {}
        self._claims: dict[int, int] = {}  # target cell -> agent chasing it
        self._events: list[PlannerEvent] = []
        self._complete = False
        self._witness: int | None = None  # see ``coverage_complete``
        #: Cells found cut off behind lost vehicles when coverage ended (``CUT_OFF``).
        self.cut_off_cells = 0
        self._witness_key: tuple[float | None, int] | None = None
        self._recalled = False  # see ``recall``
        #: The direction of a move, by the difference of the flat indices.
        self._heading_of = {self.belief.offset[d]: d for d in MOVES}
        self._roadmap = (
            Roadmap(self.settings) if self.settings.path_planner == PathPlannerKind.PRM else None
        )
        self._paper_sweep = self.settings.bm_rule == BmRule.PAPER
        #: Waits in a row after which an agent going home is given way to.
        self._long_wait = _GIVEN_WAY_AFTER * self.settings.patience
        #: The agents that have waited that long (and not moved since): mostly none,
        #: so that ``_kept_waiting_for`` need not look around at every move.
        self._held_up: set[int] = set()
        policy = self.settings.target_policy
        #: Where a blocked agent looks for a target, in order (``_take_target``).
        self._tiers: tuple[_Tier, ...] = {
            TargetPolicy.OWN_FIRST: (_Tier.OWN, _Tier.GLOBAL, _Tier.NET),
            TargetPolicy.NEAREST: (_Tier.GLOBAL, _Tier.NET),
            TargetPolicy.FRONTIER: (_Tier.FRONTIER,),
        }[policy]
        self.btps_detected = 0
        self.safety_net_fires = 0
        self._best_cost: float | None = None  # cache of _best_move_cost()
        #: After a loss: the cells the charger may still reach through free or unknown
        #: cells (``_in_range``), as of ``_open_at`` (the belief's ``walls_count``);
        #: None before.
        self._open: np.ndarray | None = None
        self._open_at = -1

    # -- queries ------------------------------------------------------------

    def mode(self, agent: int) -> AgentMode:
        return self._agents[agent].mode

    def charges(self, agent: int) -> int:
        return self._agents[agent].charges

    def cell_of(self, agent: int) -> Cell:
        return self.belief.cell(self._agents[agent].index)

    def planned_path(self, agent: int) -> list[Cell]:
        """The cells the agent is to move through after the move just decided: the rest
        of its way to its goal (the charger, when returning), as the planner keeps it."""
        return [self.belief.cell(i) for i in self._agents[agent].path]

    def btps(self) -> list[Cell]:
        return [self.belief.cell(i) for i in self.stacks.owner]

    @property
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
        if witness is None or not belief.uncovered_mask[witness] or not self._in_range(witness):
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
        beyond = (parts == parts[belief.charger_index]) & ~self._open_from_charger()
        beyond[belief.blocked] = False
        return int(beyond.sum())

    def _uncovered_in_range(self) -> int | None:
        """An uncovered cell that some agent can reach and come back from, or None.

        Read from the packed list: a set emptied by covering keeps its table, and
        iterating it reads every slot, which once coverage is complete happened
        at every call (2 % of the time of open 1000x1000 with 50 agents)."""
        belief = self.belief
        listed = belief.uncovered_list
        for k in range(belief.uncovered_count):
            if self._in_range(listed[k]):
                return listed[k]
        return None

    @property
    def homeward(self) -> bool:
        """Every agent is to go home and stop there: coverage is complete, or the
        mission was recalled."""
        return self._recalled or self.coverage_complete

    @property
    def _no_more_charges(self) -> bool:
        """Agents at the charger are done there without charging: the mission was
        recalled, or coverage is complete and ``charge_at_end`` is off."""
        return self._recalled or (not self.settings.charge_at_end and self.coverage_complete)

    @property
    def finished(self) -> bool:
        # Asked after every iteration: a loop, with no generator to build.
        for a in self._agents.values():  # noqa: SIM110
            if a.mode not in _STOPPED:
                return False
        return True

    def out_of_range_cells(self) -> list[Cell]:
        return [self.belief.cell(i) for i in self.belief.uncovered if not self._in_range(i)]

    def drain_events(self) -> list[PlannerEvent]:
        events, self._events = self._events, []
        return events

    # -- inputs -------------------------------------------------------------

    def observe(
        self,
        agent: int,
        cell: Cell,
        readings: Mapping[Direction, CellState],
        battery_pct: float,
    ) -> None:
        """The agent stands on ``cell``, sensed ``readings`` and has ``battery_pct`` left."""
        a = self._agents[agent]
        belief = self.belief
        index = belief.index(cell)
        if a.pending is not None and a.pending != index:
            self._release(a.pending, a.id)
        a.pending = None
        if index != a.index:
            heading = self._heading_of.get(index - a.index)
            if heading is not None:
                a.heading = heading
            else:
                a.path.clear()  # displaced: plans from here on
            # The cell just left stays held until the agent decides again, so
            # that no agent enters it along the same edge in the same step (a swap).
            if a.trailing is not None:
                self._release(a.trailing, a.id)
            a.trailing = a.index
            a.stand(index, cell)
        self._occupy(index, a.id)
        a.battery_pct = battery_pct
        newly_free = belief.sense(cell, readings)
        if belief.cover(cell, a.id):
            a.swept = True
            self._on_covered(index, a.id)
        if newly_free and self._roadmap is not None:
            self._roadmap.grow(belief, newly_free)
        if a.heading is not None and a.mode == _EXPLORE:
            for x in btp.detect(belief, index, a.heading):
                if self.stacks.push(a.id, x):
                    self.btps_detected += 1
                    self._events.append(PlannerEvent(EventKind.BTP_DETECTED, a.id, belief.cell(x)))

    def recall(self) -> None:
        """End the mission before coverage is complete (the operator aborts): every
        agent goes home as when it is complete, along the same ways that keep agents
        apart, and is done there; one charging is done at once."""
        self._recalled = True

    def update_battery(self, agent: int, battery_pct: float) -> None:
        """New battery telemetry without a move (e.g. while charging)."""
        self._agents[agent].battery_pct = battery_pct

    def set_energy_per_m(self, agent: int, pct_per_m: float) -> None:
        """A new estimate of the agent's battery use per metre (live missions refine it
        from telemetry); it rules every staying alive check from now on."""
        if pct_per_m < 0:
            raise ValueError("energy per metre must not be negative")
        a = self._agents[agent]
        if a.spec.energy_per_m_pct != pct_per_m:
            a.spec = replace(a.spec, energy_per_m_pct=pct_per_m)
            self._best_cost = None

    def mark_lost(self, agent: int) -> None:
        """The agent is gone: its BTPs go back to the global stack, its claims are freed."""
        a = self._agents[agent]
        a.mode = _LOST
        self._best_cost = None
        a.path.clear()
        self.stacks.release(a.id)
        self._drop_claim(a)
        # Where it stands (or, between two cells, may stand) nobody passes again: a
        # way through it would be waited on for ever.
        for i in (a.index, a.trailing, a.pending):
            if i is not None:
                self.belief.block(i)
        if a.pending is not None:
            self._release(a.pending, a.id)
        for other in self._agents.values():
            other.path.clear()
        self._open_from_charger()
        self._events.append(PlannerEvent(EventKind.LOST, a.id, self.belief.cell(a.index)))

    def _open_from_charger(self) -> np.ndarray:
        """Cells the charger may still reach through free or unknown cells, worked
        out again only when walls were found since the last time."""
        belief = self.belief
        if self._open is None or self._open_at != belief.walls_count:
            passable = np.frombuffer(belief.state, dtype=np.uint8) != _OBSTACLE
            parts, _ = ndimage.label(passable.reshape(-1, belief.stride))
            parts = parts.ravel()
            self._open, self._open_at = parts == parts[belief.charger_index], belief.walls_count
        return self._open

    def restore(self, known: np.ndarray, covered: np.ndarray, btps: Iterable[Cell]) -> None:
        """Carry on where an earlier run of the same mission stopped (a ground station
        restarted from its log): the map it knew (``CellState`` values), the cells it
        covered, and its BTPs, which go to the global pool since their agents' plans
        are gone. Call before the first ``observe``."""
        if known.shape != self.belief.shape or covered.shape != self.belief.shape:
            raise ValueError(f"restored map shape {known.shape} != {self.belief.shape}")
        belief = self.belief
        known = np.where(covered, int(CellState.FREE), known)
        self._load_prior(known)
        # A covered cell was sensed from: an unknown side means that sensing did not
        # reach the log. Such cells are left to cover again, so that someone senses there.
        for r, c in zip(*np.nonzero(covered & ~with_unknown_side(known)), strict=True):
            belief.cover((int(r), int(c)), btp.BtpStacks.POOL)
        for cell in btps:
            if belief.inside(cell) and belief.index(cell) in belief.uncovered:
                self.stacks.push(btp.BtpStacks.POOL, belief.index(cell))
        self._best_cost = None

    # -- the decision -------------------------------------------------------

    def decide(self, agent: int) -> Action:
        a = self._agents[agent]
        if a.trailing is not None:
            self._release(a.trailing, a.id)
            a.trailing = None
        mode = a.mode
        if mode == _LOST:
            return WAIT
        if mode in _AT_REST and not self.homeward:
            a.mode = mode = _IDLE  # back to work: something came into range again
        if mode == _DONE:
            return WAIT
        here = a.index
        at_charger = here == self.belief.charger_index
        if self.belief.charger_dist[here] == UNREACHED:
            return self._reconnect(a)
        if mode == _CHARGE:
            if a.battery_pct < self.settings.resume_pct - _EPS and not self._no_more_charges:
                return CHARGE
            a.mode = mode = _IDLE
        if not at_charger and mode not in _HOMEWARD and not self._can_afford(a, 0, here):
            # The battery fell without a move (a copter hovering while it waits, a
            # sag, a worse estimate of its consumption): home now, before the reserve.
            return self._go_charge(a)
        if a.make_way_for is not None:
            action = self._make_way(a)
            if action is not None:
                return action
        if a.letting_pass is not None and self._still_letting_pass(a):
            return WAIT
        mode = a.mode
        if self.homeward and mode not in _HOMEWARD:
            self._drop_claim(a)
            a.mode = mode = _HOMING
            a.path.clear()
        if mode in _HOMEWARD:
            if at_charger:
                full = a.battery_pct >= self.settings.resume_pct - _EPS
                if self._no_more_charges or (mode == _HOMING and full):
                    a.mode = _DONE
                    return WAIT
                a.mode = _CHARGE
                a.begin_charge()
                self._events.append(PlannerEvent(EventKind.CHARGED, a.id, self.belief.charger))
                return CHARGE
            return self._follow(a, self.belief.charger_index)
        if mode == _TRANSIT:
            assert a.goal is not None
            # Re-deciding needs consistent shortest paths: with the roadmap a
            # fresh path from one step on can be longer than the rest of the
            # old one, and the agent would turn back before every arrival.
            replan = self.settings.replan_transit and self._roadmap is None
            if not (
                here == a.goal
                or not self.belief.uncovered_mask[a.goal]
                # An uncovered cell beside the way is swept at once.
                or (replan and (a.recheck_in <= 0 or self._bm_next(a) is not None))
            ):
                a.recheck_in -= 1
                return self._follow(a, a.goal)
            a.was_heading_for = a.goal
            self._drop_claim(a)
            a.mode = _EXPLORE
        nxt = self._bm_next(a)
        if nxt is not None:
            a.was_heading_for = None
            if self._can_afford(a, 1, nxt):
                a.mode = _EXPLORE
                return self._move(a, nxt)
            # Staying alive: not enough to come back from there. Leave a BTP where
            # the sweep stops so that it is resumed, and go to charge.
            if self.stacks.push(a.id, nxt):
                self.btps_detected += 1
                self._events.append(
                    PlannerEvent(EventKind.BTP_DETECTED, a.id, self.belief.cell(nxt))
                )
            return self._go_charge(a)
        return self._take_target(a)

    # -- boustrophedon motion ------------------------------------------------

    def _bm_next(self, a: _Agent) -> int | None:
        """The next cell of the boustrophedon motion (Algorithm 1), or None when blocked.

        The paper takes the first of N, S, E, W that is free, uncovered and not
        taken. ``BmRule.TIGHT`` ranks those candidates first by how many
        uncovered ways on they leave (fewest first, unknown counting as open),
        then by the paper's order: it sweeps into dead ends and narrow strips
        before leaving them, so fewer pockets are left behind to come back for.
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
            if state[v] == _FREE and not covered[v] and v not in occupant:
                candidates.append(v)
        if len(candidates) <= 1 or self._paper_sweep:
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
        if len(tied) == 1 or not self.settings.bm_spread:
            return tied[0]
        rows, cols = self._team.others(a.slot)
        cell_of = self.belief.cell

        def crowding(v: int) -> int:
            return -nearest_manhattan(rows, cols, *cell_of(v))

        return min(tied, key=crowding)

    # -- blocked: choose a BTP (Algorithm 3 with exact search) ------------------

    def _take_target(self, a: _Agent) -> Action:
        if a.held_for > 0:
            # Held back from targets others are about to sweep: look again only
            # after a pause that doubles while nothing frees up (each look is a
            # search of the known map).
            a.held_for -= 1
            return WAIT
        previous, old_path = a.was_heading_for, a.path
        a.was_heading_for = None
        self._drop_claim(a)
        uncovered, claims = self.belief.uncovered, self._claims
        # Still on the way to ``previous``: the search may be skipped when it
        # would surely return it again (``TargetSearch.run``).
        hint = None
        if (
            previous is not None
            and old_path
            and old_path[-1] == previous
            and abs(old_path[0] - a.index) in (1, self.belief.stride)
        ):
            hint = (previous, old_path, a.path_known_at)
        any_candidate = False
        for tier in self._tiers:
            pool = self._pool(tier, a)
            if self._roadmap is None:
                found = self._nearest_affordable(a, None if pool is uncovered else pool, hint)
                if found is None:
                    any_candidate = any_candidate or any(
                        i not in claims and self._in_range(i) for i in pool
                    )
                    continue
                any_candidate = True
            else:
                candidates = {i for i in pool if i not in claims and self._in_range(i)}
                if not candidates:
                    continue
                any_candidate = True
                found = self._roadmap.nearest(
                    self.belief, a.index, candidates, lambda i, d: self._can_afford(a, d, i)
                )
            if isinstance(found, _Held):
                a.mode = _IDLE
                a.held_backoff = min(2 * a.held_backoff + 1, self.settings.held_backoff_max)
                a.held_for = a.held_backoff
                return WAIT
            a.held_backoff = 0
            if found is None:
                continue
            goal, path = found
            if self._worth_topping_up(a, len(path)):
                return self._go_charge(a)
            if hint is not None and goal == previous and len(old_path) <= len(path):
                # Re-deciding in transit: keep a detour around other agents
                # that is no longer than the fresh path, or the two alternate
                # and the agent paces between them for ever.
                path = old_path
            self._claims[goal] = a.id
            a.goal, a.mode = goal, _TRANSIT
            a.path = path if path is old_path else deque(path)
            a.path_known_at = self.belief.stamp
            if self.settings.far_transit_recheck:
                a.recheck_in = max(0, (len(path) - self.settings.far_transit_recheck) // 2)
            if goal != previous:  # a choice, not the target confirmed on the way to it
                kind = EventKind.SAFETY_NET if tier == _Tier.NET else EventKind.TARGET
                if tier == _Tier.NET:
                    self.safety_net_fires += 1
                self._events.append(PlannerEvent(kind, a.id, self.belief.cell(goal)))
            return self._follow(a, goal)
        if any_candidate and (
            a.index != self.belief.charger_index or a.battery_pct < self.settings.resume_pct - _EPS
        ):
            return self._go_charge(a)  # what is left needs more battery than it has
        a.mode = _IDLE
        return WAIT

    def _pool(self, tier: _Tier, a: _Agent) -> Collection[int]:
        if tier == _Tier.OWN:
            return self.stacks.own(a.id)
        if tier == _Tier.GLOBAL:
            return self.stacks.owner
        return self.belief.uncovered

    def _nearest_affordable(
        self,
        a: _Agent,
        pool: Iterable[int] | None,
        hint: tuple[int, Sequence[int], tuple[int, int] | None] | None = None,
    ) -> tuple[int, Sequence[int]] | _Held | None:
        """The closest target of ``pool`` (None: every uncovered cell) that the agent
        can afford, preferring those no other working agent is closer to (they are
        likely to be swept by that agent). Claimed and out-of-range cells are not
        targets.

        With ``hold_radius``, when every candidate is nearer to another working
        agent, those within ``hold_radius`` cells of such an agent are left to it
        (it is about to sweep them: chasing them only walks beside it), and
        ``HELD`` says that all of them are. One compiled search ranks them all
        (or confirms ``hint``: the target on the way to, the way there, and
        when it was last known to be a shortest way).
        """
        spread = self.settings.spread
        hold = self.settings.hold_radius if spread else 0
        # Positional: a keyword costs more than the field it names, once a decision.
        floor, best_cost = self.settings.reserve_pct - _EPS, self._best_move_cost()
        energy = Energy(a.battery_pct, self._move_cost(a), floor, best_cost, self._range_budget_pct)
        others = self._team.others(a.slot) if spread else _NOBODY
        heading = Hint(*hint) if hint is not None and pool is None else None
        request = SearchRequest(a.index, energy, others, hold, list(self._claims), pool, heading)
        found = self._search.run(request, a.search_memory)
        if found is None:
            return None
        level, goal, path = found
        if level == _Rank.CONTESTED and hold:
            return HELD
        return goal, path

    def _best_move_cost(self) -> float:
        """The cheapest move of any agent still in the mission (inf when none is)."""
        if self._best_cost is None:
            self._best_cost = min(
                (self._move_cost(b) for b in self._agents.values() if b.mode != _LOST),
                default=math.inf,
            )
        return self._best_cost

    @property
    def _range_budget_pct(self) -> float:
        """Battery a full charge leaves for a round trip above the reserve."""
        return self.settings.resume_pct - self.settings.reserve_pct + _EPS

    # -- staying alive policy (Algorithm 2) ------------------------------------

    def _move_cost(self, a: _Agent) -> float:
        return a.spec.energy_per_m_pct * self.settings.cell_size_m

    def _can_afford(self, a: _Agent, moves: int, there: int) -> bool:
        """After ``moves`` moves to ``there``, can the agent still reach the charger
        over known free cells and arrive with at least the reserve?"""
        cost = self._move_cost(a)
        home = self.belief.charger_dist[there]
        if home >= UNREACHED:
            return False
        return a.battery_pct - cost * (moves + home) >= self.settings.reserve_pct - _EPS

    def _in_range(self, index: int) -> bool:
        """Can a fully charged agent go to ``index`` and come back (for some agent)?"""
        home = self.belief.charger_dist[index]
        if home >= UNREACHED:
            # Not connected to what we know yet: keep it, unless walls and lost
            # vehicles cut it off from the charger even through unknown cells
            # (walls found since the last look may have closed the way).
            return self._open is None or bool(self._open_from_charger()[index])
        return 2 * home * self._best_move_cost() <= self._range_budget_pct

    def _worth_topping_up(self, a: _Agent, moves: int) -> bool:
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
        if gain <= _EPS:
            return False  # full already (or no battery model): nothing to gain
        return 2 * home * self._move_cost(a) <= ratio * gain

    def _go_charge(self, a: _Agent) -> Action:
        self._drop_claim(a)
        a.mode = _RETURN
        a.path.clear()
        self._events.append(PlannerEvent(EventKind.RETURN, a.id, self.belief.cell(a.index)))
        if a.index == self.belief.charger_index:
            a.mode = _CHARGE
            a.begin_charge()
            return CHARGE
        return self._follow(a, self.belief.charger_index)

    def _reconnect(self, a: _Agent) -> Action:
        """No known way home from here: head back to the known map through the cells
        most likely free (``path_to_known``); the staying alive checks resume there."""
        path = path_to_known(self.belief, a.index, frozenset(self._occupant) - {a.index})
        if not path:
            path = path_to_known(self.belief, a.index)
        if path is None:
            # Walled in for good (a lost vehicle in the only door): it can never come
            # home, and the mission must not wait for it.
            a.mode = _DONE
            self._drop_claim(a)
            return WAIT
        if not path or self._occupant.get(path[0], a.id) != a.id:
            return WAIT
        if self.belief.state[path[0]] != _FREE:
            return WAIT  # not sensed yet: never step into the unknown
        a.path.clear()
        self._drop_claim(a)
        return self._move(a, path[0])

    # -- moving along a path without collisions --------------------------------

    def _plan(self, a: _Agent, goal: int) -> list[int] | None:
        # The way home is always the exact shortest path: the staying alive
        # policy budgets the return on it, so a longer roadmap path could eat
        # into the reserve.
        if goal == self.belief.charger_index:
            return path_to_charger(self.belief, a.index)
        if self._roadmap is not None:
            return self._roadmap.path(self.belief, a.index, goal)
        return self._search.path(a.index, goal)

    def _follow(self, a: _Agent, goal: int) -> Action:
        if not a.path or abs(a.path[0] - a.index) not in (1, self.belief.stride):
            path = self._plan(a, goal)
            if path is None:  # cannot happen on a connected known map; be safe
                a.mode = _IDLE
                self._drop_claim(a)
                return WAIT
            if a.mode == _TRANSIT and not self._can_afford(a, len(path), goal):
                return self._go_charge(a)  # the new way there is longer than budgeted
            a.path = deque(path)
            shortest = self._roadmap is None or goal == self.belief.charger_index
            a.path_known_at = self.belief.stamp if shortest else None
        nxt = a.path[0]
        blocker = self._occupant.get(nxt)
        if blocker is None or blocker == a.id:
            if a.mode not in _HOMEWARD and self._kept_waiting_for(nxt):
                return WAIT
            a.path.popleft()
            return self._move(a, nxt)
        other = self._agents[blocker]
        # An idle agent has nowhere to go: it is asked to step aside at once. Walked
        # round, it stays on the fresh path of the next decision, and the agent
        # paces between the two ways (a crowd held idle in the corridor to the last
        # frontier stalled rooms 300x300 with 50 agents 2500 iterations).
        ask_now = other.mode == _IDLE and a.waited < self.settings.patience
        if not ask_now:
            detour = self._detour(a, goal)
            if detour is not None:
                a.path, a.path_known_at = deque(detour), None
                return self._move(a, a.path.popleft())
        a.waited += 1
        if a.waited == self._long_wait:
            self._held_up.add(a.id)
        if ask_now or a.waited >= self.settings.patience:
            self._ask_to_make_way(a, other)
        return WAIT

    def _kept_waiting_for(self, index: int) -> bool:
        """Is an agent going home held up beside ``index``, waiting to step into it?

        Then the cell is left to it: where a queue going out meets one coming
        home (the mouth of a passage at the charger), the agents going out
        would otherwise take every cell the one going home waits for, one after
        another, for ever.
        """
        if self._long_wait > 0 and not self._held_up:
            return False  # nobody has waited that long
        for c in self._agents_beside(index):
            if self._long_held_up_going_home(c) and c.path and c.path[0] == index:
                return True
        return False

    def _long_held_up_going_home(self, a: _Agent) -> bool:
        return a.mode in _HOMEWARD and a.waited >= self._long_wait

    def _agents_beside(self, index: int) -> Iterator[_Agent]:
        """The agents in the cells next to ``index`` (N, S, E, W)."""
        for s in self.belief.steps:
            c = self._agents.get(self._occupant.get(index + s, -1))
            if c is not None:
                yield c

    def _detour(self, a: _Agent, goal: int) -> list[int] | None:
        """A path around the agents in the way, if it is not much longer and affordable.

        A goal held by another agent (one about to move into it) is no way
        round: the agent waits for it like for any other held cell.
        """
        if self._occupant.get(goal, a.id) != a.id:
            return None
        blocked = [i for i in self._occupant if i != a.index]
        path = self._search.path(a.index, goal, blocked, len(a.path) + 2 * self.settings.patience)
        if not path:
            return None
        if a.mode in (_RETURN, _HOMING):
            affordable = a.battery_pct - self._move_cost(a) * len(path) >= (
                self.settings.reserve_pct - _EPS
            )
        else:
            affordable = self._can_afford(a, len(path), goal)
        return path if affordable else None

    def _priority(self, a: _Agent) -> tuple[int, int]:
        return (_PRIORITY.get(a.mode, 0), -a.id)

    def _ask_to_make_way(self, a: _Agent, blocker: _Agent) -> None:
        if blocker.mode == _IDLE or self._priority(a) > self._priority(blocker):
            asked = blocker.make_way_for
            # The most urgent request stands (a returning agent before one
            # leaving the charger), or the two can undo each other for ever.
            if asked is None or self._priority(a) > self._priority(self._agents[asked]):
                blocker.make_way_for = a.id

    def _make_way(self, b: _Agent) -> Action | None:
        """Step aside for the agent that asked, if it still needs this cell.

        Where two queues meet in a narrow passage, stepping aside one by one can
        go on for ever. What drains a jam is that agents going home walk down
        the distance field to a pad with room for all, so they never wait on
        each other in a circle: they are not pushed aside, and an agent in the
        way of one long held up, or boxed in, or too low on battery to step
        aside, goes home with them.
        """
        assert b.make_way_for is not None
        a = self._agents[b.make_way_for]
        b.make_way_for = None
        pushed, b.pushed = b.pushed, False
        if b.index == self.belief.charger_index:
            # The pad has room for all: nobody waits for it. (Asked from the cell
            # it has just left, held until it decides again, it stepped out again.)
            return None
        if not pushed and (not a.path or a.path[0] != b.index):
            return None
        if pushed and b.mode in _HOMEWARD:
            # Agents going home walk down the distance field to a pad with room
            # for all, so they never wait on each other in a circle: one waits
            # for those ahead, not steps aside for a queue's push (in a crowd
            # before the charger's door, pushes went round and round).
            return None
        if b.mode in _HOMEWARD and b.letting_pass is not None:
            # Asked again while aside: a step on home frees the cell as well. Else
            # it may be asked back by the next agent, and pace between two cells
            # for ever (a queue at the charger's door).
            on = self._free_step_home(b)
            if on is not None:
                b.letting_pass = None
                b.path.clear()
                return self._move(b, on)
        if self._long_held_up_going_home(a) and b.mode not in _HOMEWARD:
            # Stepping aside has long not let it through: in a passage two cells
            # wide the cell aside is the other lane of the queue coming home, and
            # the two lanes take turns at asking, so that the agent paces between
            # them for ever. It goes home with the queue instead (below).
            return self._go_charge(b)
        ahead = set(a.path)
        best: tuple[tuple[bool, int], int] | None = None
        too_far = False  # a cell to step aside to, but not one the battery allows
        for s in self.belief.steps:
            v = b.index + s
            if (
                self.belief.state[v] != _FREE
                or (v == a.index and v != self.belief.charger_index)  # the depot has room
                or v in self._occupant
            ):
                continue
            if not self._can_afford(b, 1, v):
                too_far = True
                continue
            key = (v not in ahead, manhattan(self.belief.cell(v), self.belief.cell(a.index)))
            if best is None or key > best[0]:
                best = (key, v)
        if best is None:
            if b.mode not in _HOMEWARD and (too_far or a.mode in _HOMEWARD):
                # Boxed in on the way of an agent going home: a queue meets it head
                # on in a narrow passage, and stepping aside one by one only lets
                # the queue close up again. The queue turns and goes home too:
                # everyone going home walks towards the charger, which has room
                # for all, so the passage drains. So too when the only cell aside
                # is farther than the battery allows: it soon must go home anyway,
                # and those between it and the charger are then on its way home.
                return self._go_charge(b)
            # Boxed in (a queue in a corridor): pass the request on to the agents
            # around, so that the queue backs off from its free end.
            for c in self._agents_beside(b.index):
                if c is not a and c.make_way_for is None:
                    c.make_way_for, c.pushed = b.id, True
            return None
        b.path.clear()
        b.letting_pass = (a.id, b.index, 4 * self.settings.patience)
        return self._move(b, best[1])

    def _free_step_home(self, a: _Agent) -> int | None:
        """A cell one move nearer the charger that the agent can step into now."""
        dist = self.belief.charger_dist
        nearer = dist[a.index] - 1
        for s in self.belief.steps:
            v = a.index + s
            if dist[v] == nearer and self._occupant.get(v, a.id) == a.id:
                return v
        return None

    def _still_letting_pass(self, b: _Agent) -> bool:
        """Stay aside until the agent let through has gone past the cell given up."""
        assert b.letting_pass is not None
        agent, cell, left = b.letting_pass
        a = self._agents[agent]
        if left > 0 and a.mode not in (_DONE, _LOST) and (cell in a.path or a.pending == cell):
            b.letting_pass = (agent, cell, left - 1)
            return True
        b.letting_pass = None
        return False

    def _move(self, a: _Agent, to: int) -> Action:
        if a.waited:
            self._held_up.discard(a.id)
            a.waited = 0
        a.pending = to
        self._occupy(to, a.id)
        return Action(_MOVE, self.belief.cell(to))

    # -- bookkeeping --------------------------------------------------------------

    def _occupy(self, index: int, agent: int) -> None:
        if index != self.belief.charger_index:
            self._occupant[index] = agent

    def _release(self, index: int, agent: int) -> None:
        if self._occupant.get(index) == agent:
            del self._occupant[index]

    def _drop_claim(self, a: _Agent) -> None:
        if a.goal is not None and self._claims.get(a.goal) == a.id:
            del self._claims[a.goal]
        a.goal = None

    def _on_covered(self, index: int, agent: int) -> None:
        if self.stacks.remove(index):
            self._events.append(PlannerEvent(EventKind.BTP_COVERED, agent, self.belief.cell(index)))

    def _load_prior(self, prior: np.ndarray) -> None:
        if prior.shape != self.belief.shape:
            raise ValueError(f"prior map shape {prior.shape} != {self.belief.shape}")
        belief = self.belief
        for r, c in zip(*np.nonzero(prior == CellState.OBSTACLE), strict=True):
            belief.state[belief.index((int(r), int(c)))] = int(CellState.OBSTACLE)
        cr, cc = belief.charger
        free = sorted(
            ((int(r), int(c)) for r, c in zip(*np.nonzero(prior == CellState.FREE), strict=True)),
            key=lambda cell: abs(cell[0] - cr) + abs(cell[1] - cc),
        )
        for cell in free:  # nearest first keeps the incremental distance update cheap
            belief.mark_free(belief.index(cell))


__all__ = ["MOVES", "Action", "ActionKind", "AgentMode", "Coordinator", "EventKind", "PlannerEvent"]
