"""Telemetry values, the cache of the latest ones, and async streams of updates.

The cache understands the common messages that ArduPilot, PX4 and MAVSDK
send (GLOBAL_POSITION_INT, SYS_STATUS, BATTERY_STATUS, DISTANCE_SENSOR,
OBSTACLE_DISTANCE, MISSION_CURRENT, MISSION_ITEM_REACHED, STATUSTEXT,
HEARTBEAT); each is handled by one function in a table keyed on message type.
Unknown values (-1, UINT16_MAX on the wire) become ``None``.
"""

from __future__ import annotations

import asyncio
import contextlib
import math
from collections import defaultdict
from collections.abc import AsyncGenerator, Callable
from dataclasses import dataclass, field, replace
from enum import StrEnum
from typing import Any, TypeAlias

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from vehicles.models import VehicleProfile, profile_from_heartbeat
from vehicles.modes import FlightMode
from vehicles.printable import printable

Message: TypeAlias = mavlink.MAVLink_message
UINT16_MAX = 65535
STREAM_QUEUE_SIZE = 64


class Topic(StrEnum):
    STATUS = "status"
    POSITION = "position"
    BATTERY = "battery"
    RANGE = "range"
    OBSTACLES = "obstacles"
    MISSION = "mission"
    STATUSTEXT = "statustext"
    #: ``GpsFix``: GPS_RAW_INT.
    GPS = "gps"
    #: ``Home``: HOME_POSITION (set once the position estimate uses GPS).
    HOME = "home"
    #: ``GuidedTarget``: where the vehicle steers to (POSITION_TARGET_GLOBAL_INT).
    TARGET = "target"
    #: ``LinkEvent`` values: the vehicle's heartbeat appeared or was lost.
    LINK = "link"


@dataclass(frozen=True)
class VehicleStatus:
    """What the last HEARTBEAT said."""

    system_id: int
    component_id: int
    mav_type: int
    autopilot: int
    base_mode: int
    custom_mode: int
    system_status: int
    armed: bool
    mode_name: str
    flight_mode: FlightMode | None

    @property
    def type_name(self) -> str:
        return _enum_name("MAV_TYPE", self.mav_type, "MAV_TYPE_")

    @property
    def autopilot_name(self) -> str:
        return _enum_name("MAV_AUTOPILOT", self.autopilot, "MAV_AUTOPILOT_")


@dataclass(frozen=True)
class Position:
    lat_deg: float
    lon_deg: float
    alt_msl_m: float
    alt_rel_m: float
    heading_deg: float | None
    vn_m_s: float
    ve_m_s: float
    vd_m_s: float
    time_boot_ms: int


@dataclass(frozen=True)
class Battery:
    remaining_pct: float | None = None
    voltage_v: float | None = None
    current_a: float | None = None
    consumed_mah: float | None = None
    #: MAV_BATTERY_CHARGE_STATE, when BATTERY_STATUS gave one.
    charge_state: int | None = None


@dataclass(frozen=True)
class RangeReading:
    """One DISTANCE_SENSOR sample; ``orientation`` is MAV_SENSOR_ORIENTATION
    (NONE = forward, YAW_45 ... YAW_315 clockwise), relative to the heading."""

    orientation: int
    distance_m: float
    min_m: float
    max_m: float
    sensor_id: int
    time_boot_ms: int


@dataclass(frozen=True)
class ObstacleDistances:
    """OBSTACLE_DISTANCE: ranges in sectors clockwise from ``angle_offset_deg``;
    ``None`` where nothing was measured (UINT16_MAX on the wire)."""

    distances_m: tuple[float | None, ...]
    increment_deg: float
    angle_offset_deg: float
    min_m: float
    max_m: float
    frame: int
    time_usec: int


@dataclass(frozen=True)
class MissionProgress:
    current_seq: int | None = None
    total: int | None = None
    last_reached_seq: int | None = None


@dataclass(frozen=True)
class GpsFix:
    """GPS_RAW_INT: ``fix_type`` is GPS_FIX_TYPE (3 and up: a 3D fix)."""

    fix_type: int
    satellites: int | None

    @property
    def has_3d_fix(self) -> bool:
        return self.fix_type >= mavlink.GPS_FIX_TYPE_3D_FIX


@dataclass(frozen=True)
class Home:
    lat_deg: float
    lon_deg: float
    alt_msl_m: float


@dataclass(frozen=True)
class GuidedTarget:
    """Where the vehicle reports it is steering to; ``time_boot_ms`` of the report."""

    lat_deg: float
    lon_deg: float
    time_boot_ms: int


@dataclass(frozen=True)
class StatusText:
    severity: int
    text: str


def _enum_name(enum: str, value: int, prefix: str) -> str:
    entry = mavlink.enums.get(enum, {}).get(value)
    return entry.name.removeprefix(prefix) if entry is not None else str(value)


def _none_if(value: float, *unknown: float) -> float | None:
    return None if value in unknown else value


class ImplausibleTelemetry(ValueError):
    """A message carrying a value no vehicle can have (battery at 127 %, latitude 1e30,
    a NaN): refused whole, so that nothing of it reaches the planner."""


#: Fastest a vehicle of ours can move (m/s): faster is a broken or lying sender.
MAX_SPEED_M_S = 150.0


def _check(ok: bool, what: str) -> None:
    if not ok:
        raise ImplausibleTelemetry(what)


def _check_lat_lon(lat_deg: float, lon_deg: float) -> None:
    _check(-90.0 <= lat_deg <= 90.0 and -180.0 <= lon_deg <= 180.0, "position off the Earth")


def _check_finite(*values: float) -> None:
    _check(all(math.isfinite(v) for v in values), "a value that is not a number")


def _check_pct(remaining: float | None) -> None:
    _check(remaining is None or 0 <= remaining <= 100, "battery outside 0-100 %")


@dataclass
class TelemetryCache:
    """The latest telemetry of one vehicle. ``update`` returns the topic it changed."""

    profile: VehicleProfile | None = None
    status: VehicleStatus | None = None
    position: Position | None = None
    battery: Battery = field(default_factory=Battery)
    ranges: dict[int, RangeReading] = field(default_factory=dict)
    obstacles: ObstacleDistances | None = None
    mission: MissionProgress = field(default_factory=MissionProgress)
    statustext: StatusText | None = None
    gps: GpsFix | None = None
    home: Home | None = None
    target: GuidedTarget | None = None

    def update(self, msg: Message) -> tuple[Topic, Any] | None:
        """Take in one message; ``ImplausibleTelemetry`` (and nothing cached) when it
        carries a value out of physical range."""
        handler = _HANDLERS.get(msg.get_type())
        return None if handler is None else handler(self, msg)

    # -- handlers ---------------------------------------------------------------------

    def _on_heartbeat(self, msg: Message) -> tuple[Topic, Any] | None:
        if msg.type == mavlink.MAV_TYPE_GCS or msg.autopilot == mavlink.MAV_AUTOPILOT_INVALID:
            return None
        profile = profile_from_heartbeat(msg.type, msg.autopilot)
        if profile is not None:
            self.profile = profile
        if self.profile is not None:
            kind, flavour = self.profile.kind, self.profile.flavour
            mode_name = flavour.mode_name(kind, msg.custom_mode)
            flight_mode = flavour.flight_mode(kind, msg.custom_mode)
        else:
            mode_name, flight_mode = f"MODE_{msg.custom_mode}", None
        self.status = VehicleStatus(
            system_id=msg.get_srcSystem(),
            component_id=msg.get_srcComponent(),
            mav_type=msg.type,
            autopilot=msg.autopilot,
            base_mode=msg.base_mode,
            custom_mode=msg.custom_mode,
            system_status=msg.system_status,
            armed=bool(msg.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED),
            mode_name=mode_name,
            flight_mode=flight_mode,
        )
        return Topic.STATUS, self.status

    def _on_global_position_int(self, msg: Message) -> tuple[Topic, Any]:
        _check_lat_lon(msg.lat / 1e7, msg.lon / 1e7)
        _check(msg.hdg <= 36000 or msg.hdg == UINT16_MAX, "heading beyond 360 degrees")
        speed = math.sqrt(msg.vx**2 + msg.vy**2 + msg.vz**2) / 100.0
        _check(speed <= MAX_SPEED_M_S, "speed beyond any vehicle's")
        self.position = Position(
            lat_deg=msg.lat / 1e7,
            lon_deg=msg.lon / 1e7,
            alt_msl_m=msg.alt / 1000.0,
            alt_rel_m=msg.relative_alt / 1000.0,
            heading_deg=None if msg.hdg == UINT16_MAX else msg.hdg / 100.0,
            vn_m_s=msg.vx / 100.0,
            ve_m_s=msg.vy / 100.0,
            vd_m_s=msg.vz / 100.0,
            time_boot_ms=msg.time_boot_ms,
        )
        return Topic.POSITION, self.position

    def _on_sys_status(self, msg: Message) -> tuple[Topic, Any]:
        remaining = _none_if(msg.battery_remaining, -1)
        _check_pct(remaining)
        voltage = _none_if(msg.voltage_battery, UINT16_MAX)
        current = _none_if(msg.current_battery, -1)
        self.battery = replace(
            self.battery,
            remaining_pct=self.battery.remaining_pct if remaining is None else float(remaining),
            voltage_v=self.battery.voltage_v if voltage is None else voltage / 1000.0,
            current_a=self.battery.current_a if current is None else current / 100.0,
        )
        return Topic.BATTERY, self.battery

    def _on_battery_status(self, msg: Message) -> tuple[Topic, Any] | None:
        if msg.id != 0:
            return None
        remaining = _none_if(msg.battery_remaining, -1)
        _check_pct(remaining)
        voltage = _none_if(msg.voltages[0], UINT16_MAX)
        current = _none_if(msg.current_battery, -1)
        consumed = _none_if(msg.current_consumed, -1)
        _check(consumed is None or consumed >= 0, "negative charge consumed")
        old = self.battery
        self.battery = Battery(
            remaining_pct=old.remaining_pct if remaining is None else float(remaining),
            voltage_v=old.voltage_v if voltage is None else voltage / 1000.0,
            current_a=old.current_a if current is None else current / 100.0,
            consumed_mah=old.consumed_mah if consumed is None else float(consumed),
            charge_state=getattr(msg, "charge_state", None) or old.charge_state,
        )
        return Topic.BATTERY, self.battery

    def _on_distance_sensor(self, msg: Message) -> tuple[Topic, Any]:
        _check(msg.max_distance > 0 and msg.min_distance <= msg.max_distance, "range limits")
        reading = RangeReading(
            orientation=msg.orientation,
            distance_m=msg.current_distance / 100.0,
            min_m=msg.min_distance / 100.0,
            max_m=msg.max_distance / 100.0,
            sensor_id=msg.id,
            time_boot_ms=msg.time_boot_ms,
        )
        self.ranges[msg.orientation] = reading
        return Topic.RANGE, reading

    def _on_obstacle_distance(self, msg: Message) -> tuple[Topic, Any]:
        _check_finite(msg.increment_f, msg.angle_offset)
        _check(msg.max_distance > 0 and msg.min_distance <= msg.max_distance, "range limits")
        increment = msg.increment_f or float(msg.increment)
        self.obstacles = ObstacleDistances(
            distances_m=tuple(None if d == UINT16_MAX else d / 100.0 for d in msg.distances),
            increment_deg=increment,
            angle_offset_deg=msg.angle_offset,
            min_m=msg.min_distance / 100.0,
            max_m=msg.max_distance / 100.0,
            frame=msg.frame,
            time_usec=msg.time_usec,
        )
        return Topic.OBSTACLES, self.obstacles

    def _on_mission_current(self, msg: Message) -> tuple[Topic, Any]:
        total = getattr(msg, "total", 0)
        self.mission = replace(
            self.mission,
            current_seq=msg.seq,
            total=None if total in (0, UINT16_MAX) else total,
        )
        return Topic.MISSION, self.mission

    def _on_mission_item_reached(self, msg: Message) -> tuple[Topic, Any]:
        self.mission = replace(self.mission, last_reached_seq=msg.seq)
        return Topic.MISSION, self.mission

    def _on_statustext(self, msg: Message) -> tuple[Topic, Any]:
        text = msg.text
        if isinstance(text, bytes):
            text = text.decode("utf-8", errors="replace")
        self.statustext = StatusText(severity=msg.severity, text=printable(text.rstrip("\x00")))
        return Topic.STATUSTEXT, self.statustext

    def _on_gps_raw_int(self, msg: Message) -> tuple[Topic, Any]:
        satellites = _none_if(msg.satellites_visible, 255)
        self.gps = GpsFix(int(msg.fix_type), None if satellites is None else int(satellites))
        return Topic.GPS, self.gps

    def _on_home_position(self, msg: Message) -> tuple[Topic, Any]:
        _check_lat_lon(msg.latitude / 1e7, msg.longitude / 1e7)
        self.home = Home(msg.latitude / 1e7, msg.longitude / 1e7, msg.altitude / 1000.0)
        return Topic.HOME, self.home

    def _on_position_target_global_int(self, msg: Message) -> tuple[Topic, Any]:
        _check_lat_lon(msg.lat_int / 1e7, msg.lon_int / 1e7)
        self.target = GuidedTarget(msg.lat_int / 1e7, msg.lon_int / 1e7, msg.time_boot_ms)
        return Topic.TARGET, self.target


_HANDLERS: dict[str, Callable[[TelemetryCache, Message], tuple[Topic, Any] | None]] = {
    "HEARTBEAT": TelemetryCache._on_heartbeat,
    "GLOBAL_POSITION_INT": TelemetryCache._on_global_position_int,
    "SYS_STATUS": TelemetryCache._on_sys_status,
    "BATTERY_STATUS": TelemetryCache._on_battery_status,
    "DISTANCE_SENSOR": TelemetryCache._on_distance_sensor,
    "OBSTACLE_DISTANCE": TelemetryCache._on_obstacle_distance,
    "MISSION_CURRENT": TelemetryCache._on_mission_current,
    "MISSION_ITEM_REACHED": TelemetryCache._on_mission_item_reached,
    "STATUSTEXT": TelemetryCache._on_statustext,
    "GPS_RAW_INT": TelemetryCache._on_gps_raw_int,
    "HOME_POSITION": TelemetryCache._on_home_position,
    "POSITION_TARGET_GLOBAL_INT": TelemetryCache._on_position_target_global_int,
}
#: Message types the cache understands.
TELEMETRY_MESSAGES = frozenset(_HANDLERS)


class TopicStreams:
    """Fan-out of updates to async iterators; each subscriber has its own bounded
    queue (oldest dropped when a slow reader falls behind) and unsubscribes when
    its iterator is closed."""

    def __init__(self) -> None:
        self._subscribers: dict[str, set[asyncio.Queue[Any]]] = defaultdict(set)

    def publish(self, topic: str, value: Any) -> None:
        for queue in self._subscribers.get(topic, ()):
            if queue.full():
                queue.get_nowait()
            queue.put_nowait(value)

    def subscriber_count(self, topic: str) -> int:
        return len(self._subscribers.get(topic, ()))

    async def stream(self, topic: str, size: int = STREAM_QUEUE_SIZE) -> AsyncGenerator[Any, None]:
        """Values published on ``topic`` from now on. Close it (``aclose()``, or
        ``contextlib.aclosing``) or break out of ``async for`` to unsubscribe."""
        queue: asyncio.Queue[Any] = asyncio.Queue(size)
        self._subscribers[topic].add(queue)
        try:
            while True:
                yield await queue.get()
        finally:
            with contextlib.suppress(KeyError):
                self._subscribers[topic].remove(queue)
