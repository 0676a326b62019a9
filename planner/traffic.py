"""Moving along paths without collisions: reservations, claims, detours, the way home.

A move reserves its target cell at once (``occupant``), so that no two agents
ever head for the same cell; the cell just left stays held until the agent
decides again (the coordinator releases it), so that no two agents swap cells.
The charging station is a depot with room for the whole fleet: agents standing
on it occupy nothing. A target a blocked agent chases is claimed (``claims``),
so that no two agents chase the same one.

An agent blocked on its way walks round (``_detour``) or waits, and after
``patience`` waits asks the agent in the way to step aside (``_ask_to_make_way``;
``GiveWay`` answers). Agents going home go first.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Iterator

from core.cells import CellState
from planner.agent import (
    CHARGE,
    CHARGING,
    DONE,
    HOMEWARD,
    HOMING,
    IDLE,
    MOVE,
    RETURNING,
    TRANSIT,
    WAIT,
    Action,
    AgentRecord,
    EventKind,
    Fleet,
    PlannerEvent,
)
from planner.belief import MapBelief
from planner.paths import path_to_charger, path_to_known
from planner.prm import Roadmap
from planner.settings import PlannerSettings
from planner.staying_alive import StayingAlive
from planner.target_search import TargetSearch

_FREE = int(CellState.FREE)

#: Who goes first when two agents want the same cell: going to charge, then
#: going home at the end, then on the way to a target; the rest after.
_PRIORITY = {RETURNING: 3, HOMING: 2, TRANSIT: 1}

#: An agent going home held up this many times ``patience`` is given the cell it
#: waits for (``_kept_waiting_for``), and the agent it asks to make way goes home
#: with it (``GiveWay``): late enough to leave ordinary crossings to the order
#: of decisions, as before, and to settle a jam.
GIVEN_WAY_AFTER = 8


class Traffic:
    """The cells the agents hold and the targets they chase, and the moves that keep
    them apart."""

    def __init__(
        self,
        *,
        belief: MapBelief,
        settings: PlannerSettings,
        agents: Fleet,
        alive: StayingAlive,
        search: TargetSearch,
        roadmap: Roadmap | None,
        events: list[PlannerEvent],
    ) -> None:
        self.belief = belief
        self.settings = settings
        self._agents = agents
        self._alive = alive
        self._search = search
        self._roadmap = roadmap
        self._events = events
        #: The agent in each reserved cell (never the charger).
        self.occupant: dict[int, int] = {}
        self.claims: dict[int, int] = {}  # target cell -> agent chasing it
        #: Waits in a row after which an agent going home is given way to.
        self.long_wait = GIVEN_WAY_AFTER * settings.patience
        #: The agents that have waited that long (and not moved since): mostly none,
        #: so that ``_kept_waiting_for`` need not look around at every move.
        self._held_up: set[int] = set()

    @property
    def fleet(self) -> Fleet:
        """Every agent's record, by id (read by ``planner.regions``)."""
        return self._agents

    # -- reservations and claims ------------------------------------------------

    def occupy(self, index: int, agent: int) -> None:
        if index != self.belief.charger_index:
            self.occupant[index] = agent

    def release(self, index: int, agent: int) -> None:
        if self.occupant.get(index) == agent:
            del self.occupant[index]

    def drop_claim(self, a: AgentRecord) -> None:
        if a.goal is not None and self.claims.get(a.goal) == a.id:
            del self.claims[a.goal]
        a.goal = None

    def move(self, a: AgentRecord, to: int) -> Action:
        if a.waited:
            self._held_up.discard(a.id)
            a.waited = 0
        a.pending = to
        self.occupy(to, a.id)
        return Action(MOVE, self.belief.cell(to))

    # -- going to charge ----------------------------------------------------------

    def go_charge(self, a: AgentRecord) -> Action:
        """Staying alive: give up what it was doing and head for the charger (or, on
        it, charge)."""
        self.drop_claim(a)
        a.mode = RETURNING
        a.path.clear()
        self._events.append(PlannerEvent(EventKind.RETURN, a.id, self.belief.cell(a.index)))
        if a.index == self.belief.charger_index:
            a.mode = CHARGING
            a.begin_charge()
            return CHARGE
        return self.follow(a, self.belief.charger_index)

    def reconnect(self, a: AgentRecord) -> Action:
        """No known way home from here: head back to the known map through the cells
        most likely free (``path_to_known``); the staying alive checks resume there."""
        path = path_to_known(self.belief, a.index, frozenset(self.occupant) - {a.index})
        if not path:
            path = path_to_known(self.belief, a.index)
        if path is None:
            # Walled in for good (a lost vehicle in the only door): it can never come
            # home, and the mission must not wait for it.
            a.mode = DONE
            self.drop_claim(a)
            return WAIT
        if not path or self.occupant.get(path[0], a.id) != a.id:
            return WAIT
        if self.belief.state[path[0]] != _FREE:
            return WAIT  # not sensed yet: never step into the unknown
        a.path.clear()
        self.drop_claim(a)
        return self.move(a, path[0])

    # -- following a path -----------------------------------------------------------

    def _plan(self, a: AgentRecord, goal: int) -> list[int] | None:
        # The way home is always the exact shortest path: the staying alive
        # policy budgets the return on it, so a longer roadmap path could eat
        # into the reserve.
        if goal == self.belief.charger_index:
            return path_to_charger(self.belief, a.index)
        if self._roadmap is not None:
            return self._roadmap.path(self.belief, a.index, goal)
        return self._search.path(a.index, goal)

    def follow(self, a: AgentRecord, goal: int) -> Action:
        """The next move towards ``goal`` along the agent's path (planned afresh when
        it has none from here), round agents in the way, or a wait for them."""
        if not a.path or abs(a.path[0] - a.index) not in (1, self.belief.stride):
            path = self._plan(a, goal)
            if path is None:  # cannot happen on a connected known map; be safe
                a.mode = IDLE
                self.drop_claim(a)
                return WAIT
            if a.mode == TRANSIT and not self._alive.can_afford(a, len(path), goal):
                return self.go_charge(a)  # the new way there is longer than budgeted
            a.path = deque(path)
            shortest = self._roadmap is None or goal == self.belief.charger_index
            a.path_known_at = self.belief.stamp if shortest else None
        nxt = a.path[0]
        blocker = self.occupant.get(nxt)
        if blocker is None or blocker == a.id:
            if a.mode not in HOMEWARD and self._kept_waiting_for(nxt):
                return WAIT
            a.path.popleft()
            return self.move(a, nxt)
        return self._blocked(a, goal, self._agents[blocker])

    def _blocked(self, a: AgentRecord, goal: int, other: AgentRecord) -> Action:
        """``other`` stands on the next cell of the agent's path: walk round, or wait
        and (after ``patience`` waits) ask it to step aside."""
        # An idle agent has nowhere to go: it is asked to step aside at once. Walked
        # round, it stays on the fresh path of the next decision, and the agent
        # paces between the two ways (a crowd held idle in the corridor to the last
        # frontier stalled rooms 300x300 with 50 agents 2500 iterations).
        ask_now = other.mode == IDLE and a.waited < self.settings.patience
        if not ask_now:
            detour = self._detour(a, goal)
            # Two agents crossing in a narrow passage can each walk round the
            # other into the cell the other just left, back and forth for ever:
            # one that has turned back twice in a row waits instead.
            if detour is not None and (a.turned_back < 2 or detour[0] != a.came_from):
                a.path, a.path_known_at = deque(detour), None
                return self.move(a, a.path.popleft())
        a.waited += 1
        if a.waited == self.long_wait:
            self._held_up.add(a.id)
        if ask_now or a.waited >= self.settings.patience:
            self._ask_to_make_way(a, other)
        return WAIT

    def _detour(self, a: AgentRecord, goal: int) -> list[int] | None:
        """A path around the agents in the way, if it is not much longer and affordable.

        A goal held by another agent (one about to move into it) is no way
        round: the agent waits for it like for any other held cell.
        """
        if self.occupant.get(goal, a.id) != a.id:
            return None
        blocked = [i for i in self.occupant if i != a.index]
        path = self._search.path(a.index, goal, blocked, len(a.path) + 2 * self.settings.patience)
        if not path:
            return None
        if a.mode in (RETURNING, HOMING):
            affordable = self._alive.can_afford_home_after(a, len(path))
        else:
            affordable = self._alive.can_afford(a, len(path), goal)
        return path if affordable else None

    # -- who goes first -------------------------------------------------------------

    def _kept_waiting_for(self, index: int) -> bool:
        """Is an agent going home held up beside ``index``, waiting to step into it?

        Then the cell is left to it: where a queue going out meets one coming
        home (the mouth of a passage at the charger), the agents going out
        would otherwise take every cell the one going home waits for, one after
        another, for ever.
        """
        if self.long_wait > 0 and not self._held_up:
            return False  # nobody has waited that long
        for c in self.agents_beside(index):
            if self.long_held_up_going_home(c) and c.path and c.path[0] == index:
                return True
        return False

    def long_held_up_going_home(self, a: AgentRecord) -> bool:
        return a.mode in HOMEWARD and a.waited >= self.long_wait

    def agents_beside(self, index: int) -> Iterator[AgentRecord]:
        """The agents in the cells next to ``index`` (N, S, E, W)."""
        for s in self.belief.steps:
            c = self._agents.get(self.occupant.get(index + s, -1))
            if c is not None:
                yield c

    def _priority(self, a: AgentRecord) -> tuple[int, int]:
        return (_PRIORITY.get(a.mode, 0), -a.id)

    def _ask_to_make_way(self, a: AgentRecord, blocker: AgentRecord) -> None:
        if blocker.mode == IDLE or self._priority(a) > self._priority(blocker):
            asked = blocker.make_way_for
            # The most urgent request stands (a returning agent before one
            # leaving the charger), or the two can undo each other for ever.
            if asked is None or self._priority(a) > self._priority(self._agents[asked]):
                blocker.make_way_for = a.id
