"""Stepping aside for an agent that asked (``Traffic`` asks, ``GiveWay`` answers).

Where two queues meet in a narrow passage, stepping aside one by one can go on
for ever. What drains a jam is that agents going home walk down the distance
field to a pad with room for all, so they never wait on each other in a
circle: they are not pushed aside, and an agent in the way of one long held
up, or boxed in, or too low on battery to step aside, goes home with them.
"""

from __future__ import annotations

from core.cells import CellState, manhattan
from planner.agent import DONE, HOMEWARD, LOST, Action, AgentRecord, Fleet
from planner.belief import MapBelief
from planner.settings import PlannerSettings
from planner.staying_alive import StayingAlive
from planner.traffic import Traffic

_FREE = int(CellState.FREE)


class GiveWay:
    """An agent's answer to a request to make way, and its wait aside afterwards."""

    def __init__(
        self,
        *,
        belief: MapBelief,
        settings: PlannerSettings,
        agents: Fleet,
        traffic: Traffic,
        alive: StayingAlive,
    ) -> None:
        self.belief = belief
        self.settings = settings
        self._agents = agents
        self._traffic = traffic
        self._alive = alive

    def answer(self, b: AgentRecord) -> Action | None:
        """Step aside for the agent that asked, if it still needs this cell (None: the
        agent decides as if not asked)."""
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
        if pushed and b.mode in HOMEWARD:
            # Agents going home walk down the distance field to a pad with room
            # for all, so they never wait on each other in a circle: one waits
            # for those ahead, not steps aside for a queue's push (in a crowd
            # before the charger's door, pushes went round and round).
            return None
        if b.mode in HOMEWARD and b.letting_pass is not None:
            # Asked again while aside: a step on home frees the cell as well. Else
            # it may be asked back by the next agent, and pace between two cells
            # for ever (a queue at the charger's door).
            on = self._free_step_home(b)
            if on is not None:
                b.letting_pass = None
                b.path.clear()
                return self._traffic.move(b, on)
        if self._traffic.long_held_up_going_home(a) and b.mode not in HOMEWARD:
            # Stepping aside has long not let it through: in a passage two cells
            # wide the cell aside is the other lane of the queue coming home, and
            # the two lanes take turns at asking, so that the agent paces between
            # them for ever. It goes home with the queue instead (below).
            return self._traffic.go_charge(b)
        return self._step_aside(b, a)

    def _step_aside(self, b: AgentRecord, a: AgentRecord) -> Action | None:
        """Move ``b`` to a free cell beside it, off ``a``'s way if it can and far from
        ``a``; boxed in, go home or pass the request on."""
        belief, occupant = self.belief, self._traffic.occupant
        ahead = set(a.path)
        best: tuple[tuple[bool, int], int] | None = None
        too_far = False  # a cell to step aside to, but not one the battery allows
        for s in belief.steps:
            v = b.index + s
            if (
                belief.state[v] != _FREE
                or (v == a.index and v != belief.charger_index)  # the depot has room
                or v in occupant
            ):
                continue
            if not self._alive.can_afford(b, 1, v):
                too_far = True
                continue
            key = (v not in ahead, manhattan(belief.cell(v), belief.cell(a.index)))
            if best is None or key > best[0]:
                best = (key, v)
        if best is None:
            return self._boxed_in(b, a, too_far)
        b.path.clear()
        b.letting_pass = (a.id, b.index, 4 * self.settings.patience)
        return self._traffic.move(b, best[1])

    def _boxed_in(self, b: AgentRecord, a: AgentRecord, too_far: bool) -> Action | None:
        if b.mode not in HOMEWARD and (too_far or a.mode in HOMEWARD):
            # Boxed in on the way of an agent going home: a queue meets it head
            # on in a narrow passage, and stepping aside one by one only lets
            # the queue close up again. The queue turns and goes home too:
            # everyone going home walks towards the charger, which has room
            # for all, so the passage drains. So too when the only cell aside
            # is farther than the battery allows: it soon must go home anyway,
            # and those between it and the charger are then on its way home.
            return self._traffic.go_charge(b)
        # Boxed in (a queue in a corridor): pass the request on to the agents
        # around, so that the queue backs off from its free end.
        for c in self._traffic.agents_beside(b.index):
            if c is not a and c.make_way_for is None:
                c.make_way_for, c.pushed = b.id, True
        return None

    def _free_step_home(self, a: AgentRecord) -> int | None:
        """A cell one move nearer the charger that the agent can step into now."""
        dist = self.belief.charger_dist
        nearer = dist[a.index] - 1
        occupant = self._traffic.occupant
        for s in self.belief.steps:
            v = a.index + s
            if dist[v] == nearer and occupant.get(v, a.id) == a.id:
                return v
        return None

    def still_letting_pass(self, b: AgentRecord) -> bool:
        """Stay aside until the agent let through has gone past the cell given up."""
        assert b.letting_pass is not None
        agent, cell, left = b.letting_pass
        a = self._agents[agent]
        if left > 0 and a.mode not in (DONE, LOST) and (cell in a.path or a.pending == cell):
            b.letting_pass = (agent, cell, left - 1)
            return True
        b.letting_pass = None
        return False
