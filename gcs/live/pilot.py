"""Flying one vehicle from cell to cell over its ``VehicleLink``: no planner in here.

The pilot knows how to get a rover or a copter going (GUIDED, arm, take off),
to put it on a cell and tell when it is there (inside the cell and stopped,
from its telemetry, never from a sleep), to collect range readings taken
*after* it arrived, to fly a path home as an AUTO mission (which goes on
without us when the link drops), to park it on the charger (land, or stop
and roll out, back onto the pad if it rolled off, disarm), and to put it in
its safe state (``make_safe``) when it is given up.

Every wait is a wait on the vehicle's telemetry with a timeout in mission
time (simulated seconds under a speed-up, converted through the clock).
Operations return normally or raise ``LinkError`` / ``TimeoutError``.
"""

from __future__ import annotations

import asyncio
import contextlib
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from core.cells import Cell
from core.clocks import Clock
from core.geo import GeoFrame, bearing_deg, wrap_deg
from gcs.live.sensing import SECTOR_ORIENTATIONS, Pose
from vehicles.driving import (
    SPEED_UP_AND_STOP_S,
    DrivingLimits,
    read_driving_limits,
)
from vehicles.errors import CommandDenied, CommandError, LinkError, MissionTimeout
from vehicles.fence import FENCE, inclusion_fence, same_fence
from vehicles.link import VehicleLink
from vehicles.mission_items import MissionItem, same_items
from vehicles.modes import FlightMode, VehicleKind
from vehicles.telemetry import ObstacleDistances, Position, RangeReading, Topic

#: A copter this high above home has left the ground (metres).
CLIMBING_M = 0.1
#: Real seconds an upload of a flight home may always take (round trips are real time).
MIN_UPLOAD_REAL_S = 2.0
#: A car drives straight to a target at most this far off its nose (degrees); one
#: further off it lines up for first (``Pilot._line_up``), backing up at most this
#: many cells. From 1.5 cells back, the way forward to a cell beside it cuts across
#: the cell diagonal to it behind: where it may not enter that cell, it backs up a
#: short step only (its turn then stays clear of that cell's corner). The short step
#: is not the default: on SITL's car, a target that far off its nose was reached
#: (inside WP_RADIUS) 2 m from the centre, move after move.
CAR_AHEAD_DEG = 35.0
CAR_BACK_UP_CELLS = 1.5
CAR_TIGHT_BACK_UP_CELLS = 0.6
#: Grid steps (rows, columns) ahead of a vehicle heading north, east, south, west.
_HEADING_STEPS = ((-1, 0), (0, 1), (1, 0), (0, -1))


@dataclass(frozen=True)
class Route:
    """A flight home under way in AUTO."""

    #: Mission seq of the first cell of the path.
    first_seq: int
    #: Uploaded now (False: the rest of the one on board, resumed).
    uploaded: bool


#: A reading stamped this much later than the latest position is on another clock.
_OTHER_CLOCK_MS = 60_000


@dataclass(frozen=True)
class PilotSettings:
    """Times are mission seconds (simulated under a speed-up)."""

    #: Arrived when inside the target cell: within this share of a cell of its centre (or
    #: the vehicle's own acceptance radius, where that is tighter), stopped or reported
    #: there.
    arrival_tolerance_cells: float = 0.5
    #: Below this ground speed a vehicle has stopped (m/s).
    stopped_m_s: float = 0.15
    #: Copters fly at this height above home (low: every climb costs battery).
    cruise_alt_m: float = 3.0
    #: A move may take this many times its expected time (distance at the vehicle's speed,
    #: its turn, speeding up and stopping), plus ``move_slack_s``.
    move_time_factor: float = 3.0
    move_slack_s: float = 3.0
    #: Times a move is sent before it is given up (each time because the vehicle showed
    #: it lost the target, stopped short of it, or ran out of time).
    move_attempts: int = 4
    #: After a target is sent, the vehicle's reported target (POSITION_TARGET_GLOBAL_INT)
    #: is believed only when it arrives this much later (stream beat and link delay).
    target_echo_s: float = 1.5
    #: A vehicle that reports no target is sent it again only when it has stood this long
    #: (beyond any turn) no nearer to it: the target was lost on the way.
    stall_s: float = 3.0
    #: How long to wait for range readings taken after arrival.
    sensing_timeout_s: float = 3.0
    #: Take-off, landing, stopping, mode changes that show in telemetry.
    manoeuvre_timeout_s: float = 60.0
    #: Pause at every waypoint of a flight home (AUTO): the window in which the ground
    #: station can stop the vehicle if the planner does not grant the next cell.
    waypoint_hold_s: float = 0.5
    #: Longest a flight home may take to upload (the vehicle waits meanwhile).
    upload_budget_s: float = 10.0
    #: Read the mission back after uploading a flight home (the final ACK is always checked).
    verify_by_download: bool = False
    #: Retries of operations refused while the vehicle is not ready (pre-arm checks).
    ready_wait_s: float = 60.0
    #: Times a rover is brought back onto the pad when it stopped off it.
    park_attempts: int = 3
    #: Parked means within this share of a cell of the pad's centre (tighter than a move's
    #: arrival: a pad is smaller than its cell), and below this ground speed (m/s).
    park_tolerance_cells: float = 0.35
    parked_m_s: float = 0.05
    #: Real seconds below which no timeout is cut, whatever the speed-up (event loop jitter).
    min_real_timeout_s: float = 0.25


class MoveFailed(LinkError):
    """The vehicle did not get to a cell; the message says where it is and why."""


class Pilot:
    def __init__(
        self,
        link: VehicleLink,
        kind: VehicleKind,
        geo: GeoFrame,
        clock: Clock,
        speed_m_s: float,
        settings: PilotSettings | None = None,
        *,
        car: bool = False,
    ) -> None:
        self.link = link
        self.kind = kind
        self.geo = geo
        self.clock = clock
        self.speed_m_s = speed_m_s
        self.settings = settings or PilotSettings()
        self.flies = kind == VehicleKind.COPTER
        #: A rover that steers round a turning circle (it cannot pivot in place).
        self.car = car and not self.flies
        #: What the vehicle's own settings say of its driving (``learn_limits``).
        self.limits = DrivingLimits()
        #: The flight home on board, as uploaded: its cells, whether it lands, and the
        #: mission seq of its first cell.
        self._route: tuple[tuple[Cell, ...], bool, int] | None = None
        #: MISSION_ITEM_REACHED messages so far, and when the vehicle last reported its
        #: target (event loop time).
        self._reached_reports = 0
        #: Driving backwards (MAV_CMD_DO_SET_REVERSE) for the move under way.
        self._reversing = False
        #: Whether the vehicle may pass through a cell off its way (set by the agent:
        #: free on the planner's map, no other vehicle on it or bound for it): a car
        #: lining up backs only into such cells and keeps clear of the others' corners.
        self.may_enter: Callable[[Cell], bool] = lambda _cell: True
        self._target_heard_at: float | None = None
        self._status_heard_at: float | None = None
        link.router.on("MISSION_ITEM_REACHED", self._on_item_reached)
        link.router.on("POSITION_TARGET_GLOBAL_INT", self._on_target_report)
        link.router.on("HEARTBEAT", self._on_heartbeat)

    def _on_item_reached(self, _msg: object) -> None:
        self._reached_reports += 1

    def _on_target_report(self, _msg: object) -> None:
        self._target_heard_at = asyncio.get_running_loop().time()

    def _on_heartbeat(self, _msg: object) -> None:
        self._status_heard_at = asyncio.get_running_loop().time()

    async def learn_limits(self) -> DrivingLimits:
        """Read how the vehicle drives from its parameters (where they matter: rovers)."""
        if not self.flies:
            self.limits = await read_driving_limits(self.link)
        return self.limits

    async def set_fence(self, vertices: Sequence[tuple[float, float]]) -> None:
        """Upload an inclusion fence of (latitude, longitude) vertices, read it back, and
        switch it on with the safe state as its breach action (``vehicles.fence``):
        ``LinkError`` if the vehicle does not take it."""
        link = self.link
        items = inclusion_fence(vertices)
        await link.upload_mission(items, mission_type=FENCE)
        if not same_fence(items, await link.download_mission(FENCE)):
            raise LinkError("the vehicle holds another fence than the one sent")
        profile = link.profile
        if profile is None:
            raise LinkError("the vehicle's autopilot is not known: its fence cannot be enabled")
        params = profile.flavour.fence_params(profile.kind)
        for name, bits in params.bits.items():
            value = int(await link.read_param(name))
            if value & bits != bits:
                await link.set_param(name, value | bits)
        for name, setting in params.values.items():
            await link.set_param(name, setting)

    # -- time and state --------------------------------------------------------------

    def real_s(self, mission_s: float) -> float:
        """Real seconds to wait for ``mission_s`` of mission time."""
        return max(self.settings.min_real_timeout_s, self.clock.to_real(mission_s))

    @property
    def position(self) -> Position | None:
        return self.link.telemetry.position

    @property
    def battery_pct(self) -> float | None:
        return self.link.telemetry.battery.remaining_pct

    @property
    def armed(self) -> bool:
        status = self.link.status
        return status is not None and status.armed

    @property
    def flight_mode(self) -> FlightMode | None:
        status = self.link.status
        return None if status is None else status.flight_mode

    def cell_of(self, pos: Position) -> Cell:
        return self.geo.geo_to_cell(pos.lat_deg, pos.lon_deg)

    def offset_m(self, pos: Position, cell: Cell) -> float:
        """Horizontal distance from a position to a cell's centre."""
        north, east = self.geo.geo_to_local(pos.lat_deg, pos.lon_deg)
        cn, ce = self.geo.cell_centre_local(cell)
        return math.hypot(north - cn, east - ce)

    def airborne(self, pos: Position | None = None) -> bool:
        pos = pos or self.position
        return self.flies and pos is not None and pos.alt_rel_m > 0.5 * self.settings.cruise_alt_m

    @property
    def tolerance_m(self) -> float:
        """How far from a cell's centre the vehicle may stop and be on it."""
        tolerance = self.settings.arrival_tolerance_cells * self.geo.cell_size_m
        radius = self.limits.acceptance_radius_m
        return tolerance if radius is None else min(tolerance, radius)

    def at(self, pos: Position, cell: Cell, within_m: float | None = None) -> bool:
        """Inside ``cell`` (and, for a copter, up at cruise height), moving or not."""
        if self.offset_m(pos, cell) > (self.tolerance_m if within_m is None else within_m):
            return False
        return not self.flies or pos.alt_rel_m >= 0.8 * self.settings.cruise_alt_m

    def pose_of(self, pos: Position) -> Pose | None:
        """A position in the local frame, or None without a heading."""
        if pos.heading_deg is None:
            return None
        north, east = self.geo.geo_to_local(pos.lat_deg, pos.lon_deg)
        return Pose(north, east, pos.heading_deg, pos.time_boot_ms)

    def stopped(self, pos: Position) -> bool:
        return math.hypot(pos.vn_m_s, pos.ve_m_s) < self.settings.stopped_m_s

    def _parked(self, pos: Position) -> bool:
        return math.hypot(pos.vn_m_s, pos.ve_m_s) < self.settings.parked_m_s

    @property
    def park_tolerance_m(self) -> float:
        return min(self.tolerance_m, self.settings.park_tolerance_cells * self.geo.cell_size_m)

    async def wait_position(
        self, predicate: Callable[[Position], bool], mission_s: float, what: str = ""
    ) -> Any:
        """The cached position if it already satisfies ``predicate``, else the first update
        that does; ``TimeoutError`` after ``mission_s`` (saying ``what`` was awaited)."""
        pos = self.position
        if pos is not None and predicate(pos):
            return pos
        try:
            return await self.link.wait_for(Topic.POSITION, predicate, self.real_s(mission_s))
        except TimeoutError:
            waited = f"{what} " if what else "a position "
            raise TimeoutError(f"no {waited}within {mission_s:g} s") from None

    async def position_after(self, time_ms: int) -> Position:
        """The first position the vehicle reports at or after ``time_ms`` (its boot time).
        A time far beyond the latest position is on another clock (MAVLink lets a
        sensor stamp UNIX time): then simply the next position."""
        latest = self.position
        if latest is not None and time_ms > latest.time_boot_ms + _OTHER_CLOCK_MS:
            time_ms = latest.time_boot_ms + 1
        return await self.wait_position(
            lambda p: p.time_boot_ms >= time_ms,
            self.settings.sensing_timeout_s,
            f"position after {time_ms} ms",
        )

    async def wait_stopped(self, mission_s: float) -> Position:
        return await self.wait_position(self.stopped, mission_s, "stop")

    # -- getting going ----------------------------------------------------------------

    async def set_mode(self, mode: FlightMode) -> None:
        """Set a mode, retrying while the vehicle refuses it for not being ready. Always
        sent: the mode in the last heartbeat may be a second old."""
        await self._until_ready(lambda: self.link.set_mode(mode))

    async def _until_ready(self, op: Callable[[], Any]) -> None:
        loop = asyncio.get_running_loop()
        deadline = loop.time() + self.real_s(self.settings.ready_wait_s)
        while True:
            try:
                await op()
                return
            except CommandDenied:
                if loop.time() >= deadline:
                    raise
                # Wait for the vehicle to say something (pre-arm text) or a beat of time.
                with contextlib.suppress(TimeoutError):
                    await self.link.wait_for(Topic.STATUSTEXT, lambda _t: True, self.real_s(1.0))

    async def underway(self) -> None:
        """Ready to take a GUIDED target: GUIDED, armed and, for a copter, at cruise height.

        Nothing is sent when the telemetry already shows it so (every command costs a
        round trip, many on a lossy link); should the mode have changed since the last
        heartbeat, ``goto`` finds out from the heartbeat and sets it again."""
        ready = self.flight_mode == FlightMode.GUIDED and self.armed
        if ready and (not self.flies or self.airborne()):
            return
        if self.flies and self.airborne():
            await self.set_mode(FlightMode.GUIDED)
            return
        for _ in range(self.settings.move_attempts):
            await self.set_mode(FlightMode.GUIDED)
            if not self.armed:
                await self.link.arm(wait_ready_s=self.real_s(self.settings.ready_wait_s))
            if not self.flies:
                return
            try:
                await self.link.takeoff(self.settings.cruise_alt_m)
            except CommandDenied:
                # Refused: either it disarmed itself before the take-off came (a lost
                # packet), or an earlier take-off got through and only its ACK was lost.
                with contextlib.suppress(TimeoutError):
                    await self.wait_position(lambda p: p.alt_rel_m > CLIMBING_M, 2.0)
                pos = self.position
                if pos is None or pos.alt_rel_m <= CLIMBING_M:
                    continue
            await self.wait_position(
                lambda p: p.alt_rel_m >= 0.9 * self.settings.cruise_alt_m,
                self.settings.manoeuvre_timeout_s,
                "climb to cruise height",
            )
            return
        raise LinkError("take-off refused every time")

    # -- moving --------------------------------------------------------------------------

    def move_time_s(self, metres: float, turn_deg: float = 0.0) -> float:
        """How long a move may take: its expected time (the distance at the vehicle's
        speed, its turn, speeding up and stopping) times ``move_time_factor``, plus slack."""
        s = self.settings
        speed = self.limits.cruise_m_s(self.speed_m_s)
        expected = metres / speed
        if not self.flies:
            expected += SPEED_UP_AND_STOP_S
            expected += self.limits.turn_s(turn_deg, car=self.car, speed_m_s=speed)
        return s.move_time_factor * expected + s.move_slack_s

    def turn_to_deg(self, pos: Position | None, lat: float, lon: float) -> float:
        """How far the vehicle must turn to face a point (0 when it does not know)."""
        if pos is None or pos.heading_deg is None or self.flies:
            return 0.0
        n0, e0 = self.geo.geo_to_local(pos.lat_deg, pos.lon_deg)
        n1, e1 = self.geo.geo_to_local(lat, lon)
        if math.hypot(n1 - n0, e1 - e0) < 1e-3:
            return 0.0
        return abs(wrap_deg(bearing_deg(n1 - n0, e1 - e0) - pos.heading_deg))

    async def goto(self, cell: Cell, within_m: float | None = None) -> Position:
        """Drive or fly to ``cell`` in GUIDED; the position once there: inside the cell,
        stopped or reported there.

        The target is sent once, and again only when the vehicle shows it lost it: out
        of GUIDED, steering to another target, stopped short of the cell after saying
        it reached it, or (a vehicle that reports no target) standing still no nearer;
        or when the move's whole time is up. Each autopilot restarts its path on a new
        target, so a target sent on a timer would keep a rover from ever arriving.
        A car is lined up first (``_line_up``). ``within_m``: nearer the centre than
        the cell's own tolerance (the pad). ``MoveFailed`` after ``move_attempts``
        sends, saying what happened."""
        lat, lon = self.geo.cell_centre(cell)
        why = ""
        for _attempt in range(self.settings.move_attempts):
            if self.flight_mode not in (None, FlightMode.GUIDED):
                await self.set_mode(FlightMode.GUIDED)
            try:
                if self.car:
                    await self._line_up(lat, lon, cell)
                outcome = await self._drive(lat, lon, lambda p: self.at(p, cell, within_m))
            finally:
                await self._set_reverse(False)
            if isinstance(outcome, Position):
                return outcome
            why = outcome
        pos = self.position
        where = "" if pos is None else f", {self.offset_m(pos, cell):.2f} m from its centre"
        raise MoveFailed(
            f"not at cell {cell} after {self.settings.move_attempts} tries{where} ({why})"
        )

    async def _drive(
        self, lat: float, lon: float, there: Callable[[Position], bool]
    ) -> Position | str:
        """Send one target and follow the vehicle: its position once ``there`` and stopped
        (or reported there), else why the target must be sent again."""
        loop = asyncio.get_running_loop()
        pos = self.position
        distance = self.geo.cell_size_m if pos is None else self.distance_m(pos, lat, lon)
        limit_s = self.move_time_s(distance, self.turn_to_deg(pos, lat, lon))
        await self.link.goto(lat, lon, self.settings.cruise_alt_m if self.flies else 0.0)
        sent = loop.time()
        reports = self._reached_reports
        deadline = sent + self.real_s(limit_s)
        watch = _Progress(sent, distance)
        while True:
            pos = self.position
            done = pos is not None and there(pos)
            if pos is not None and done and (self.stopped(pos) or self._reached_reports > reports):
                return pos
            lost = self._target_lost(pos, (lat, lon), sent, reports, watch)
            if lost:
                return lost
            left = deadline - loop.time()
            if left <= 0:
                return f"not there after {limit_s:.0f} s"
            with contextlib.suppress(TimeoutError):
                await self.link.wait_for(Topic.POSITION, lambda _p: True, min(left, 1.0))

    async def line_up(self, cell: Cell) -> None:
        """Put a car where ``cell`` lies ahead of it (before a route that starts there)."""
        try:
            await self._line_up(*self.geo.cell_centre(cell), cell)
        finally:
            await self._set_reverse(False)

    async def _line_up(self, lat: float, lon: float, cell: Cell) -> None:
        """A car cannot turn on the spot, and ArduPilot's car overshoots a target off to
        its side by metres (seen on SITL: 1.7 m from a point 2 m beside it). A target
        behind it is driven to backwards (MAV_CMD_DO_SET_REVERSE); for one off to its
        side it first backs up along its heading (back the way it came) until the target
        lies within ``CAR_AHEAD_DEG`` of its nose. On SITL's car this put 17 moves of 17
        within 0.64 m of the cell centre, against 4 of 12 sent straight."""
        pos = self.position
        if pos is None or pos.heading_deg is None:
            return
        off = self.turn_to_deg(pos, lat, lon)
        if off <= CAR_AHEAD_DEG:
            return
        if off >= 180.0 - CAR_AHEAD_DEG:
            await self._set_reverse(True)
            return  # straight back to it
        distance = self.distance_m(pos, lat, lon)
        ahead = distance * math.cos(math.radians(off))
        beside = distance * math.sin(math.radians(off))
        back = beside / math.tan(math.radians(CAR_AHEAD_DEG)) - ahead
        back = min(back, self._room_behind(pos, cell) * self.geo.cell_size_m)
        if back <= 0.0:
            return  # nowhere to back up to: forwards, turning as it can
        await self._set_reverse(True)
        north, east = self.geo.geo_to_local(pos.lat_deg, pos.lon_deg)
        h = math.radians(pos.heading_deg)
        to = self.geo.local_to_geo(north - back * math.cos(h), east - back * math.sin(h))
        near = 0.25 * self.geo.cell_size_m
        await self._drive(*to, lambda p: self.distance_m(p, *to) <= near)
        await self._set_reverse(False)

    def _room_behind(self, pos: Position, cell: Cell) -> float:
        """How many cells a car may back up to line up for ``cell``, a neighbour beside
        it: none into a cell it may not enter (``may_enter``), a short step where it
        may not enter the cell diagonal to it behind, on the side of ``cell`` (a long
        back-up would cut its corner on the way forward), else ``CAR_BACK_UP_CELLS``."""
        here = self.cell_of(pos)
        side = (cell[0] - here[0], cell[1] - here[1])
        if pos.heading_deg is None or abs(side[0]) + abs(side[1]) != 1:
            return CAR_BACK_UP_CELLS
        ahead = _HEADING_STEPS[round(pos.heading_deg / 90.0) % 4]
        behind = (here[0] - ahead[0], here[1] - ahead[1])
        if not self.may_enter(behind):
            return 0.0
        if not self.may_enter((behind[0] + side[0], behind[1] + side[1])):
            return CAR_TIGHT_BACK_UP_CELLS
        return CAR_BACK_UP_CELLS

    async def _set_reverse(self, backwards: bool) -> None:
        if backwards == self._reversing:
            return
        await self.link.command_long(mavlink.MAV_CMD_DO_SET_REVERSE, 1.0 if backwards else 0.0)
        self._reversing = backwards

    def distance_m(self, pos: Position, lat: float, lon: float) -> float:
        """Horizontal distance from a position to a point."""
        return self._metres(pos.lat_deg, pos.lon_deg, lat, lon)

    def _metres(self, lat0: float, lon0: float, lat1: float, lon1: float) -> float:
        n0, e0 = self.geo.geo_to_local(lat0, lon0)
        n1, e1 = self.geo.geo_to_local(lat1, lon1)
        return math.hypot(n1 - n0, e1 - e0)

    def _target_lost(
        self,
        pos: Position | None,
        target: tuple[float, float],
        sent: float,
        reports: int,
        watch: _Progress,
    ) -> str:
        """Why the target must be sent again, or "" while the vehicle is on its way."""
        mode = self.flight_mode
        beat = self._status_heard_at
        if beat is not None and beat > sent and mode is not None and mode != FlightMode.GUIDED:
            status = self.link.status
            return f"it left GUIDED for {status.mode_name if status else mode}"
        if pos is None:
            return ""
        loop_now = asyncio.get_running_loop().time()
        heard = self._target_heard_at
        echo = self.link.telemetry.target
        grace = self.real_s(self.settings.target_echo_s)
        # A report of the target it steers to, made after it had our target.
        reported = heard is not None and echo is not None and heard >= sent + grace
        if reported and echo is not None:
            steers_to = self._metres(echo.lat_deg, echo.lon_deg, *target)
            if steers_to > 0.1 * self.geo.cell_size_m:
                return "it steers to another target"
        offset = self.distance_m(pos, *target)
        if not self.stopped(pos):
            watch.moving(loop_now, offset)
            return ""
        if self._reached_reports > reports:
            return f"it stopped {offset:.2f} m from the target, saying it was there"
        if not reported:
            # No report of our target: standing still this long (beyond any turn in
            # place), no nearer, it never got it.
            turn = self.limits.turn_s(180.0, car=self.car, speed_m_s=self.speed_m_s)
            if watch.stalled(loop_now, offset, self.real_s(self.settings.stall_s + turn)):
                return "it stood still, no nearer"
        return ""

    async def stop_here(self) -> Position:
        """Stop (GUIDED with no target), then settle on the centre of the cell it is in."""
        await self.link.set_mode(FlightMode.GUIDED)
        pos = self.position
        if pos is None:
            raise LinkError("no position")
        if not self.flies:
            pos = await self.wait_stopped(self.settings.manoeuvre_timeout_s)
        return await self.goto(self.cell_of(pos))

    # -- sensing -------------------------------------------------------------------------

    async def ranges_since(
        self, since_ms: int
    ) -> tuple[dict[int, RangeReading], ObstacleDistances | None]:
        """Range readings taken at or after ``since_ms`` (vehicle boot time): all eight
        DISTANCE_SENSOR sectors and one OBSTACLE_DISTANCE (of those the vehicle sends at
        all). Asks for them at once (MAV_CMD_REQUEST_MESSAGE) rather than wait for the next
        stream beat.
        After the timeout, whatever fresh readings there are."""
        cache = self.link.telemetry

        def fresh() -> tuple[dict[int, RangeReading], ObstacleDistances | None]:
            ranges = {
                o: r
                for o, r in cache.ranges.items()
                if o in SECTOR_ORIENTATIONS and r.time_boot_ms >= since_ms
            }
            obstacles = cache.obstacles
            if obstacles is not None and obstacles.time_usec < since_ms * 1000:
                obstacles = None
            return ranges, obstacles

        has_ranges = bool(cache.ranges)
        has_obstacles = cache.obstacles is not None

        def complete(_update: object = None) -> bool:
            ranges, obstacles = fresh()
            # One OBSTACLE_DISTANCE says all there is to say (every direction, and the
            # narrow sectors that settle diagonals); else all eight DISTANCE_SENSORs.
            if obstacles is not None:
                return True
            return len(ranges) == len(SECTOR_ORIENTATIONS) and not has_obstacles

        if complete():
            return fresh()
        wanted = [
            message_id
            for message_id, present in (
                (mavlink.MAVLINK_MSG_ID_DISTANCE_SENSOR, has_ranges or not has_obstacles),
                (mavlink.MAVLINK_MSG_ID_OBSTACLE_DISTANCE, has_obstacles),
            )
            if present
        ]
        requests = [asyncio.ensure_future(self._request(m)) for m in wanted]
        waits = [
            asyncio.ensure_future(
                self.link.wait_for(topic, complete, self.real_s(self.settings.sensing_timeout_s))
            )
            for topic in (Topic.RANGE, Topic.OBSTACLES)
        ]
        try:
            await asyncio.wait(waits, return_when=asyncio.FIRST_COMPLETED)
        finally:
            for task in (*requests, *waits):
                task.cancel()
            await asyncio.gather(*requests, *waits, return_exceptions=True)
        return fresh()

    async def _request(self, message_id: int) -> None:
        with contextlib.suppress(LinkError):
            await self.link.command_long(mavlink.MAV_CMD_REQUEST_MESSAGE, message_id)

    # -- flying home in AUTO -------------------------------------------------------------

    def route_items(self, cells: Sequence[Cell], land: bool) -> list[MissionItem]:
        """The path as a mission: item 0 home (ArduPilot), a waypoint per cell with a short
        hold, and for a copter a landing on the last one."""
        s = self.settings
        alt = s.cruise_alt_m if self.flies else 0.0
        items: list[MissionItem] = []
        profile = self.link.profile
        if profile is None or profile.flavour.mission_has_home:
            home_lat, home_lon = self.geo.cell_centre(cells[-1])
            items.append(MissionItem.waypoint(0, home_lat, home_lon, 0.0))
        for i, cell in enumerate(cells):
            lat, lon = self.geo.cell_centre(cell)
            hold = s.waypoint_hold_s if i < len(cells) - 1 else 0.0
            items.append(MissionItem.waypoint(len(items), lat, lon, alt, hold_s=hold))
        if land and self.flies:
            lat, lon = self.geo.cell_centre(cells[-1])
            items.append(
                MissionItem.waypoint(len(items), lat, lon, 0.0, command=mavlink.MAV_CMD_NAV_LAND)
            )
        return items

    async def start_route(self, cells: Sequence[Cell], land: bool) -> Route:
        """Fly the path in AUTO: uploaded, or, when it is the rest of the flight home
        already on board (a vehicle stopped on the way and let go on), resumed there
        with DO_SET_MISSION_CURRENT and AUTO instead of uploading it again (over a
        slow radio an upload keeps the vehicle hovering for seconds). Entering AUTO,
        the autopilot goes on from the current item (ArduPilot with MIS_RESTART 0,
        its default).

        The upload counts only when the vehicle accepted it (final MISSION_ACK), and with
        ``verify_by_download`` only when it reads back the same."""
        offset = self._rest_of_route(cells, land)
        if offset is not None:
            try:
                await self.link.set_current_item(offset)
            except CommandError:
                pass  # not on board after all (a reboot, another ground station): upload
            else:
                await self.set_mode(FlightMode.AUTO)
                return Route(offset, uploaded=False)
        items = self.route_items(cells, land)
        budget_s = self.settings.upload_budget_s
        self._route = None  # a failed upload may leave anything on board
        try:
            # Never less than a few real seconds: the transfer's round trips run in real
            # time whatever the vehicles' speed-up.
            async with asyncio.timeout(max(MIN_UPLOAD_REAL_S, self.real_s(budget_s))):
                await self.link.upload_mission(items)
        except TimeoutError:
            # Hovering while a lossy link crawls through the items costs battery the
            # return was not budgeted for: better to step home at once.
            raise MissionTimeout("upload", f"still going after {budget_s:g} s") from None
        if self.settings.verify_by_download:
            back = await self.link.download_mission()
            if not same_items(back[1:], items[1:]):
                raise LinkError("the flight home read back differs from the one sent")
        first_seq = len(items) - len(cells) - (1 if land and self.flies else 0)
        self._route = (tuple(cells), land, first_seq)
        await self.set_mode(FlightMode.AUTO)
        return Route(first_seq, uploaded=True)

    def _rest_of_route(self, cells: Sequence[Cell], land: bool) -> int | None:
        """The mission seq of ``cells[0]`` when ``cells`` end the flight home on board."""
        if self._route is None or not cells:
            return None
        on_board, lands, first_seq = self._route
        skipped = len(on_board) - len(cells)
        if lands != land or skipped < 0 or on_board[skipped:] != tuple(cells):
            return None
        return first_seq + skipped

    def mission_seq(self) -> int | None:
        return self.link.telemetry.mission.current_seq

    # -- parking and the safe state --------------------------------------------------

    async def park(self, pad: Cell) -> None:
        """Stop on ``pad`` and disarm (only a disarmed vehicle charges): a copter lands,
        first brought over the pad's centre if it hovers off it (arrived at the pad cell's
        edge); a rover holds, and once it has stopped rolling is brought back onto the pad
        if it stopped off it, then disarmed."""
        self._route = None  # the flight home is over: the next one is uploaded afresh
        wait_s = self.settings.manoeuvre_timeout_s
        if self.flies:
            pos = self.position
            if (
                pos is not None
                and self.airborne()
                and self.offset_m(pos, pad) > self.park_tolerance_m
            ):
                await self.underway()
                await self.goto(pad, self.park_tolerance_m)
            await self._land(wait_s)
        else:
            tries = self.settings.park_attempts
            for attempt in range(tries + 1):
                if attempt:
                    # Back onto the pad in GUIDED, which stops there; held only once
                    # stopped, since HOLD at speed lets a rover roll off again.
                    await self.underway()
                    await self.goto(pad, self.park_tolerance_m)
                    await self.wait_position(self._parked, wait_s, "stop")
                if self.flight_mode != FlightMode.HOLD:
                    await self.set_mode(FlightMode.HOLD)
                pos = await self.wait_position(self._parked, wait_s, "stop")
                off = self.offset_m(pos, pad)
                if off <= self.park_tolerance_m:
                    break
                if attempt == tries:
                    raise MoveFailed(
                        f"did not stop on the pad {pad} in {tries} tries "
                        f"({off:.2f} m off its centre)"
                    )
        await self._disarm(wait_s)

    async def _land(self, wait_s: float) -> None:
        pos = self.position
        if pos is None or pos.alt_rel_m > 0.2:
            await self.link.land()  # also when an AUTO route is landing it already
            await self.wait_position(lambda p: p.alt_rel_m <= 0.2, wait_s, "landing")
        if self.armed:  # autopilots disarm by themselves once landed: give it a moment
            with contextlib.suppress(TimeoutError):
                await self.link.wait_for(
                    Topic.STATUS, lambda s: not s.armed, self.real_s(self.settings.move_slack_s)
                )

    async def _disarm(self, wait_s: float) -> None:
        if self.armed:
            await self._until_ready(self.link.disarm)
            if self.armed:
                try:
                    await self.link.wait_for(
                        Topic.STATUS, lambda s: not s.armed, self.real_s(wait_s)
                    )
                except TimeoutError:
                    raise TimeoutError(f"still armed {wait_s:g} s after disarming") from None

    async def make_safe(self) -> str:
        """The safe state, wherever the vehicle is: a rover stopped (HOLD) and disarmed, a
        copter landed (LAND) and disarmed. Returns what was done, for the operator;
        raises ``LinkError`` or ``TimeoutError`` when the vehicle does not follow."""
        self._route = None
        wait_s = self.settings.manoeuvre_timeout_s
        if self.flies:
            await self._land(wait_s)
            await self._disarm(wait_s)
            return "landed and disarmed"
        await self.set_mode(FlightMode.HOLD)
        await self.wait_stopped(wait_s)
        await self._disarm(wait_s)
        return "stopped (HOLD) and disarmed"


@dataclass
class _Progress:
    """When a vehicle last got nearer its target, to tell a lost target from a pause."""

    since: float
    best_m: float

    def moving(self, now: float, offset_m: float) -> None:
        self.since, self.best_m = now, min(self.best_m, offset_m)

    def stalled(self, now: float, offset_m: float, after_s: float) -> bool:
        if offset_m < self.best_m - 0.05:
            self.since, self.best_m = now, offset_m
            return False
        return now - self.since >= after_s
