"""One mock vehicle: an ArduPilot-like state machine advanced by ``step(dt)``.

The vehicle lives in the grid's local frame (metres north and east of the
map's north-west corner, altitude above the ground). It moves in straight
lines toward its current goal at its cruise speed and never enters a wall,
a cell outside the map or a cell held by another vehicle: such a move is
refused, the vehicle drives back to the centre of its cell, stops there and
says so in a STATUSTEXT. When the cell ahead is held by another vehicle it
first waits a moment (``yield_timeout_s``) for it to move on, as two rovers
in a corridor would.

Commands come in as method calls (the MAVLink endpoint translates them) and
either succeed or raise ``CommandRefused`` with the text ArduPilot would
print. Events (status texts, waypoints reached, mission progress, death)
go to subscribers as they happen.
"""

from __future__ import annotations

import contextlib
import math
import random
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from core.cells import Cell
from core.geo import bearing_deg
from sitl_mock.battery import Battery, BatterySettings, ChargeState
from sitl_mock.drive import Drive, DriveSettings
from sitl_mock.events import (
    ItemReached,
    MissionCurrentChanged,
    Severity,
    StatusText,
    VehicleDied,
    VehicleEvent,
)
from sitl_mock.failsafe import FailsafeAction, GcsFailsafe, GcsWatch
from sitl_mock.fence import Fence, FenceAction
from sitl_mock.modes import PROFILES, Behaviour, KindProfile, VehicleKind
from sitl_mock.ranging import axis_exit
from sitl_mock.world import Blocker, BlockReason, World
from vehicles.mission_items import MissionItem

_EPS_M = 1e-6
_TIE = 1e-7
#: Copters move sideways only above this height.
_MIN_NAV_ALT_M = 0.5

ARM_FORCE_MAGIC = 2989
DISARM_FORCE_MAGIC = 21196

#: ArduPilot's two battery failsafe levels; a pack below critical stays at critical.
_FAILSAFE_LEVEL = {
    ChargeState.LOW: 1,
    ChargeState.CRITICAL: 2,
    ChargeState.EMERGENCY: 2,
}
_FAILSAFE_NAMES = {1: "low", 2: "critical"}


@dataclass(frozen=True)
class VehicleSettings:
    kind: VehicleKind
    speed_m_s: float = 2.0
    climb_rate_m_s: float = 2.5
    land_rate_m_s: float = 1.0
    takeoff_alt_m: float = 5.0
    #: Seconds after boot until the position estimate uses GPS (ArduPilot: about 10-40 s).
    #: Until then the vehicle reports latitude and longitude 0, 0, no GPS fix and no home,
    #: and refuses arming ("Arm: Need Position Estimate"), AUTO/GUIDED/RTL and uploads.
    startup_delay_s: float = 0.0
    #: ArduPilot Copter disarms when left armed on the ground this long (None: never).
    copter_auto_disarm_s: float | None = 10.0
    #: How long to wait for another vehicle to leave the cell ahead before refusing the move.
    yield_timeout_s: float = 1.0
    #: Start cell; None means the charging station.
    start_cell: Cell | None = None
    #: Range sensors (DISTANCE_SENSOR x 8, OBSTACLE_DISTANCE); False for a vehicle given the map.
    range_sensing: bool = True
    range_max_m: float = 10.0
    #: What the vehicle does when its ground station falls silent (default: nothing).
    gcs_failsafe: GcsFailsafe = field(default_factory=GcsFailsafe)
    #: A rover that drives as ArduPilot Rover does (``sitl_mock.drive``: turns, WP_RADIUS,
    #: braking, coasting); None drives in straight lines and stops dead on every target.
    #: Copters always fly straight to their targets (ArduPilot Copter reaches them).
    drive: DriveSettings | None = None

    def __post_init__(self) -> None:
        if self.speed_m_s <= 0:
            raise ValueError(f"speed_m_s must be positive, got {self.speed_m_s}")


class CommandRefused(Exception):
    """A command the vehicle will not carry out; ``result`` is the MAV_RESULT to answer."""

    def __init__(self, text: str, result: int = mavlink.MAV_RESULT_FAILED) -> None:
        super().__init__(text)
        self.text = text
        self.result = result


@dataclass(frozen=True)
class Goal:
    """Where the vehicle is heading. ``alt_m`` None keeps the altitude; ``land`` makes a
    copter descend to the ground once above the point."""

    north_m: float
    east_m: float
    alt_m: float | None = None
    land: bool = False


class Vehicle:
    def __init__(
        self,
        vehicle_id: int,
        settings: VehicleSettings,
        battery: BatterySettings,
        world: World,
        rng: random.Random | None = None,
    ) -> None:
        self.id = vehicle_id
        self.settings = settings
        self.profile: KindProfile = PROFILES[settings.kind]
        self.world = world
        self.battery = Battery(battery, rng)
        start = settings.start_cell if settings.start_cell is not None else world.map.charger
        world.place(vehicle_id, start)
        self.north_m, self.east_m = world.geo.cell_centre_local(start)
        self.home = (self.north_m, self.east_m)
        self.alt_m = 0.0
        self.heading_deg = 0.0
        self.velocity_ned_m_s = (0.0, 0.0, 0.0)
        self.speed_m_s = settings.speed_m_s
        self.armed = False
        self.mode = self.profile.initial_mode
        self.elapsed_s = 0.0
        self.dead = False
        self.mission: tuple[MissionItem, ...] = ()
        self.fence = Fence()
        self.mission_seq = 0
        self.mission_state = mavlink.MISSION_STATE_NO_MISSION
        self._goal: Goal | None = None
        #: The last GUIDED position target, kept until the mode changes (reported in
        #: POSITION_TARGET_GLOBAL_INT, as ArduPilot does); north, east in metres.
        self.guided_target: tuple[float, float] | None = None
        self.guided_alt_m: float | None = None
        self._item_hold_s = 0.0
        self._refused_goal: Goal | None = None
        self._wait_s = 0.0
        self._ground_idle_s = 0.0
        self._failsafe_level = 0
        self._gcs = GcsWatch(settings.gcs_failsafe)
        self.drive: Drive | None = None
        if settings.drive is not None and not self.profile.flies:
            self.drive = Drive(settings.drive)
        self._listeners: list[Callable[[VehicleEvent], None]] = []

    # ------------------------------------------------------------------ observers

    def subscribe(self, listener: Callable[[VehicleEvent], None]) -> None:
        self._listeners.append(listener)

    def _emit(self, event: VehicleEvent) -> None:
        for listener in list(self._listeners):
            listener(event)

    def _say(self, text: str, severity: Severity = Severity.INFO) -> None:
        self._emit(StatusText(severity, text))

    # ------------------------------------------------------------------ state queries

    @property
    def behaviour(self) -> Behaviour:
        return self.profile.modes[self.mode]

    @property
    def mode_name(self) -> str:
        return self.profile.name_of(self.mode)

    @property
    def ready(self) -> bool:
        """Past the start-up delay (GPS fix, pre-arm checks)."""
        return self.elapsed_s >= self.settings.startup_delay_s

    @property
    def reported_lat_lon_deg(self) -> tuple[float, float]:
        """What the vehicle says of its position: 0, 0 until its position estimate."""
        return self.lat_lon_deg if self.ready else (0.0, 0.0)

    @property
    def cell(self) -> Cell:
        return self.world.cell_of(self.id)

    @property
    def airborne(self) -> bool:
        return self.profile.flies and self.alt_m > 0.0

    @property
    def landed(self) -> bool:
        return not self.airborne

    @property
    def lat_lon_deg(self) -> tuple[float, float]:
        return self.world.geo.local_to_geo(self.north_m, self.east_m)

    @property
    def current_goal(self) -> Goal | None:
        return self._refused_goal or self._goal

    @property
    def stopped_by_refusal(self) -> bool:
        return self._refused_goal is not None

    @property
    def gcs_failsafe_active(self) -> bool:
        """The GCS failsafe has triggered and no ground station has been heard since."""
        return self._gcs.active

    # ------------------------------------------------------------------ commands

    def arm(self, force: bool = False) -> None:
        if self.armed:
            return
        if not force and not self.ready:
            raise CommandRefused("Arm: Need Position Estimate")
        if self.mode in self.profile.unarmable or (
            self.profile.flies and self.behaviour is Behaviour.AUTO and not self._at_takeoff_item()
        ):
            raise CommandRefused("Arm: Mode not armable")
        self.armed = True
        self._ground_idle_s = 0.0
        self._say("Arming motors")

    def disarm(self, force: bool = False) -> None:
        if not self.armed:
            return
        if self.airborne and not force:
            raise CommandRefused("Disarm: vehicle is flying")
        self._disarm("Disarming motors")

    def set_mode(self, mode: int) -> None:
        if mode not in self.profile.modes:
            raise CommandRefused(f"Unknown mode {mode}")
        behaviour = self.profile.modes[mode]
        if behaviour in (Behaviour.AUTO, Behaviour.GUIDED, Behaviour.RTL) and not self.ready:
            raise CommandRefused(
                f"Mode change to {self.profile.name_of(mode)} failed: requires position"
            )
        if behaviour is Behaviour.AUTO and len(self.mission) < 2:
            raise CommandRefused("Mode change to AUTO failed: no mission")
        self._clear_motion()
        self.mode = mode
        self.guided_target = None
        if self.drive is not None:
            # GUIDED brakes to a stop under control; HOLD and MANUAL let the rover roll.
            if behaviour is Behaviour.GUIDED:
                self.drive.leg = None
                self.drive.stop()
            else:
                self.drive.release()
        if behaviour is Behaviour.AUTO:
            if self.mission_seq < 1 or self.mission_state == mavlink.MISSION_STATE_COMPLETE:
                self._set_seq(1)
            self._start_item()
        elif behaviour is Behaviour.RTL:
            self._aim(Goal(*self.home, land=self.profile.flies))
        elif behaviour is Behaviour.LAND:
            self._goal = Goal(self.north_m, self.east_m, land=True)

    def goto(self, north_m: float, east_m: float, alt_m: float | None = None) -> None:
        """A GUIDED position target (SET_POSITION_TARGET_GLOBAL_INT, DO_REPOSITION)."""
        if self.behaviour is not Behaviour.GUIDED:
            raise CommandRefused("Position target ignored: not in GUIDED")
        if self.profile.flies and not self.airborne:
            raise CommandRefused("Position target ignored: not flying")
        self._clear_motion()
        self.guided_target = (north_m, east_m)
        self.guided_alt_m = alt_m
        self._aim(Goal(north_m, east_m, alt_m if alt_m is not None and alt_m > 0 else None))

    def takeoff(self, alt_m: float) -> None:
        if not self.profile.flies:
            raise CommandRefused("Takeoff not supported", mavlink.MAV_RESULT_UNSUPPORTED)
        if not self.armed:
            raise CommandRefused("Takeoff: not armed")
        if self.behaviour is not Behaviour.GUIDED:
            raise CommandRefused("Takeoff: requires GUIDED")
        if self.airborne:
            raise CommandRefused("Takeoff: already flying")
        self._clear_motion()
        target = alt_m if alt_m > 0 else self.settings.takeoff_alt_m
        self._goal = Goal(self.north_m, self.east_m, target)

    def land(self) -> None:
        if not self.profile.flies:
            raise CommandRefused("Land not supported", mavlink.MAV_RESULT_UNSUPPORTED)
        self.set_mode(self.profile.mode_for(Behaviour.LAND))

    def return_to_launch(self) -> None:
        self.set_mode(self.profile.mode_for(Behaviour.RTL))

    def set_reverse(self, backwards: bool) -> None:
        """MAV_CMD_DO_SET_REVERSE: a rover drives backwards to its targets (any mode)."""
        if self.drive is None:
            raise CommandRefused("Reverse not supported", mavlink.MAV_RESULT_UNSUPPORTED)
        self.drive.reversed = backwards

    # ------------------------------------------------------------------ GCS failsafe

    def gcs_heartbeat(self) -> None:
        """A ground station's HEARTBEAT (MAV_TYPE_GCS) arrived: the failsafe is armed from
        now on, and an active one clears (the mode stays: the ground station decides)."""
        if self._gcs.heard(self.elapsed_s):
            severity = Severity.WARNING if self.profile.flies else Severity.INFO
            self._say("GCS Failsafe Cleared", severity)

    def gcs_failsafe(self, action: FailsafeAction) -> None:
        """Act on ground-station loss as ArduPilot does (see ``sitl_mock.failsafe``):
        a copter on the ground disarms, a landing goes on, a mission in AUTO goes on
        (with ``continue_auto``), else ``action``: HOLD stops here (Rover HOLD, Copter
        BRAKE), RTL returns to launch (falling back to HOLD, or LAND for a copter)."""
        self._gcs.active = True
        behaviour = self.behaviour
        if self.profile.flies and self.armed and self.landed:
            self._say("GCS Failsafe - Disarming", Severity.WARNING)
            self._disarm("Disarming motors")
            return
        if behaviour is Behaviour.AUTO and self.settings.gcs_failsafe.continue_auto:
            self._say("GCS Failsafe - Continuing Auto Mode", Severity.WARNING)
            return
        if behaviour is Behaviour.LAND:
            self._say("GCS Failsafe - Continuing Landing", Severity.WARNING)
            return
        self._say("GCS Failsafe", Severity.WARNING)
        if action is FailsafeAction.RTL:
            try:
                self.return_to_launch()
                return
            except CommandRefused:
                pass  # not ready for RTL (forced arming during start-up): the fallback
            if self.profile.flies:
                self.land()
                return
        if action is not FailsafeAction.NONE and self.profile.failsafe_hold_mode is not None:
            self.set_mode(self.profile.failsafe_hold_mode)

    def _check_fence(self) -> None:
        """A breach of the geofence (``sitl_mock.fence``), acted on once, as ArduPilot."""
        fence = self.fence
        if not (self.armed and fence.active):
            return
        inside = fence.contains(*self.lat_lon_deg)
        if inside or fence.breached:
            fence.breached = not inside
            return
        fence.breached = True
        self._say("Fence Breached", Severity.CRITICAL)
        action = int(fence.action)
        if action == FenceAction.REPORT:
            return
        if action == FenceAction.RTL:
            with contextlib.suppress(CommandRefused):
                self.return_to_launch()
                return
        if self.profile.flies:
            self.land()
        elif self.profile.failsafe_hold_mode is not None:
            self.set_mode(self.profile.failsafe_hold_mode)

    def _check_gcs_failsafe(self) -> None:
        if self._gcs.active or not self.armed or not self._gcs.overdue(self.elapsed_s):
            return
        if not self.profile.flies and self.behaviour in (Behaviour.HOLD, Behaviour.RTL):
            return  # ArduPilot Rover: no failsafe in HOLD or RTL
        self.gcs_failsafe(self.settings.gcs_failsafe.action)

    # ------------------------------------------------------------------ mission

    def replace_mission(self, items: Sequence[MissionItem]) -> None:
        """Install a whole new mission at once (uploads are atomic on the mock)."""
        self.mission = tuple(items)
        self.mission_state = (
            mavlink.MISSION_STATE_NOT_STARTED
            if len(self.mission) > 1
            else mavlink.MISSION_STATE_NO_MISSION
        )
        self._set_seq(1 if len(self.mission) > 1 else 0)
        if self.behaviour is Behaviour.AUTO:
            self._clear_motion()
            if len(self.mission) > 1:
                self._start_item()
            else:
                self._mission_finished(announce=False)

    def set_current(self, seq: int) -> None:
        if not 0 <= seq < max(1, len(self.mission)):
            raise CommandRefused(f"Mission item {seq} does not exist")
        self._set_seq(seq)
        if self.mission_state == mavlink.MISSION_STATE_COMPLETE:
            self.mission_state = mavlink.MISSION_STATE_NOT_STARTED
        if self.behaviour is Behaviour.AUTO:
            self._clear_motion()
            self._start_item()

    def start_mission(self, first: int = 1) -> None:
        if len(self.mission) < 2:
            raise CommandRefused("Mission start failed: no mission")
        self._set_seq(max(1, min(first, len(self.mission) - 1)))
        self.mission_state = mavlink.MISSION_STATE_NOT_STARTED
        self.set_mode(self.profile.mode_for(Behaviour.AUTO))

    def _at_takeoff_item(self) -> bool:
        return (
            0 < self.mission_seq < len(self.mission)
            and self.mission[self.mission_seq].command == mavlink.MAV_CMD_NAV_TAKEOFF
        )

    def _set_seq(self, seq: int) -> None:
        if seq != self.mission_seq:
            self.mission_seq = seq
            self._emit(MissionCurrentChanged(seq))

    def _start_item(self) -> None:
        """Activate ``mission[mission_seq]``; non-navigation items run at once."""
        self._item_hold_s = 0.0
        for _ in range(len(self.mission) + 1):
            if self.mission_seq >= len(self.mission) or self.mission_seq < 1:
                self._mission_finished(announce=True)
                return
            self.mission_state = mavlink.MISSION_STATE_ACTIVE
            item = self.mission[self.mission_seq]
            goal = self._goal_of(item)
            if goal is not None:
                self._aim(goal, onward=True)
                is_waypoint = item.command == mavlink.MAV_CMD_NAV_WAYPOINT
                self._item_hold_s = item.param1 if is_waypoint else 0.0
                return
            if item.command == mavlink.MAV_CMD_DO_CHANGE_SPEED and item.param2 > 0:
                self.speed_m_s = item.param2
            self._set_seq(self.mission_seq + 1)
        self._mission_finished(announce=True)

    def _goal_of(self, item: MissionItem) -> Goal | None:
        """The navigation goal of a mission item, or None for an item that just runs."""
        here_n, here_e = self.north_m, self.east_m
        if item.has_position:
            here_n, here_e = self.world.geo.geo_to_local(item.lat_deg, item.lon_deg)
        flies = self.profile.flies
        if item.command == mavlink.MAV_CMD_NAV_WAYPOINT:
            return Goal(here_n, here_e, item.z if flies and item.z > 0 else None)
        if item.command == mavlink.MAV_CMD_NAV_TAKEOFF:
            if not flies:
                return None
            alt = item.z if item.z > 0 else self.settings.takeoff_alt_m
            return Goal(self.north_m, self.east_m, alt)
        if item.command == mavlink.MAV_CMD_NAV_LAND:
            if not flies:
                return Goal(here_n, here_e) if item.has_position else None
            return Goal(here_n, here_e, land=True)
        if item.command == mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH:
            return Goal(*self.home, land=flies)
        return None

    def _mission_finished(self, announce: bool) -> None:
        self._goal = None
        if self.drive is not None:
            self.drive.stop()
        if announce:
            self.mission_state = mavlink.MISSION_STATE_COMPLETE
            self._say("Mission Complete")
        after = self.profile.mode_after_mission
        if after is not None:
            self.mode = after

    def _item_reached(self) -> None:
        self._emit(ItemReached(self.mission_seq))
        self._say(f"Reached waypoint #{self.mission_seq}")
        self._set_seq(self.mission_seq + 1)
        self._start_item()

    # ------------------------------------------------------------------ physics

    def step(self, dt_s: float) -> None:
        """Advance the vehicle by ``dt_s`` seconds of simulated time."""
        if self.dead or dt_s <= 0:
            return
        self.elapsed_s += dt_s
        self._check_gcs_failsafe()
        before = (self.north_m, self.east_m, self.alt_m)
        moved_m = self._move(dt_s) if self.armed else 0.0
        self._check_fence()
        self.velocity_ned_m_s = (
            (self.north_m - before[0]) / dt_s,
            (self.east_m - before[1]) / dt_s,
            -(self.alt_m - before[2]) / dt_s,
        )
        can_charge = not self.armed and self.landed and self.world.is_depot(self.cell)
        sag = self.battery.step(
            dt_s,
            moved_m=moved_m,
            airborne=self.airborne,
            can_charge=can_charge,
            vehicle_time_s=self.elapsed_s,
        )
        if sag > 0:
            self._say(f"Battery sag: lost {sag:.0f}%", Severity.WARNING)
        self._report_charge_state()
        self._auto_disarm(dt_s)
        if self.battery.empty:
            self._die("Battery exhausted: vehicle lost")

    def _report_charge_state(self) -> None:
        """Announce the battery failsafe as ArduPilot does (AP_BattMonitor): once per level
        reached, low then critical, as a WARNING with the pack's voltage and charge used."""
        state = self.battery.charge_state
        if state is ChargeState.CHARGING:
            self._failsafe_level = 0
            return
        level = _FAILSAFE_LEVEL.get(state, 0)
        if level > self._failsafe_level:
            b = self.battery
            name = _FAILSAFE_NAMES[level]
            used = f"{b.voltage_v:.2f}V used {b.consumed_mah:.0f} mAh"
            self._say(f"Battery 1 is {name} {used}", Severity.WARNING)
            self._failsafe_level = level

    def _auto_disarm(self, dt_s: float) -> None:
        limit = self.settings.copter_auto_disarm_s
        climbing = self.current_goal is not None and (self.current_goal.alt_m or 0.0) > 0
        if not (self.profile.flies and self.armed and self.landed) or climbing:
            self._ground_idle_s = 0.0
            return
        self._ground_idle_s += dt_s
        if limit is not None and self._ground_idle_s >= limit:
            self._disarm("Disarming motors (auto disarm)")

    def _disarm(self, text: str) -> None:
        self.armed = False
        self._ground_idle_s = 0.0
        self._say(text)

    def _die(self, reason: str) -> None:
        self.dead = True
        self.armed = False
        self.velocity_ned_m_s = (0.0, 0.0, 0.0)
        self.alt_m = 0.0
        self._say(reason, Severity.EMERGENCY)
        self._emit(VehicleDied(reason))

    def _clear_motion(self) -> None:
        self._goal = None
        self._refused_goal = None
        self._wait_s = 0.0
        self._item_hold_s = 0.0

    def _aim(self, goal: Goal, onward: bool = False) -> None:
        """Head for ``goal``; a driving rover starts a new track there (``onward``: the
        next leg of a mission, running on from the last waypoint unless it stopped)."""
        self._goal = goal
        drive = self.drive
        if drive is None:
            return
        to = (goal.north_m, goal.east_m)
        if onward and drive.leg is not None and not drive.braking:
            drive.then(to)
        else:
            drive.go(self.north_m, self.east_m, self.heading_deg, to)

    def _move(self, dt_s: float) -> float:
        if self.drive is not None:
            return self._drive(dt_s)
        goal = self.current_goal
        if goal is None:
            return 0.0
        moved = 0.0
        horizontal_left = math.hypot(goal.north_m - self.north_m, goal.east_m - self.east_m)
        if self.profile.flies:
            moved += self._move_vertically(goal, horizontal_left, dt_s)
        flies = self.profile.flies
        if not flies or (self.airborne and (self.alt_m >= _MIN_NAV_ALT_M or goal.land)):
            moved += self._move_horizontally(goal, self.speed_m_s * dt_s, dt_s)
        if self._reached(goal):
            self._on_goal_reached(goal, dt_s)
        return moved

    def _drive(self, dt_s: float) -> float:
        """One step of a rover driven as ArduPilot drives (``sitl_mock.drive``)."""
        drive = self.drive
        assert drive is not None
        leg = drive.leg
        if self._item_hold_s > 0 and leg is not None and leg.reached and drive.stopped:
            # A mission waypoint's hold time, counted once the rover has stopped.
            self._item_hold_s -= dt_s
            if self._item_hold_s <= 0:
                self._item_reached()
        goal = self._goal
        heading, travel, metres = drive.step(
            self.north_m, self.east_m, self.heading_deg, self.speed_m_s, dt_s
        )
        self.heading_deg = heading
        moved = self._advance(travel, metres, dt_s) if metres > 0 else 0.0
        if (
            goal is not None
            and self._refused_goal is None
            and drive.check_reached(self.north_m, self.east_m)
        ):
            self._on_leg_reached(goal)
        return moved

    def _on_leg_reached(self, goal: Goal) -> None:
        drive = self.drive
        assert drive is not None
        behaviour = self.behaviour
        if behaviour is Behaviour.AUTO:
            if self._item_hold_s > 0:
                drive.stop()  # stop, wait the hold time (``_drive``), then go on
                return
            self._item_reached()
            return
        drive.stop()
        if behaviour is Behaviour.GUIDED:
            self._emit(ItemReached(0))  # ArduPilot Rover: MISSION_ITEM_REACHED seq 0
        elif behaviour is Behaviour.RTL:
            self._say("Reached destination")

    def _advance(self, bearing_deg: float, metres: float, dt_s: float) -> float:
        """Drive ``metres`` along ``bearing_deg``, cell by cell; a wall or a vehicle in
        the way stops the rover at the edge of its cell."""
        h = math.radians(bearing_deg)
        un, ue = math.cos(h), math.sin(h)
        moved = 0.0
        for _ in range(10_000):
            if metres <= _EPS_M:
                break
            exit_m, ahead = self._cell_exit(un, ue)
            if metres <= exit_m + _EPS_M:
                self._shift(un, ue, metres)
                return moved + metres
            blocker = next(
                (b for b in (self.world.blocker(self.id, c) for c in ahead) if b is not None),
                None,
            )
            if blocker is not None:
                step = max(0.0, exit_m - 1e-6)
                self._shift(un, ue, step)
                if self.drive is not None:
                    self.drive.speed_m_s = 0.0
                self._blocked(blocker, dt_s)
                return moved + step
            self._shift(un, ue, exit_m)
            moved += exit_m
            metres -= exit_m
            self.world.move(self.id, ahead[-1])
            self._wait_s = 0.0
        return moved

    def _move_vertically(self, goal: Goal, horizontal_left_m: float, dt_s: float) -> float:
        if goal.land:
            if horizontal_left_m > _EPS_M:
                return 0.0
            target = 0.0
            rate = self.settings.land_rate_m_s
        else:
            target = goal.alt_m if goal.alt_m is not None else self.alt_m
            climbing = target > self.alt_m
            rate = self.settings.climb_rate_m_s if climbing else self.settings.land_rate_m_s
        step = min(abs(target - self.alt_m), rate * dt_s)
        self.alt_m += math.copysign(step, target - self.alt_m)
        if abs(self.alt_m - target) < _EPS_M:
            self.alt_m = target
        return step

    def _reached(self, goal: Goal) -> bool:
        if math.hypot(goal.north_m - self.north_m, goal.east_m - self.east_m) > _EPS_M:
            return False
        if not self.profile.flies:
            return True
        if goal.land:
            return self.alt_m <= 0.0
        return goal.alt_m is None or abs(goal.alt_m - self.alt_m) < _EPS_M

    def _on_goal_reached(self, goal: Goal, dt_s: float) -> None:
        if goal is self._refused_goal:
            return  # stopped after a refused move: hold here until told otherwise
        if goal.land and self.armed:
            self._say("Land complete")
            self._disarm("Disarming motors")
        behaviour = self.behaviour
        if behaviour is Behaviour.AUTO:
            if self._item_hold_s > 0:  # a waypoint's hold time (param1), then move on
                self._item_hold_s -= dt_s
                return
            self._item_reached()
        elif behaviour is Behaviour.RTL:
            if not self.profile.flies:
                self._say("Reached destination")
            self._goal = None
        else:
            self._goal = None

    # ------------------------------------------------------------------ horizontal motion

    def _move_horizontally(self, goal: Goal, budget_m: float, dt_s: float) -> float:
        """Drive straight toward the goal cell by cell; returns the distance covered."""
        dn, de = goal.north_m - self.north_m, goal.east_m - self.east_m
        dist = math.hypot(dn, de)
        moved = 0.0
        if dist > _EPS_M and budget_m > _EPS_M:
            self.heading_deg = bearing_deg(dn, de)
            moved = self._advance(self.heading_deg, min(budget_m, dist), dt_s)
        if math.hypot(goal.north_m - self.north_m, goal.east_m - self.east_m) <= _EPS_M:
            self.north_m, self.east_m = goal.north_m, goal.east_m
        return moved

    def _shift(self, un: float, ue: float, metres: float) -> None:
        self.north_m += un * metres
        self.east_m += ue * metres

    def _cell_exit(self, un: float, ue: float) -> tuple[float, list[Cell]]:
        """Metres to the edge of the held cell along (un, ue), and the cells met there
        (for an exact corner: both side cells and the diagonal one, the diagonal last)."""
        cs = self.world.cell_size_m
        r, c = self.cell
        col_f, row_f = self.east_m / cs, -self.north_m / cs
        d_col, d_row = ue, -un
        step_c, t_c = axis_exit(col_f, c, d_col)
        step_r, t_r = axis_exit(row_f, r, d_row)
        t_c, t_r = max(0.0, t_c), max(0.0, t_r)
        if abs(t_c - t_r) <= _TIE:
            return t_c * cs, [(r, c + step_c), (r + step_r, c), (r + step_r, c + step_c)]
        if t_c < t_r:
            return t_c * cs, [(r, c + step_c)]
        return t_r * cs, [(r + step_r, c)]

    def _blocked(self, blocker: Blocker, dt_s: float) -> None:
        if blocker.reason is BlockReason.VEHICLE and self._refused_goal is None:
            self._wait_s += dt_s
            if self._wait_s < self.settings.yield_timeout_s:
                return
        self._wait_s = 0.0
        self._say(f"Move refused: {blocker.describe()}; stopping", Severity.WARNING)
        if self.drive is not None:
            self.drive.halt()  # stopped at the edge of its cell, where it stands
            self._refused_goal = Goal(self.north_m, self.east_m)
            return
        centre = self.world.geo.cell_centre_local(self.cell)
        self._refused_goal = Goal(centre[0], centre[1])
        if self.behaviour is Behaviour.AUTO:
            self.mission_state = mavlink.MISSION_STATE_PAUSED
