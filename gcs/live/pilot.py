"""Flying one vehicle from cell to cell over its ``VehicleLink``: no planner in here.

The pilot knows how to get a rover or a copter going (GUIDED, arm, take off),
to put it on a cell centre and tell when it is there (from its position
telemetry, never from a sleep), to collect range readings taken *after* it
arrived, to fly a path home as an AUTO mission (which goes on without us
when the link drops), and to park it on the charger (land or stop, disarm).

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

from gcs.live.sensing import SECTOR_ORIENTATIONS
from planner.grid import Cell
from vehicles.clock import Clock
from vehicles.errors import CommandDenied, CommandError, LinkError, MissionTimeout
from vehicles.geo import GeoFrame
from vehicles.link import VehicleLink
from vehicles.mission_items import MissionItem, same_items
from vehicles.modes import FlightMode, VehicleKind
from vehicles.telemetry import ObstacleDistances, Position, RangeReading, Topic

#: A copter this high above home has left the ground (metres).
CLIMBING_M = 0.1


@dataclass(frozen=True)
class Route:
    """A flight home under way in AUTO."""

    #: Mission seq of the first cell of the path.
    first_seq: int
    #: Uploaded now (False: the rest of the one on board, resumed).
    uploaded: bool


@dataclass(frozen=True)
class PilotSettings:
    """Times are mission seconds (simulated under a speed-up)."""

    #: Arrived when the horizontal distance to the cell centre is below this share of a cell.
    arrival_tolerance_cells: float = 0.15
    #: Copters fly at this height above home (low: every climb costs battery).
    cruise_alt_m: float = 3.0
    #: A move may take this many times its travel time at cruise speed, plus ``move_slack_s``,
    #: before the target is sent again (a GUIDED target has no acknowledgement).
    move_time_factor: float = 3.0
    move_slack_s: float = 3.0
    move_attempts: int = 4
    #: A GUIDED target is sent again this often until the vehicle is there: it has no
    #: acknowledgement, and a lost one would otherwise cost a whole move timeout.
    target_resend_s: float = 1.0
    #: How long to wait for range readings taken after arrival.
    sensing_timeout_s: float = 3.0
    #: Take-off, landing, mode changes that show in telemetry.
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
    #: Real seconds below which no timeout is cut, whatever the speed-up (event loop jitter).
    min_real_timeout_s: float = 0.25


class Pilot:
    def __init__(
        self,
        link: VehicleLink,
        kind: VehicleKind,
        geo: GeoFrame,
        clock: Clock,
        speed_m_s: float,
        settings: PilotSettings | None = None,
    ) -> None:
        self.link = link
        self.kind = kind
        self.geo = geo
        self.clock = clock
        self.speed_m_s = speed_m_s
        self.settings = settings or PilotSettings()
        self.flies = kind == VehicleKind.COPTER
        #: The flight home on board, as uploaded: its cells, whether it lands, and the
        #: mission seq of its first cell.
        self._route: tuple[tuple[Cell, ...], bool, int] | None = None

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

    def at(self, pos: Position, cell: Cell) -> bool:
        """On the centre of ``cell`` (and, for a copter, up at cruise height)."""
        if self.offset_m(pos, cell) > self.settings.arrival_tolerance_cells * self.geo.cell_size_m:
            return False
        return not self.flies or pos.alt_rel_m >= 0.8 * self.settings.cruise_alt_m

    async def wait_position(self, predicate: Callable[[Position], bool], mission_s: float) -> Any:
        """The cached position if it already satisfies ``predicate``, else the first update
        that does; ``TimeoutError`` after ``mission_s``."""
        pos = self.position
        if pos is not None and predicate(pos):
            return pos
        return await self.link.wait_for(Topic.POSITION, predicate, self.real_s(mission_s))

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
        heartbeat, ``goto`` finds out when the vehicle does not come and sets it again."""
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
            )
            return
        raise LinkError("take-off refused every time")

    # -- moving --------------------------------------------------------------------------

    def move_time_s(self, metres: float) -> float:
        s = self.settings
        return s.move_time_factor * metres / self.speed_m_s + s.move_slack_s

    async def goto(self, cell: Cell) -> Position:
        """Fly to the centre of ``cell`` in GUIDED and return the position on arrival.

        The target is sent again every ``target_resend_s`` until the vehicle is there (the
        message may have been lost), and GUIDED set again after a move's time without
        arriving; ``TimeoutError`` after every attempt."""
        lat, lon = self.geo.cell_centre(cell)
        alt = self.settings.cruise_alt_m if self.flies else 0.0
        pos = self.position
        distance = self.geo.cell_size_m if pos is None else self.offset_m(pos, cell)
        timeout = self.move_time_s(distance)
        for _ in range(self.settings.move_attempts):
            left = timeout
            while left > 0:
                await self.link.goto(lat, lon, alt)
                wait = min(self.settings.target_resend_s, left)
                with contextlib.suppress(TimeoutError):
                    return await self.wait_position(lambda p: self.at(p, cell), wait)
                left -= wait
            await self.set_mode(FlightMode.GUIDED)
        raise TimeoutError(f"not at cell {cell} after {self.settings.move_attempts} moves")

    async def stop_here(self) -> Position:
        """Stop (GUIDED with no target), then settle on the centre of the cell it is in."""
        await self.link.set_mode(FlightMode.GUIDED)
        pos = self.position
        if pos is None:
            raise LinkError("no position")
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
            async with asyncio.timeout(self.real_s(budget_s)):
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

    # -- parking -------------------------------------------------------------------------

    async def park(self) -> None:
        """On the charger: a copter lands, a rover holds; then disarm (only a disarmed
        vehicle charges)."""
        self._route = None  # the flight home is over: the next one is uploaded afresh
        wait_s = self.settings.manoeuvre_timeout_s
        if self.flies:
            pos = self.position
            if pos is None or pos.alt_rel_m > 0.2:
                await self.link.land()  # also when an AUTO route is landing it already
                await self.wait_position(lambda p: p.alt_rel_m <= 0.2, wait_s)
            if self.armed:  # autopilots disarm by themselves once landed: give it a moment
                with contextlib.suppress(TimeoutError):
                    await self.link.wait_for(
                        Topic.STATUS, lambda s: not s.armed, self.real_s(self.settings.move_slack_s)
                    )
        else:
            await self.set_mode(FlightMode.HOLD)
        if self.armed:
            await self._until_ready(self.link.disarm)
            if self.armed:
                await self.link.wait_for(Topic.STATUS, lambda s: not s.armed, self.real_s(wait_s))

    async def hold(self) -> None:
        """Stop where it is: HOLD for a rover, a landing for a copter (it cannot hover for
        ever). Used when a vehicle cannot be sent to charge."""
        self._route = None
        if self.flies:
            await self.link.land()
        else:
            await self.link.set_mode(FlightMode.HOLD)
