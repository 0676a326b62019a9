"""What the coordinator keeps of each agent, and what it tells the outside world.

An agent is in one ``AgentMode`` at a time (the states of the paper's
Algorithm 4, plus those the paper leaves implicit: idle, homing, done, lost).
``decide`` answers with an ``Action``; what happened on the way (a BTP found,
a charge, a loss) is a ``PlannerEvent`` for the logs. ``AgentRecord`` is the
coordinator's record of one agent: where it stands, its battery, its plan and
the bookkeeping of the rules that keep agents apart.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field
from enum import StrEnum
from typing import Final

from core.cells import Cell, Direction
from planner.settings import AgentSpec
from planner.target_search import SearchMemory
from planner.team import Team


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


#: The modes and the move kind as module names, for the decisions: in Python 3.11
#: every look-up of an enum member on its class (``AgentMode.EXPLORE``) goes
#: through ``EnumType.__getattr__``, and each decision makes dozens.
EXPLORING, TRANSIT, RETURNING = AgentMode.EXPLORE, AgentMode.TRANSIT, AgentMode.RETURN
CHARGING, IDLE, HOMING = AgentMode.CHARGE, AgentMode.IDLE, AgentMode.HOMING
DONE, LOST = AgentMode.DONE, AgentMode.LOST
MOVE = ActionKind.MOVE
STOPPED = frozenset({DONE, LOST})
AT_REST = frozenset({DONE, HOMING})  # nothing left to do, unless coverage is incomplete
WORKING = frozenset({EXPLORING, TRANSIT})
HOMEWARD = frozenset({RETURNING, HOMING})


@dataclass
class AgentRecord:
    """The coordinator's record of one agent (``index``: the flat index of its cell)."""

    spec: AgentSpec
    index: int
    team: Team
    slot: int
    #: What the target search keeps of the agent (``TargetSearch.memory``).
    search_memory: SearchMemory
    battery_pct: float = 100.0
    _mode: AgentMode = EXPLORING
    path: deque[int] = field(default_factory=deque)  # remaining moves, next first
    goal: int | None = None
    heading: Direction | None = None
    pending: int | None = None  # reserved target of the move under way
    trailing: int | None = None  # the cell just left, held until the next decision
    #: The cell left on the last move, as a decision starts (``trailing`` before it is
    #: released), and how many moves in a row went straight back into the cell
    #: left the move before: an agent pacing so takes no detour back (``Traffic._blocked``).
    came_from: int | None = None
    turned_back: int = 0
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
    launch_in: int = 0  # decisions to wait on the charger before the first move
    held_backoff: int = 0
    #: Asked to make way by an agent that is itself making way (see ``GiveWay``).
    pushed: bool = False
    #: ``mode in WORKING``, as last written to ``team.working`` (which starts all True).
    _working: bool = True
    id: int = field(init=False)

    def __post_init__(self) -> None:
        self.id = self.spec.id

    @property
    def mode(self) -> AgentMode:
        return self._mode

    @mode.setter
    def mode(self, mode: AgentMode) -> None:
        if (mode == EXPLORING) != (self._mode == EXPLORING):
            self.team.sweeping[self.slot] = mode == EXPLORING
        self._mode = mode
        working = mode in WORKING
        if working != self._working:  # a write to the array costs more than the test
            self._working = working
            self.team.working[self.slot] = working

    def going_to(self, charger: int) -> int | None:
        """The end of the planned path it moves along: its target in transit, the
        charger going home; None while it sweeps, waits or charges."""
        if self._mode in HOMEWARD:
            return charger
        return self.goal if self._mode == TRANSIT else None

    def held_at_launch(self) -> bool:
        """Not its turn to leave the charger yet (``launch_interval``): one decision less."""
        if self.launch_in <= 0:
            return False
        self.launch_in -= 1
        return True

    def left_alone_held(self) -> bool:
        """Held back and idle, and nothing changed for it since its last decision: no
        cell left to release, no launch to wait for, nobody to make way for or let pass
        (``Coordinator._still_held`` asks the rest)."""
        return (
            self.held_for > 0
            and self._mode == IDLE
            and self.trailing is None
            and self.launch_in <= 0
            and self.make_way_for is None
            and self.letting_pass is None
        )

    def begin_charge(self) -> None:
        self.charges += 1
        self.swept = False

    def stand(self, index: int, cell: Cell) -> None:
        """Moved to ``index``; counts the moves in a row back into the cell left before."""
        self.turned_back = self.turned_back + 1 if index == self.came_from else 0
        self.index = index
        self.team.rows[self.slot], self.team.cols[self.slot] = cell


#: The records of the fleet, by agent id.
Fleet = dict[int, AgentRecord]
