"""One vehicle's task in a live mission: arrive, sense, observe, decide, act; again.

Each vehicle asks the shared planner for its next move when it has arrived
somewhere, at its own pace: no lockstep, so a slow vehicle never holds up
the others. What an action means for a vehicle:

* MOVE: fly to the cell centre in GUIDED, wait for the position telemetry to
  show it there, collect range readings taken after arrival, observe.
  When the planner sends the vehicle home (returning to charge, or homing at
  the end) the whole way home, once it runs over covered cells only, is
  uploaded as a mission and flown in AUTO, so the vehicle gets home even if
  the link drops; the ground station still
  observes each waypoint and asks the planner for the next cell, and stops
  the vehicle (back to stepping in GUIDED) if the planner does not grant it.
* CHARGE: park on the charger (copter lands, rover holds and rolls out, back
  onto the pad if it rolled off, disarm), then charge (``gcs.live.charging``:
  on the telemetry, or timed and told to the autopilot) until the planner
  lets it go.
* WAIT: wait until another vehicle changes something, or a while.

A vehicle whose heartbeat is lost is held out of planning (its task does not
decide) until the link is back; if it does not come back within
``lost_after_s`` the vehicle is declared lost, its work goes back to the
others, and the mission carries on. A vehicle given up for any reason is
put in its safe state (``Pilot.make_safe``) if it can still be heard.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import math
from dataclasses import dataclass, field

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from core.cells import Cell, CellState, Direction, manhattan
from gcs.live.charging import ChargeSettings, PadStay
from gcs.live.energy import EnergyEstimator
from gcs.live.pilot import Pilot, PilotSettings
from gcs.live.sensing import (
    Pose,
    Ray,
    neighbour_states,
    pose_at,
    rays_from_obstacles,
    rays_from_sensors,
    readings_from_map,
    still_between,
)
from gcs.live.shared import Level, Phase, SharedPlanner, VehicleView
from gcs.log.mission_log import GeoFix
from gcs.mission import Sensing, VehicleSpec
from planner.agent import Action, ActionKind, AgentMode
from planner.paths import path_to_charger
from sitl_mock.gridmap import GridMap
from vehicles.errors import LinkError, MissionError
from vehicles.link import LinkEvent, VehicleLink
from vehicles.telemetry import Battery, Position, Topic

log = logging.getLogger(__name__)

_FOREVER_S = 1e9
#: Range readings asked for again at most this often when the vehicle turned while taking them.
SENSING_TRIES = 4
_WARNING_SEVERITY = mavlink.MAV_SEVERITY_WARNING
_ERROR_SEVERITY = mavlink.MAV_SEVERITY_ERROR


def log_level(severity: int) -> str:
    """The mission log's level (``gcs.log.topics.LOG_LEVELS``) of a STATUSTEXT severity:
    EMERGENCY, ALERT and CRITICAL are fatal, ERROR an error, WARNING a warning, NOTICE
    and INFO information, DEBUG debug."""
    if severity <= mavlink.MAV_SEVERITY_CRITICAL:
        return "fatal"
    if severity == _ERROR_SEVERITY:
        return "error"
    if severity == _WARNING_SEVERITY:
        return "warning"
    return "debug" if severity >= mavlink.MAV_SEVERITY_DEBUG else "info"


def announce(
    planner: SharedPlanner,
    text: str,
    level: Level = Level.INFO,
    sysid: int | None = None,
    log_as: str | None = None,
) -> None:
    """Show ``text`` to the operator and write it in the mission log, at the same mission
    time: the one way a mission event reaches both, so that what the screen said can be
    found in the log (Foxglove's Log panel). ``log_as``: the log's level when finer than
    the screen's (a vehicle's CRITICAL is fatal there). Nothing is awaited: the display
    prints a line, the log adds a message to its buffer (written out at most once a
    second, and never again once it failed)."""
    planner.notify(text, level, sysid)
    planner.log.event(planner.t_s, text, log_as or level.value, sysid)


@dataclass(frozen=True)
class AgentSettings:
    """Times are mission seconds."""

    #: A waiting vehicle decides again at least this often, even if nothing changed.
    wait_recheck_s: float = 5.0
    #: A vehicle whose link stays lost this long is declared lost.
    lost_after_s: float = 30.0
    #: Longest wait for a battery update while charging.
    charge_poll_s: float = 10.0
    #: Fly the way home as an AUTO mission (survives a lost link); else step in GUIDED.
    auto_return: bool = True
    #: Shorter ways home are simply stepped.
    min_auto_cells: int = 3
    #: Failed actions in a row (with the link up) before a vehicle is given up.
    max_failures: int = 6
    #: Longest wait for a vehicle given up to reach its safe state (mission seconds).
    safe_state_s: float = 60.0
    #: A vehicle's text is told to the operator again only after this many mission seconds.
    repeat_text_s: float = 30.0
    pilot: PilotSettings = field(default_factory=PilotSettings)
    charge: ChargeSettings = field(default_factory=ChargeSettings)


class AgentLost(Exception):
    """The vehicle cannot be worked with any more (link gone, or it keeps failing)."""


def describe(exc: BaseException) -> str:
    """What went wrong, never an empty string (``str(TimeoutError())`` is "")."""
    return str(exc) or type(exc).__name__


class Agent:
    def __init__(
        self,
        spec: VehicleSpec,
        link: VehicleLink,
        pilot: Pilot,
        planner: SharedPlanner,
        estimator: EnergyEstimator,
        view: VehicleView,
        grid: GridMap,
        settings: AgentSettings | None = None,
    ) -> None:
        self.spec = spec
        self.id = spec.sysid
        self.link = link
        self.pilot = pilot
        # A car lining up backs only into cells clear of walls and of other vehicles.
        pilot.may_enter = lambda cell: planner.clear_for(spec.sysid, cell)
        self.planner = planner
        self.estimator = estimator
        self.view = view
        self.grid = grid
        self.settings = settings or AgentSettings()
        self._odometer_m = 0.0
        #: The distance the planner counts (a cell size per move), and how much of it the
        #: energy estimate has been given.
        self._planned_m = 0.0
        self._estimated_m = 0.0
        self._last_cell: Cell | None = None
        self._lost_reason: str | None = None
        #: The way home failed to upload on this trip: step it instead.
        self._step_home = False
        #: The stay on the pad under way, if charging.
        self._pad: PadStay | None = None
        #: The battery telemetry rose while on the pad (it charges itself).
        self._pad_risen = False
        self._helpers: list[asyncio.Task[None]] = []

    @property
    def charger(self) -> Cell:
        return self.planner.coordinator.belief.charger

    def _tell(self, text: str, level: Level = Level.INFO, log_as: str | None = None) -> None:
        announce(self.planner, f"vehicle {self.id} {text}", level, self.id, log_as)

    @property
    def _moves(self) -> str:
        """How the vehicle goes: a copter flies, a rover drives."""
        return "flies" if self.pilot.flies else "drives"

    # -- the task ------------------------------------------------------------------------

    async def run(self) -> None:
        """Work until the planner says done, or the vehicle is lost."""
        main = asyncio.current_task()
        assert main is not None
        self._helpers = [
            asyncio.ensure_future(self._watch_link(main)),
            asyncio.ensure_future(self._track_odometer()),
            asyncio.ensure_future(self._track_battery()),
            asyncio.ensure_future(self._relay_statustext()),
        ]
        lost: str | None = None
        try:
            await self._work()
        except asyncio.CancelledError:
            if self._lost_reason is None:
                raise
            lost = self._lost_reason
        except AgentLost as exc:
            lost = str(exc)
        except Exception as exc:  # a bug must not take the fleet down with it
            log.exception("vehicle %d task failed", self.id)
            lost = f"internal error: {exc!r}"
        try:
            if lost is not None:
                try:
                    await self.planner.mark_lost(self.id, lost)
                except Exception:  # the planner broken too: the vehicle is made safe anyway
                    log.exception("vehicle %d: the planner could not record the loss", self.id)
                await self._make_safe()
        finally:
            for task in self._helpers:
                task.cancel()
            await asyncio.gather(*self._helpers, return_exceptions=True)

    async def _make_safe(self) -> None:
        """A vehicle given up is left in its safe state if it can be reached at all (the
        link may be down for good: then its own failsafe is all there is)."""
        self.view.phase = Phase.LOST
        try:
            async with asyncio.timeout(self.pilot.real_s(self.settings.safe_state_s)):
                done = await self.pilot.make_safe()
        except (LinkError, TimeoutError) as exc:
            heard = "link down" if not self.link.is_up else describe(exc)
            self._tell(
                f"could not be put in its safe state ({heard}): left to its own failsafe",
                Level.ERROR,
            )
            return
        self._tell(f"given up: {done}", Level.WARNING)

    async def _work(self) -> None:
        await self.pilot.wait_position(lambda _p: True, self.settings.pilot.sensing_timeout_s)
        await self._resync()  # on the charger, or wherever a resumed mission finds it
        action: Action | None = None
        failures = 0
        while True:
            await self._link_up()
            current = action if action is not None else await self._decide()
            action = current  # tried again as it is if it fails with the link down
            try:
                if current.kind == ActionKind.WAIT and self.planner.mode(self.id) in (
                    AgentMode.DONE,
                    AgentMode.LOST,
                ):
                    await self._finish()
                    return
                action = await self._execute(current)
                failures = 0
            except (LinkError, TimeoutError) as exc:
                failures += 1
                if failures >= self.settings.max_failures:
                    raise AgentLost(f"failed {failures} times in a row ({describe(exc)})") from exc
                self._tell(f"{current.kind} failed ({describe(exc)})", Level.WARNING)
                if not self.link.is_up:
                    continue  # the same action again once the link is back
                with contextlib.suppress(LinkError, TimeoutError):
                    await self._resync()
                    action = None

    async def _decide(self) -> Action:
        battery = self.pilot.battery_pct
        if battery is not None:
            await self.planner.update_battery(self.id, battery)
        await self.planner.set_energy(self.id, self.estimator.estimate_pct_per_m)
        action = await self.planner.decide(self.id)
        self.view.mode = str(self.planner.mode(self.id))
        return action

    async def _execute(self, action: Action) -> Action | None:
        """Carry out an action; returns a follow-up action already decided, or None."""
        if action.kind != ActionKind.CHARGE:
            self._charge_ended()
        if action.kind == ActionKind.WAIT:
            self.estimator.pause()  # until it moves or charges again: not per metre
        else:
            self.estimator.resume()
        if action.kind == ActionKind.MOVE:
            assert action.to is not None
            mode = self.planner.mode(self.id)
            if (
                self.settings.auto_return
                and mode in (AgentMode.RETURN, AgentMode.HOMING)
                and not self._step_home
            ):
                async with self.planner.reading():
                    cells = self._way_home(action.to)
                    swept = self._swept(cells)
                if len(cells) >= self.settings.min_auto_cells and swept:
                    try:
                        return await self._fly_home(cells)
                    except MissionError as exc:
                        # A link too lossy for the upload: step home in GUIDED this time
                        # rather than try again while the battery runs down.
                        self._tell(f"steps home in GUIDED: the way home did not upload ({exc})")
                        self._step_home = True
                        await self._resync()
                        return None
                    except (LinkError, TimeoutError):
                        # The vehicle did not follow the route (a waypoint it could not
                        # make): the rest of this trip is stepped, cell by cell.
                        self._step_home = True
                        raise
            await self._step(action.to)
            return None
        if action.kind == ActionKind.CHARGE:
            self._step_home = False
            await self._charge()
            return None
        await self._wait()
        return None

    # -- link, odometer, battery -----------------------------------------------------------

    async def _watch_link(self, main: asyncio.Task[None]) -> None:
        """Hold the vehicle out of planning while its link is lost; give it up after
        ``lost_after_s``."""
        events = self.link.stream(Topic.LINK)
        try:
            async for event in events:
                if event != LinkEvent.LOST:
                    continue
                before = self.view.phase
                self.view.phase = Phase.LINK_LOST
                lost_at = self.pilot.clock.now()
                self._tell(
                    f"link lost: held out of planning (declared lost after "
                    f"{self.settings.lost_after_s:g} s)",
                    Level.WARNING,
                )
                try:
                    await self.link.wait_for(
                        Topic.LINK,
                        lambda e: e == LinkEvent.UP,
                        self.pilot.real_s(self.settings.lost_after_s),
                    )
                except TimeoutError:
                    self._lost_reason = f"no heartbeat for {self.settings.lost_after_s:g} s"
                    main.cancel()
                    return
                self.view.phase = before
                self._tell(f"link is back after {self._since(lost_at)}{self._mode_now()}")
        finally:
            await events.aclose()

    def _since(self, then: float) -> str:
        return f"{self.pilot.clock.now() - then:.0f} s"

    def _mode_now(self) -> str:
        """``; in HOLD, armed``: what the vehicle is in, as its heartbeat says (its own
        failsafe may have changed it while the link was down)."""
        status = self.link.status
        if status is None:
            return ""
        return f"; in {status.mode_name}, {'armed' if status.armed else 'disarmed'}"

    async def _link_up(self) -> None:
        if not self.link.is_up:
            # No timeout of our own: the link watcher gives the vehicle up in time.
            await self.link.wait_for(Topic.LINK, lambda e: e == LinkEvent.UP, _FOREVER_S)

    async def _track_odometer(self) -> None:
        """Horizontal distance travelled, from the position telemetry."""
        last: Position | None = None
        geo = self.pilot.geo
        positions = self.link.stream(Topic.POSITION)
        try:
            async for pos in positions:
                if last is not None:
                    n0, e0 = geo.geo_to_local(last.lat_deg, last.lon_deg)
                    n1, e1 = geo.geo_to_local(pos.lat_deg, pos.lon_deg)
                    step = math.hypot(n1 - n0, e1 - e0)
                    if step > 0.01:  # below GPS jitter and rounding
                        self._odometer_m += step
                last = pos
        finally:
            await positions.aclose()

    async def _track_battery(self) -> None:
        """Feed the energy estimate with each battery update and the distance since, as
        the planner counts it (a cell size per move): the planner budgets every way home
        in those metres, so whatever a vehicle spends beyond them on its way (a car
        backing up to line up) must be in the rate per metre. What it uses while it waits
        is not (``EnergyEstimator.pause``)."""
        updates = self.link.stream(Topic.BATTERY)
        try:
            async for battery in updates:
                assert isinstance(battery, Battery)
                if battery.remaining_pct is None:
                    continue
                moved = self._planned_m - self._estimated_m
                self._estimated_m = self._planned_m
                self.estimator.add(moved, battery.remaining_pct)
                self.view.battery_pct = battery.remaining_pct
                self.planner.record.agents[self.id].odometer_m = self._odometer_m
        finally:
            await updates.aclose()

    async def _relay_statustext(self) -> None:
        """What the vehicle says (STATUSTEXT), as ``vehicle N says: ...``. Every text goes
        to the mission log at its severity (``log_level``). The operator is shown its
        warnings and worse, and whatever it says of a failsafe (ArduPilot Rover clears
        its GCS failsafe at INFO), each text once per ``repeat_text_s`` (ArduPilot
        repeats its pre-arm refusals every time arming is retried)."""
        texts = self.link.stream(Topic.STATUSTEXT)
        told: dict[str, float] = {}
        clock = self.pilot.clock
        try:
            async for text in texts:
                said = f"vehicle {self.id} says: {text.text}"
                shown = text.severity <= _WARNING_SEVERITY or "failsafe" in text.text.lower()
                now = clock.now()
                if shown and now - told.get(text.text, -math.inf) >= self.settings.repeat_text_s:
                    told[text.text] = now
                    if text.severity <= _ERROR_SEVERITY:
                        level = Level.ERROR
                    elif text.severity == _WARNING_SEVERITY:
                        level = Level.WARNING
                    else:
                        level = Level.INFO
                    announce(self.planner, said, level, self.id, log_level(text.severity))
                else:
                    planner = self.planner
                    planner.log.event(planner.t_s, said, log_level(text.severity), self.id)
        finally:
            await texts.aclose()

    # -- actions -----------------------------------------------------------------------------

    async def _step(self, to: Cell) -> None:
        if not (self.pilot.airborne() or (not self.pilot.flies and self.pilot.armed)):
            self.view.phase = Phase.TAKING_OFF
        await self.pilot.underway()
        self.view.phase = Phase.MOVING
        self.planner.commanding(self.id)
        pos = await self.pilot.goto(to)
        await self._arrive(to, pos)

    async def _arrive(self, cell: Cell, pos: Position) -> None:
        self.view.phase = Phase.SENSING
        if self.spec.sensing == Sensing.RANGE and not self.pilot.stopped(pos):
            # Arrived on the vehicle's word while it still brakes: ranges taken on the
            # move are read from a place known only to a tenth of a cell or so.
            pos = await self.pilot.wait_stopped(self.settings.pilot.manoeuvre_timeout_s)
        readings = await self._sense(cell, pos)
        await self._observe(cell, pos, readings)

    async def _observe(
        self, cell: Cell, pos: Position, readings: dict[Direction, CellState]
    ) -> None:
        battery = self.pilot.battery_pct
        battery = 100.0 if battery is None else battery
        if self._last_cell is not None:
            self._planned_m += manhattan(self._last_cell, cell) * self.pilot.geo.cell_size_m
        self._last_cell = cell
        self.view.cell = cell
        self.view.battery_pct = battery
        fix = GeoFix(pos.lat_deg, pos.lon_deg, pos.heading_deg)
        await self.planner.observe(self.id, cell, readings, battery, fix)

    async def _sense(self, cell: Cell, pos: Position) -> dict[Direction, CellState]:
        if self.spec.sensing == Sensing.MAP:
            return readings_from_map(self.grid, cell)
        pilot = self.pilot
        for _ in range(SENSING_TRIES):
            ranges, obstacles = await pilot.ranges_since(pos.time_boot_ms)
            taken = [r.time_boot_ms for r in ranges.values()]
            if obstacles is not None:
                taken.append(obstacles.time_usec // 1000)
            if not taken:
                return {}
            # A reading is placed between the positions reported before and after it; a
            # vehicle that turned in between (braking rovers swing) measured from a pose
            # not known well enough, and is read again.
            after = await pilot.position_after(max(taken))
            before, pose_after = pilot.pose_of(pos), pilot.pose_of(after)
            if before is None or pose_after is None:
                return {}  # no heading: the rays cannot be pointed
            if not still_between(before, pose_after):
                pos = after
                continue
            rays: list[Ray] = []
            for orientation, reading in ranges.items():
                heading, at = self._sensor_pose(cell, before, pose_after, reading.time_boot_ms)
                rays += rays_from_sensors(heading, {orientation: reading}, at)
            if obstacles is not None:
                heading, at = self._sensor_pose(
                    cell, before, pose_after, obstacles.time_usec // 1000
                )
                rays += rays_from_obstacles(heading, obstacles, at)
            return neighbour_states(rays, pilot.geo.cell_size_m)
        return {}  # never still while it measured: nothing is said of the neighbours

    def _sensor_pose(
        self, cell: Cell, before: Pose, after: Pose, at_ms: int
    ) -> tuple[float, tuple[float, float]]:
        """The heading and the place (cells east and north of ``cell``'s centre) of the
        vehicle at ``at_ms``, between two reported poses."""
        pose = pose_at(before, after, at_ms)
        centre_n, centre_e = self.pilot.geo.cell_centre_local(cell)
        size = self.pilot.geo.cell_size_m
        return pose.heading_deg, ((pose.east_m - centre_e) / size, (pose.north_m - centre_n) / size)

    def _swept(self, cells: list[Cell]) -> bool:
        """Every cell already covered. Flown over in AUTO, a cell is observed without
        sensing; a covered cell must have been sensed from (the planner finds what lies
        beyond it from there, and a resumed mission rebuilds the map on it), so a way
        home over cells not yet covered is stepped, sensing each, until it is not."""
        belief = self.planner.coordinator.belief
        return all(belief.is_covered(cell) for cell in cells)

    def _way_home(self, first: Cell) -> list[Cell]:
        """The planner's own way home from ``first`` (the move just granted): the route
        flown must be the one it grants cell by cell, or the vehicle is stopped at the
        first waypoint where the two part (a shortest way home changes as the map grows)."""
        coordinator = self.planner.coordinator
        planned = coordinator.planned_path(self.id)
        if planned and planned[-1] == self.charger:
            return [first, *planned]
        belief = coordinator.belief
        rest = path_to_charger(belief, belief.index(first)) or []
        return [first, *(belief.cell(i) for i in rest)]

    async def _fly_home(self, cells: list[Cell]) -> Action | None:
        """Fly ``cells`` (the last one the charger) as an AUTO mission, observing each
        waypoint and asking the planner for the next cell; stop and hand back to
        stepping when the planner does not grant it."""
        await self.pilot.underway()
        if self.pilot.car:
            await self.pilot.line_up(cells[0])
        route = await self.pilot.start_route(cells, land=True)
        self.view.phase = Phase.FLYING_HOME
        if route.uploaded:
            self._tell(f"{self._moves} {len(cells)} cells home in AUTO")
        else:
            self._tell(f"{self._moves} on home in AUTO ({len(cells)} cells, the route on board)")
        first_seq = route.first_seq
        previous = self.planner.coordinator.cell_of(self.id)
        heading = None
        start = self.pilot.position
        for k, cell in enumerate(cells):
            seq = first_seq + k

            def reached(p: Position, cell: Cell = cell, seq: int = seq) -> bool:
                current = self.pilot.mission_seq()
                return self.pilot.at(p, cell) or (current is not None and current > seq)

            metres = self.pilot.geo.cell_size_m * max(1, manhattan(previous, cell))
            leg = (cell[0] - previous[0], cell[1] - previous[1])
            if heading is None:  # the first waypoint: from where the vehicle faces
                turn = self.pilot.turn_to_deg(start, *self.pilot.geo.cell_centre(cell))
            elif leg == heading:
                turn = 0.0
            else:
                turn = 180.0 if leg == (-heading[0], -heading[1]) else 90.0
            heading = leg
            pos = await self.pilot.wait_position(
                reached,
                self.pilot.move_time_s(metres, turn) + self.settings.pilot.waypoint_hold_s,
                f"arrival at waypoint {seq} (cell {cell})",
            )
            previous = cell
            # No fresh ranges here: the vehicle does not stop long enough, and the way
            # home runs over cells already known.
            await self._observe(cell, pos, {})
            if k == len(cells) - 1:
                return None  # home: the mission lands a copter; CHARGE parks it
            action = await self._decide()
            if action.kind == ActionKind.MOVE and action.to == cells[k + 1]:
                continue
            # The planner does not grant the next cell (another vehicle in the way): stop.
            self.view.phase = Phase.MOVING
            pos = await self.pilot.stop_here()
            actual = self.pilot.cell_of(pos)
            if actual != cell:
                await self._observe(actual, pos, {})
                return None
            return action
        return None

    async def _charge(self) -> None:
        """Park on the pad, then charge: wait on the battery telemetry, or, where the
        autopilot cannot see the charge, time it and tell the autopilot when it is done
        (``gcs.live.charging``); a charge far overdue gives the vehicle up."""
        if self.pilot.armed or self.pilot.airborne():
            self.view.phase = Phase.PARKING
            await self.pilot.park(self.charger)
        self.view.phase = Phase.CHARGING
        clock = self.pilot.clock
        battery = self.pilot.battery_pct
        if self._pad is None:
            start = 0.0 if battery is None else battery
            self._pad = PadStay(
                started_s=clock.now(),
                start_pct=start,
                target_pct=self.planner.coordinator.settings.resume_pct,
                rate_pct_s=self.spec.charge_rate_pct_s,
                how=self.spec.charging,
            )
            self._pad_risen = False
            self._tell(
                f"charging from {start:.0f} % to {self._pad.target_pct:.0f} % "
                f"(about {self._pad.expected_s:.0f} s)"
            )
        stay = self._pad
        update = await self.link.wait_for(
            Topic.BATTERY,
            lambda b: b.remaining_pct is not None,
            self.pilot.real_s(self.settings.charge_poll_s),
        )
        pct = update.remaining_pct
        self._pad_risen |= stay.rises(pct)
        now = clock.now()
        self.view.detail = f"{stay.estimate_pct(now):.0f} % by the pad's rate"
        if stay.needs_reset(now, pct, self._pad_risen):
            pct = await self._reset_battery(stay.target_pct)
        elif stay.overdue(now, self.settings.charge) and pct < stay.target_pct - 1.0:
            raise AgentLost(
                f"its charge did not complete: {pct:.0f} % after "
                f"{now - stay.started_s:.0f} s on the pad, {stay.limit_s(self.settings.charge):.0f}"
                " s allowed"
            )
        self.view.detail = ""
        await self.planner.update_battery(self.id, pct)
        self.planner.record.battery(self.id, self.charger, pct)

    async def _reset_battery(self, pct: float) -> float:
        """MAV_CMD_BATTERY_RESET (battery 0 to ``pct``); the telemetry must then show it."""
        await self.link.command_long(mavlink.MAV_CMD_BATTERY_RESET, 1, pct)
        try:
            update = await self.link.wait_for(
                Topic.BATTERY,
                lambda b: b.remaining_pct is not None and b.remaining_pct >= pct - 1.0,
                self.pilot.real_s(self.settings.charge.reset_confirm_s),
            )
        except TimeoutError:
            raise LinkError(
                f"the battery telemetry does not show the reset to {pct:.0f} %"
            ) from None
        self._tell(f"told its autopilot the battery is at {pct:.0f} % (MAV_CMD_BATTERY_RESET)")
        return float(update.remaining_pct)

    def _charge_ended(self) -> None:
        """The planner no longer has the vehicle charge: say how the stay on the pad ended."""
        stay, self._pad = self._pad, None
        if stay is None:
            return
        pct = self.pilot.battery_pct
        on_pad = f"{self._since(stay.started_s)} on the pad"
        if pct is not None and pct < stay.target_pct - 1.0:
            # Coverage complete (or an abort) mid-charge: no more charge is needed.
            self._tell(f"stops charging at {pct:.0f} % ({on_pad}): no more charge is needed")
            return
        level = "" if pct is None else f" to {pct:.0f} %"
        self._tell(f"charged{level} ({on_pad})")

    async def _wait(self) -> None:
        if self.planner.coordinator.cell_of(self.id) == self.charger and (
            self.pilot.armed or self.pilot.airborne()
        ):
            self.view.phase = Phase.PARKING
            await self.pilot.park(self.charger)  # nothing to do: wait on the ground, disarmed
        self.view.phase = Phase.WAITING
        # Decide again at the first change after one move's time (the planner counts its
        # patience in decisions, as if each were an iteration in which others move once),
        # or after ``wait_recheck_s`` in any case.
        clock = self.pilot.clock
        start = clock.now()
        pace = self.pilot.geo.cell_size_m / self.pilot.speed_m_s
        changed = False
        while True:
            waited = clock.now() - start
            left = self.settings.wait_recheck_s - waited
            if left <= 0 or (changed and waited >= pace):
                return
            timeout = min(left, pace - waited) if changed else left
            changed |= await self.planner.changed.wait(clock.to_real(max(timeout, 0.0)))

    async def _finish(self) -> None:
        self._charge_ended()
        if self.planner.mode(self.id) == AgentMode.DONE:
            self.view.phase = Phase.PARKING
            cell = self.planner.coordinator.cell_of(self.id)
            await self.pilot.park(cell)
            self.view.phase = Phase.DONE
            if cell == self.charger:
                self._tell("is home, parked and disarmed")
            else:
                self._tell(f"is walled in at {cell}, no way home: parked there", Level.WARNING)

    async def _resync(self) -> None:
        """After a failed action: settle where the vehicle really is and tell the planner."""
        pos = self.pilot.position
        if pos is None:
            raise LinkError("no position")
        if self.pilot.airborne(pos) or (not self.pilot.flies and self.pilot.armed):
            pos = await self.pilot.stop_here()
        cell = self.pilot.cell_of(pos)
        await self._arrive(cell, pos)


async def send_home(agent: Agent, timeout_s: float) -> str:
    """After an abort: send the vehicle to the charger in AUTO, or hold it where it is.
    Returns what was done, for the operator."""
    pilot = agent.pilot
    if not agent.link.is_up:
        return "link down: left as it is"
    pos = pilot.position
    try:
        if pos is None:
            raise LinkError("no position")
        cell = pilot.cell_of(pos)
        belief = agent.planner.coordinator.belief
        if cell == agent.charger:
            await pilot.park(agent.charger)
            return "parked on the charger"
        if not belief.is_free(cell):
            cell = agent.planner.coordinator.cell_of(agent.id)
        rest = path_to_charger(belief, belief.index(cell))
        if rest is None:
            raise LinkError("no known way home")
        cells = [cell, *(belief.cell(i) for i in rest)]
        if pilot.flies and not pilot.airborne(pos):
            return f"{await pilot.make_safe()} where it is"
        await pilot.start_route(cells, land=True)
        with contextlib.suppress(TimeoutError):
            await pilot.wait_position(
                lambda p: pilot.at(p, agent.charger) or (pilot.flies and p.alt_rel_m < 0.2),
                timeout_s,
            )
            await pilot.park(agent.charger)
            return f"{'flew' if pilot.flies else 'drove'} home and parked"
        return f"{'flying' if pilot.flies else 'driving'} home in AUTO"
    except (LinkError, TimeoutError) as exc:
        with contextlib.suppress(LinkError, TimeoutError):
            return f"could not send home ({describe(exc)}): {await pilot.make_safe()}"
        return f"could not send home or make safe ({describe(exc)})"
