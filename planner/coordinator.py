"""Multi-agent exploration and coverage with the staying alive policy (paper, Algorithm 4).

The coordinator owns the shared map belief, the BTP stacks and every agent's
record. It is driven from outside, one agent at a time, which serves both the
lockstep simulation (``gcs plan``: every agent decides once per iteration)
and a live mission (each vehicle asks for its next move when it has arrived):

* ``observe(agent, cell, readings, battery_pct)`` after the agent arrived
  somewhere and sensed its 8 neighbours;
* ``decide(agent) -> Action``: move to a neighbour cell, wait, or charge.

``decide`` is the loop body of Algorithm 4, a state machine over each agent's
``AgentMode``; its collaborators each hold one part of the paper:

* ``Sweep`` (``sweep.py``): the boustrophedon motion, Algorithm 1;
* ``Targets`` (``targets.py``): the target of a blocked agent, Algorithm 3;
* ``StayingAlive`` (``staying_alive.py``): what the battery allows, Algorithm 2;
* ``Traffic`` and ``GiveWay`` (``traffic.py``, ``give_way.py``): moves without
  collisions or swaps, and stepping aside.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import replace

import numpy as np

from core.cells import MOVES, Cell, CellState, Direction
from planner import btp, known_map
from planner.agent import (
    AT_REST,
    CHARGE,
    CHARGING,
    DONE,
    EXPLORING,
    HOMEWARD,
    HOMING,
    IDLE,
    LOST,
    STOPPED,
    TRANSIT,
    WAIT,
    Action,
    AgentMode,
    AgentRecord,
    EventKind,
    Fleet,
    PlannerEvent,
)
from planner.belief import UNREACHED, MapBelief
from planner.give_way import GiveWay
from planner.prm import Roadmap
from planner.settings import AgentSpec, PathPlannerKind, PlannerSettings
from planner.staying_alive import EPS, StayingAlive
from planner.sweep import Sweep
from planner.target_search import target_search
from planner.targets import Finders, Targets
from planner.team import Team
from planner.traffic import Traffic


class Coordinator:
    """The public face of the planner: observations in, one agent's action out."""

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
        self.settings = settings = settings or PlannerSettings()
        ids = [a.id for a in agents]
        if len(set(ids)) != len(ids):
            raise ValueError("agent ids must be unique")
        self.belief = belief = MapBelief(shape, charger)
        if prior is not None:
            known_map.load_prior(belief, prior)
        self.stacks = btp.BtpStacks()
        team = Team(len(agents), charger)
        self._search = search = target_search(belief, settings)
        self._agents: Fleet = {
            a.id: AgentRecord(a, belief.charger_index, team, slot, search.memory(team, slot))
            for slot, a in enumerate(agents)
        }
        for a in self._agents.values():
            a.launch_in = a.slot * settings.launch_interval
        self._events: list[PlannerEvent] = []
        self._recalled = False  # see ``recall``
        #: The direction of a move, by the difference of the flat indices.
        self._heading_of = {belief.offset[d]: d for d in MOVES}
        self._roadmap = Roadmap(settings) if settings.path_planner == PathPlannerKind.PRM else None
        self.btps_detected = 0
        self._wire(belief, settings, team)

    def _wire(self, belief: MapBelief, settings: PlannerSettings, team: Team) -> None:
        """The collaborators, each given the shared state it needs."""
        agents, events = self._agents, self._events
        self._alive = alive = StayingAlive(
            belief=belief, settings=settings, agents=agents, events=events
        )
        self._traffic = traffic = Traffic(
            belief=belief,
            settings=settings,
            agents=agents,
            alive=alive,
            search=self._search,
            roadmap=self._roadmap,
            events=events,
        )
        self._give_way = GiveWay(
            belief=belief, settings=settings, agents=agents, traffic=traffic, alive=alive
        )
        self._sweep = Sweep(belief=belief, settings=settings, occupant=traffic.occupant, team=team)
        self._targets = Targets(
            belief=belief,
            settings=settings,
            stacks=self.stacks,
            traffic=traffic,
            alive=alive,
            finders=Finders(self._search, team, self._roadmap),
            sweep=self._sweep,
            events=events,
        )
        self._held_shortcut = settings.search_shortcuts.held_wait
        #: Held waits told by the shortcut (``_still_held``), for the tests.
        self.quick_held_waits = 0

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

    def heading_for(self, agent: int) -> Cell | None:
        """Where the agent goes along a planned path (``AgentRecord.going_to``), or None."""
        i = self._agents[agent].going_to(self.belief.charger_index)
        return None if i is None else self.belief.cell(i)

    def btps(self) -> list[Cell]:
        return [self.belief.cell(i) for i in self.stacks.owner]

    @property
    def safety_net_fires(self) -> int:
        """Targets taken by the safety net (no BTP left: an uncovered cell)."""
        return self._targets.safety_net_fires

    @property
    def cut_off_cells(self) -> int:
        """Cells found cut off behind lost vehicles when coverage ended (``CUT_OFF``)."""
        return self._alive.cut_off_cells

    @property
    def coverage_complete(self) -> bool:
        """Nothing is left that any agent can reach and come back from (judged afresh
        every time: see ``StayingAlive.coverage_complete``)."""
        return self._alive.coverage_complete()

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
            if a.mode not in STOPPED:
                return False
        return True

    def out_of_range_cells(self) -> list[Cell]:
        in_range = self._alive.in_range
        return [self.belief.cell(i) for i in self.belief.uncovered if not in_range(i)]

    def drain_events(self) -> list[PlannerEvent]:
        events = self._events.copy()  # the list itself is shared with the collaborators
        self._events.clear()
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
        belief, traffic = self.belief, self._traffic
        index = belief.index(cell)
        if a.pending is not None and a.pending != index:
            traffic.release(a.pending, a.id)
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
                traffic.release(a.trailing, a.id)
            a.trailing = a.index
            a.stand(index, cell)
        traffic.occupy(index, a.id)
        a.battery_pct = battery_pct
        newly_free = belief.sense(cell, readings)
        if belief.cover(cell, a.id):
            a.swept = True
            if self.stacks.remove(index):
                covered = belief.cell(index)
                self._events.append(PlannerEvent(EventKind.BTP_COVERED, a.id, covered))
        if newly_free and self._roadmap is not None:
            self._roadmap.grow(belief, newly_free)
        if a.heading is not None and a.mode == EXPLORING:
            for x in btp.detect(belief, index, a.heading):
                self._push_btp(a, x)

    def _push_btp(self, a: AgentRecord, index: int) -> None:
        if self.stacks.push(a.id, index):
            self.btps_detected += 1
            self._events.append(PlannerEvent(EventKind.BTP_DETECTED, a.id, self.belief.cell(index)))

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
            self._alive.forget_costs()

    def mark_lost(self, agent: int) -> None:
        """The agent is gone: its BTPs go back to the global stack, its claims are freed."""
        a = self._agents[agent]
        a.mode = LOST
        self._alive.forget_costs()
        a.path.clear()
        self.stacks.release(a.id)
        self._traffic.drop_claim(a)
        # Where it stands (or, between two cells, may stand) nobody passes again: a
        # way through it would be waited on for ever.
        for i in (a.index, a.trailing, a.pending):
            if i is not None:
                self.belief.block(i)
        if a.pending is not None:
            self._traffic.release(a.pending, a.id)
        for other in self._agents.values():
            other.path.clear()
        self._alive.open_from_charger()
        self._events.append(PlannerEvent(EventKind.LOST, a.id, self.belief.cell(a.index)))

    def restore(self, known: np.ndarray, covered: np.ndarray, btps: Iterable[Cell]) -> None:
        """Carry on where an earlier run of the same mission stopped (a ground station
        restarted from its log): the map it knew (``CellState`` values), the cells it
        covered, and its BTPs, which go to the global pool since their agents' plans
        are gone. Call before the first ``observe``."""
        known_map.restore(self.belief, self.stacks, known, covered, btps)
        self._alive.forget_costs()

    # -- the decision (Algorithm 4) -------------------------------------------

    def decide(self, agent: int) -> Action:
        """The agent's next action. In order: the rules that stop or hold an agent
        (lost, done, cut off from the known map, charging), the staying alive check,
        a request to make way, going home; else its work (``_work``)."""
        a = self._agents[agent]
        if self._held_shortcut and a.left_alone_held() and self._still_held(a):
            a.came_from = None
            a.held_for -= 1
            self.quick_held_waits += 1
            return WAIT
        if a.trailing is not None:
            self._traffic.release(a.trailing, a.id)
        a.came_from, a.trailing = a.trailing, None
        mode = a.mode
        if mode == LOST:
            return WAIT
        if a.held_at_launch():
            return WAIT
        if mode in AT_REST and not self.homeward:
            a.mode = mode = IDLE  # back to work: something came into range again
        if mode == DONE:
            return WAIT
        here = a.index
        if self.belief.charger_dist[here] == UNREACHED:
            return self._traffic.reconnect(a)
        if mode == CHARGING:
            if self._alive.needs_charge(a) and not self._no_more_charges:
                return CHARGE
            a.mode = mode = IDLE
        if (
            here != self.belief.charger_index
            and mode not in HOMEWARD
            and not self._alive.can_afford(a, 0, here)
        ):
            # The battery fell without a move (a copter hovering while it waits, a
            # sag, a worse estimate of its consumption): home now, before the reserve.
            return self._traffic.go_charge(a)
        action = self._make_way(a)
        if action is not None:
            return action
        if self.homeward and a.mode not in HOMEWARD:
            self._traffic.drop_claim(a)
            a.mode = HOMING
            a.path.clear()
        if a.mode in HOMEWARD:
            return self._go_home(a)
        return self._work(a)

    def _still_held(self, a: AgentRecord) -> bool:
        """Would ``decide`` find the held agent left alone as it left it: blocked where
        it stands, its way home affordable, the mission not homeward? Then its
        decision is the held wait, told without the rest."""
        here = a.index
        return (
            self.belief.charger_dist[here] != UNREACHED
            and (here == self.belief.charger_index or self._alive.can_afford(a, 0, here))
            and not self.homeward
            and self._sweep.blocked(a)
        )

    def _make_way(self, a: AgentRecord) -> Action | None:
        """Asked to make way, or aside while another passes: what that requires."""
        if a.make_way_for is not None:
            action = self._give_way.answer(a)
            if action is not None:
                return action
        if a.letting_pass is not None and self._give_way.still_letting_pass(a):
            return WAIT
        return None

    def _go_home(self, a: AgentRecord) -> Action:
        """Returning to charge, or homing at the end: on towards the charger; there,
        charge, or be done."""
        if a.index != self.belief.charger_index:
            return self._traffic.follow(a, self.belief.charger_index)
        full = a.battery_pct >= self.settings.resume_pct - EPS
        if self._no_more_charges or (a.mode == HOMING and full):
            a.mode = DONE
            return WAIT
        a.mode = CHARGING
        a.begin_charge()
        self._events.append(PlannerEvent(EventKind.CHARGED, a.id, self.belief.charger))
        return CHARGE

    def _work(self, a: AgentRecord) -> Action:
        """Sweep on (Algorithm 1) while the battery allows, else charge; blocked, take
        a target (Algorithm 3); in transit, go on to it unless re-deciding."""
        if a.mode == TRANSIT and not self._targets.transit_ends(a):
            a.recheck_in -= 1
            assert a.goal is not None
            return self._traffic.follow(a, a.goal)
        nxt = self._sweep.next_cell(a)
        if nxt is None:
            return self._targets.take(a)
        a.was_heading_for = None
        if self._alive.can_afford(a, 1, nxt):
            a.mode = EXPLORING
            return self._traffic.move(a, nxt)
        # Staying alive: not enough to come back from there. Leave a BTP where
        # the sweep stops so that it is resumed, and go to charge.
        self._push_btp(a, nxt)
        return self._traffic.go_charge(a)
