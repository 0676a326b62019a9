"""The planner shared by every vehicle task, and what the operator sees of each vehicle.

The planner is synchronous and may take a while (a long search on a large
map, numba compiling a kernel): its decisions and observations run in a
worker thread, one at a time under a lock, so that the event loop keeps
every link's heartbeat and telemetry going whatever the planner does.
Everything else (the record, the mission log, the operator's messages)
happens on the event loop, under the same lock, so the log is only ever
written from one thread. Reads of the planner's state that must be
consistent (a way home) go through ``reading()``. ``SharedPlanner`` wraps
the ``Coordinator`` to do what must happen on every call: record the run,
write the mission log, pass planner events on as operator messages, and
wake the vehicles that wait for something to change (``ChangeSignal``)
whenever a vehicle observes, its mode changes or one is lost.
"""

from __future__ import annotations

import asyncio
import contextlib
import time
from collections.abc import AsyncIterator, Callable, Mapping
from dataclasses import dataclass
from enum import StrEnum
from typing import Any, TypeVar

from core.cells import Cell, CellState, Direction
from core.clocks import Clock
from gcs.live.record import MissionRecord
from gcs.log.mission_log import GeoFix, MissionLog
from planner.agent import WAIT, Action, ActionKind, AgentMode, EventKind, PlannerEvent
from planner.coordinator import Coordinator

_T = TypeVar("_T")


async def _in_thread(fn: Callable[..., _T], *args: Any) -> _T:
    """``fn(*args)`` in a worker thread. Cancelled meanwhile, it still waits for the call
    to end before it lets the cancellation through: the caller's lock must not be
    released while the planner is still at work."""
    future = asyncio.get_running_loop().run_in_executor(None, fn, *args)
    try:
        return await asyncio.shield(future)
    except asyncio.CancelledError:
        with contextlib.suppress(BaseException):
            await future
        raise


class ChangeSignal:
    """Wakes every waiter at the next ``notify``. A waiter that starts waiting right
    after its decision (no ``await`` in between) cannot miss a change."""

    def __init__(self) -> None:
        self._event = asyncio.Event()

    def notify(self) -> None:
        self._event.set()
        self._event = asyncio.Event()

    async def wait(self, timeout_real_s: float) -> bool:
        """True if something changed, False on timeout."""
        event = self._event
        with contextlib.suppress(TimeoutError):
            async with asyncio.timeout(timeout_real_s):
                await event.wait()
                return True
        return False


class Phase(StrEnum):
    """What the ground station is doing with a vehicle (shown to the operator)."""

    CONNECTING = "connecting"
    READY = "ready"
    TAKING_OFF = "taking off"
    MOVING = "moving"
    SENSING = "sensing"
    FLYING_HOME = "flying home (AUTO)"
    WAITING = "waiting"
    PARKING = "parking"
    CHARGING = "charging"
    LINK_LOST = "link lost"
    LOST = "lost"
    DONE = "done"
    ABORTED = "aborted"


@dataclass
class VehicleView:
    """One vehicle as the display shows it."""

    sysid: int
    kind: str
    phase: Phase = Phase.CONNECTING
    mode: str = ""
    #: What the vehicle is waiting for or doing in its phase (e.g. "GPS fix"), if anything.
    detail: str = ""
    cell: Cell | None = None
    battery_pct: float | None = None
    energy_pct_per_m: float | None = None
    charges: int = 0


class Level(StrEnum):
    INFO = "info"
    WARNING = "warning"
    ERROR = "error"


Notify = Callable[[str, Level, int | None], None]

_EVENT_TEXT = {
    EventKind.RETURN: "returns to charge from {cell}",
    EventKind.OUT_OF_RANGE: "cell {cell} is out of range",
    EventKind.COVERAGE_COMPLETE: "coverage complete: every vehicle goes home to park",
    EventKind.CUT_OFF: (
        "coverage stopped: what is left lies beyond the lost vehicle at {cell}, out of "
        "reach while it stands there; every vehicle goes home"
    ),
    EventKind.LOST: "declared lost at {cell}",
    EventKind.SAFETY_NET: "no backtracking point left: takes the frontier cell {cell}",
}


class SharedPlanner:
    def __init__(
        self,
        coordinator: Coordinator,
        record: MissionRecord,
        clock: Clock,
        log: MissionLog,
        notify: Notify,
        views: Mapping[int, VehicleView],
        coverage_period_s: float = 2.0,
    ) -> None:
        self.coordinator = coordinator
        self.record = record
        self.clock = clock
        self.log = log
        self.notify = notify
        self.views = views
        self.changed = ChangeSignal()
        #: One planner call at a time; held while it runs in its worker thread.
        self._lock = asyncio.Lock()
        self.planner_s = 0.0
        self.t0 = clock.now()
        self._coverage_period_s = coverage_period_s
        self._next_coverage_t = 0.0
        self._btps: list[Cell] = []
        #: Where each vehicle was last observed, and the cell each one is on its way to.
        self._at: dict[int, Cell] = {}
        self._heading_for: dict[int, Cell] = {}
        #: Moves held back because another vehicle stands on or heads for the cell.
        self.held_back = 0
        #: WAIT decisions (the planner's and held-back moves).
        self.waits = 0
        #: Real seconds from a vehicle's arrival and sensing (telemetry in) to the
        #: guided target of the move decided then (command out): the ground
        #: station's own delay (arrivals followed by a wait are not counted).
        self.decision_latency_s: list[float] = []
        self._observed_at: dict[int, float] = {}

    @property
    def t_s(self) -> float:
        """Mission time (seconds since the start, simulated under a speed-up)."""
        return self.clock.now() - self.t0

    # -- planner calls ---------------------------------------------------------------

    @contextlib.asynccontextmanager
    async def reading(self) -> AsyncIterator[Coordinator]:
        """The coordinator, while no planner call runs (for reads that must agree)."""
        async with self._lock:
            yield self.coordinator

    async def _timed(self, fn: Callable[..., _T], *args: Any) -> _T:
        tick = time.perf_counter()
        try:
            return await _in_thread(fn, *args)
        finally:
            self.planner_s += time.perf_counter() - tick

    async def observe(
        self,
        agent: int,
        cell: Cell,
        readings: Mapping[Direction, CellState],
        battery_pct: float,
        fix: GeoFix | None = None,
    ) -> None:
        async with self._lock:
            self._observed_at[agent] = time.perf_counter()
            before = self.coordinator.mode(agent)
            self._at[agent] = cell
            self._heading_for.pop(agent, None)
            await self._timed(self.coordinator.observe, agent, cell, readings, battery_pct)
            self._observed(agent, cell, battery_pct, before, readings, fix)

    def _observed(
        self,
        agent: int,
        cell: Cell,
        battery_pct: float,
        before: AgentMode,
        readings: Mapping[Direction, CellState],
        fix: GeoFix | None,
    ) -> None:
        self.record.arrived(agent, cell, battery_pct, self.coordinator.belief.covered_count)
        mode = str(self.coordinator.mode(agent))
        self.log.agent_state(self.t_s, agent, cell, battery_pct, mode, fix, readings)
        self._after(agent, before, force_coverage=False)
        self.changed.notify()

    def commanding(self, agent: int) -> None:
        """The next target is about to be sent to ``agent``: time the decision."""
        observed = self._observed_at.pop(agent, None)
        if observed is not None:
            self.decision_latency_s.append(time.perf_counter() - observed)

    async def decide(self, agent: int) -> Action:
        async with self._lock:
            return await self._decide(agent)

    async def _decide(self, agent: int) -> Action:
        coordinator = self.coordinator
        before = coordinator.mode(agent)
        homing = before == AgentMode.HOMING or coordinator.homeward
        action = await self._timed(coordinator.decide, agent)
        if action.kind == ActionKind.MOVE:
            assert action.to is not None
            if self._claimed_by_other(agent, action.to):
                # Never send two vehicles into one cell, whatever the planner says: wait
                # until the other one has arrived (its observe wakes us) and decide again.
                self.held_back += 1
                # Take the reservation back at once (the other vehicle's own arrival
                # claims the cell again; until then this guard keeps it out of reach).
                here = self._at.get(agent, coordinator.cell_of(agent))
                battery = self.record.agents[agent].battery_pct[-1]
                coordinator.observe(agent, here, {}, battery)
                self._after(agent, before, force_coverage=False)
                self.waits += 1
                self._observed_at.pop(agent, None)
                return WAIT
            self._heading_for[agent] = action.to
            self.record.agents[agent].homing = homing
        self._after(agent, before, force_coverage=False)
        if action.kind != ActionKind.MOVE:
            self._observed_at.pop(agent, None)  # a wait is not a delay of ours
        if action.kind == ActionKind.WAIT:
            self.waits += 1
        if coordinator.mode(agent) != before:
            self.changed.notify()
        return action

    def _claimed_by_other(self, agent: int, cell: Cell) -> bool:
        if cell == self.coordinator.belief.charger:
            return False  # a depot: room for everyone
        return self._others_on(agent, cell)

    def _others_on(self, agent: int, cell: Cell) -> bool:
        # Lost vehicles count too: nobody knows where exactly between the two they are.
        return any(
            other != agent
            for other, c in (*self._at.items(), *self._heading_for.items())
            if c == cell
        )

    def clear_for(self, agent: int, cell: Cell) -> bool:
        """Whether ``agent`` may pass through ``cell`` off its planned way (a car backing
        up to line up): free on the planner's map, and no other vehicle on it or bound
        for it (the charger included)."""
        return self.coordinator.belief.is_free(cell) and not self._others_on(agent, cell)

    async def update_battery(self, agent: int, battery_pct: float) -> None:
        async with self._lock:
            self.coordinator.update_battery(agent, battery_pct)

    async def set_energy(self, agent: int, pct_per_m: float) -> None:
        async with self._lock:
            self.coordinator.set_energy_per_m(agent, pct_per_m)
        self.views[agent].energy_pct_per_m = pct_per_m

    async def mark_lost(self, agent: int, why: str) -> None:
        async with self._lock:
            self._mark_lost(agent, why)

    def _mark_lost(self, agent: int, why: str) -> None:
        """Give a vehicle up. If it was on its way to a cell, it is taken to be there: a
        GUIDED target or a mission goes on without the link, so that cell (and the one it
        left, which the planner keeps holding for a lost agent) must stay out of everyone
        else's way."""
        if self.coordinator.mode(agent) == AgentMode.LOST:
            return
        target = self._heading_for.get(agent)
        if target is not None:
            battery = self.record.agents[agent].battery_pct[-1]
            self.coordinator.observe(agent, target, {}, battery)
            why += f"; taken to be at {target}, where it was heading"
        self.coordinator.mark_lost(agent)
        self.record.agents[agent].lost = True
        self.views[agent].phase = Phase.LOST
        text = f"vehicle {agent} lost: {why}; the others carry on"
        self.notify(text, Level.ERROR, agent)
        self.log.event(self.t_s, text, "error", agent)
        self._after(agent, AgentMode.LOST, force_coverage=True)
        self.changed.notify()

    async def recall(self) -> None:
        """Bring every vehicle home under the planner (an abort), and wake those waiting."""
        async with self._lock:
            self.coordinator.recall()
        self.changed.notify()

    def mode(self, agent: int) -> AgentMode:
        return self.coordinator.mode(agent)

    def heading_for(self, agent: int) -> Cell | None:
        """The cell a vehicle was sent to and has not reached yet, if any."""
        return self._heading_for.get(agent)

    @property
    def finished(self) -> bool:
        return self.coordinator.finished

    # -- bookkeeping -----------------------------------------------------------------

    def _after(self, agent: int, before: AgentMode, force_coverage: bool) -> None:
        events = self.coordinator.drain_events()
        t = self.t_s
        self.record.planner_events(events, t)
        for event in events:
            self._tell(event)
        self.views[agent].charges = self.coordinator.charges(agent)
        btps = self.coordinator.btps()
        if btps != self._btps:
            self._btps = btps
            self.log.btps(t, btps)
        if force_coverage or t >= self._next_coverage_t:
            self.write_coverage()

    def write_coverage(self) -> None:
        belief = self.coordinator.belief
        self.log.coverage(self.t_s, belief.state_grid(), belief.covered_grid())
        self._next_coverage_t = self.t_s + self._coverage_period_s

    def _tell(self, event: PlannerEvent) -> None:
        text = _EVENT_TEXT.get(event.kind)
        if text is None:
            return
        message = text.format(cell=event.cell)
        who = None if event.agent < 0 else event.agent
        self.log.event(
            self.t_s, message if who is None else f"vehicle {who} {message}", "info", who
        )
        if event.kind in (EventKind.COVERAGE_COMPLETE, EventKind.RETURN):
            self.notify(message if who is None else f"vehicle {who} {message}", Level.INFO, who)
        elif event.kind is EventKind.CUT_OFF:
            self.notify(message, Level.WARNING, None)
