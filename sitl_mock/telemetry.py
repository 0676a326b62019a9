"""Telemetry messages of a mock vehicle, built from its state (pure: state in, message out).

Field conventions follow ArduPilot: HEARTBEAT with autopilot ARDUPILOTMEGA
and the custom mode; battery in SYS_STATUS (mV, cA, %) and BATTERY_STATUS
(cell voltages, consumed mAh, charge state; ``time_remaining`` 0 =
unsupported); range readings as one DISTANCE_SENSOR per 45-degree sector
(orientation relative to the heading) and one OBSTACLE_DISTANCE of 72
five-degree sectors.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TypeAlias

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sitl_mock.modes import Behaviour
from sitl_mock.ranging import sector_distances_m
from sitl_mock.vehicle import Vehicle

Message: TypeAlias = mavlink.MAVLink_message
Builder = Callable[[mavlink.MAVLink, Vehicle], list[Message]]

UINT16_MAX = 65535
INT16_MAX = 32767
MIN_RANGE_CM = 10
OBSTACLE_SECTORS = 72
#: Pretend firmware version 4.6.0, official.
FLIGHT_SW_VERSION = (4 << 24) | (6 << 16) | (0 << 8) | mavlink.FIRMWARE_VERSION_TYPE_OFFICIAL
CAPABILITIES = (
    mavlink.MAV_PROTOCOL_CAPABILITY_MISSION_FLOAT
    | mavlink.MAV_PROTOCOL_CAPABILITY_MISSION_INT
    | mavlink.MAV_PROTOCOL_CAPABILITY_COMMAND_INT
    | mavlink.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_GLOBAL_INT
    | mavlink.MAV_PROTOCOL_CAPABILITY_MAVLINK2
)
_SENSORS = (
    mavlink.MAV_SYS_STATUS_SENSOR_3D_GYRO
    | mavlink.MAV_SYS_STATUS_SENSOR_3D_ACCEL
    | mavlink.MAV_SYS_STATUS_SENSOR_GPS
    | mavlink.MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS
    | mavlink.MAV_SYS_STATUS_AHRS
    | mavlink.MAV_SYS_STATUS_SENSOR_BATTERY
)
_SECTOR_ORIENTATIONS = (
    mavlink.MAV_SENSOR_ROTATION_NONE,
    mavlink.MAV_SENSOR_ROTATION_YAW_45,
    mavlink.MAV_SENSOR_ROTATION_YAW_90,
    mavlink.MAV_SENSOR_ROTATION_YAW_135,
    mavlink.MAV_SENSOR_ROTATION_YAW_180,
    mavlink.MAV_SENSOR_ROTATION_YAW_225,
    mavlink.MAV_SENSOR_ROTATION_YAW_270,
    mavlink.MAV_SENSOR_ROTATION_YAW_315,
)


def _boot_ms(v: Vehicle) -> int:
    return int(v.elapsed_s * 1000) & 0xFFFFFFFF


def centiamps(current_a: float) -> int:
    """Current in cA as SYS_STATUS and BATTERY_STATUS carry it (int16): saturated, since a
    value out of range would make ``pack`` raise and kill the telemetry stream."""
    return max(-INT16_MAX, min(INT16_MAX, round(current_a * 100)))


def battery_pct(v: Vehicle) -> int:
    """Whole percent, rounded up so that 0 means empty (a dead vehicle)."""
    return min(100, math.ceil(v.battery.remaining_pct))


def heartbeat(codec: mavlink.MAVLink, v: Vehicle) -> list[Message]:
    base = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | mavlink.MAV_MODE_FLAG_STABILIZE_ENABLED
    if v.behaviour is Behaviour.MANUAL:
        base |= mavlink.MAV_MODE_FLAG_MANUAL_INPUT_ENABLED
    if v.behaviour in (Behaviour.AUTO, Behaviour.GUIDED, Behaviour.RTL, Behaviour.LAND):
        base |= mavlink.MAV_MODE_FLAG_GUIDED_ENABLED
    if v.behaviour is Behaviour.AUTO:
        base |= mavlink.MAV_MODE_FLAG_AUTO_ENABLED
    if v.armed:
        base |= mavlink.MAV_MODE_FLAG_SAFETY_ARMED
    if not v.ready:
        status = mavlink.MAV_STATE_BOOT
    elif v.armed:
        status = mavlink.MAV_STATE_ACTIVE
    else:
        status = mavlink.MAV_STATE_STANDBY
    return [
        codec.heartbeat_encode(
            v.profile.mav_type, mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA, base, int(v.mode), status
        )
    ]


def global_position_int(codec: mavlink.MAVLink, v: Vehicle) -> list[Message]:
    lat, lon = v.reported_lat_lon_deg
    vn, ve, vd = v.velocity_ned_m_s
    return [
        codec.global_position_int_encode(
            _boot_ms(v),
            round(lat * 1e7),
            round(lon * 1e7),
            round((v.world.geo.alt_m + v.alt_m) * 1000),
            round(v.alt_m * 1000),
            round(vn * 100),
            round(ve * 100),
            round(vd * 100),
            round(v.heading_deg * 100) % 36000,
        )
    ]


def attitude(codec: mavlink.MAVLink, v: Vehicle) -> list[Message]:
    yaw = math.radians(v.heading_deg)
    yaw = math.atan2(math.sin(yaw), math.cos(yaw))
    return [codec.attitude_encode(_boot_ms(v), 0.0, 0.0, yaw, 0.0, 0.0, 0.0)]


def sys_status(codec: mavlink.MAVLink, v: Vehicle) -> list[Message]:
    present = _SENSORS | (
        mavlink.MAV_SYS_STATUS_SENSOR_PROXIMITY if v.settings.range_sensing else 0
    )
    healthy = present if v.ready else present & ~mavlink.MAV_SYS_STATUS_SENSOR_GPS
    b = v.battery
    return [
        codec.sys_status_encode(
            present,
            present,
            healthy,
            0,
            round(b.voltage_v * 1000),
            centiamps(b.current_a),
            battery_pct(v),
            0,
            0,
            0,
            0,
            0,
            0,
        )
    ]


def battery_status(codec: mavlink.MAVLink, v: Vehicle) -> list[Message]:
    b = v.battery
    voltages = [min(UINT16_MAX - 1, round(b.voltage_v * 1000))] + [UINT16_MAX] * 9
    return [
        codec.battery_status_encode(
            0,
            mavlink.MAV_BATTERY_FUNCTION_ALL,
            mavlink.MAV_BATTERY_TYPE_LIPO,
            INT16_MAX,
            voltages,
            centiamps(b.current_a),
            round(b.consumed_mah),
            -1,
            battery_pct(v),
            0,
            int(b.charge_state),
        )
    ]


def gps_raw_int(codec: mavlink.MAVLink, v: Vehicle) -> list[Message]:
    lat, lon = v.reported_lat_lon_deg
    vn, ve, _ = v.velocity_ned_m_s
    fix = mavlink.GPS_FIX_TYPE_3D_FIX if v.ready else mavlink.GPS_FIX_TYPE_NO_FIX
    return [
        codec.gps_raw_int_encode(
            int(v.elapsed_s * 1e6),
            fix,
            round(lat * 1e7),
            round(lon * 1e7),
            round((v.world.geo.alt_m + v.alt_m) * 1000),
            80,
            120,
            round(math.hypot(vn, ve) * 100),
            round(v.heading_deg * 100) % 36000,
            12 if v.ready else 0,
        )
    ]


def extended_sys_state(codec: mavlink.MAVLink, v: Vehicle) -> list[Message]:
    if not v.profile.flies or v.landed:
        landed = mavlink.MAV_LANDED_STATE_ON_GROUND
    elif v.velocity_ned_m_s[2] < 0:
        landed = mavlink.MAV_LANDED_STATE_TAKEOFF
    elif v.velocity_ned_m_s[2] > 0:
        landed = mavlink.MAV_LANDED_STATE_LANDING
    else:
        landed = mavlink.MAV_LANDED_STATE_IN_AIR
    return [codec.extended_sys_state_encode(mavlink.MAV_VTOL_STATE_UNDEFINED, landed)]


def mission_current(codec: mavlink.MAVLink, v: Vehicle) -> list[Message]:
    total = len(v.mission) - 1 if v.mission else UINT16_MAX
    return [codec.mission_current_encode(v.mission_seq, total, v.mission_state)]


def home_position(codec: mavlink.MAVLink, v: Vehicle) -> list[Message]:
    """Only once the position estimate uses GPS (ArduPilot sets home then)."""
    if not v.ready:
        return []
    lat, lon = v.world.geo.local_to_geo(*v.home)
    return [
        codec.home_position_encode(
            round(lat * 1e7),
            round(lon * 1e7),
            round(v.world.geo.alt_m * 1000),
            0.0,
            0.0,
            0.0,
            [1.0, 0.0, 0.0, 0.0],
            0.0,
            0.0,
            0.0,
            int(v.elapsed_s * 1e6),
        )
    ]


def position_target_global_int(codec: mavlink.MAVLink, v: Vehicle) -> list[Message]:
    """The guided target the vehicle steers to, as ArduPilot reports it in GUIDED (kept
    after it is reached, until the mode changes); nothing without one."""
    target = v.guided_target
    if target is None or v.behaviour is not Behaviour.GUIDED:
        return []
    lat, lon = v.world.geo.local_to_geo(*target)
    ignore = (
        mavlink.POSITION_TARGET_TYPEMASK_VX_IGNORE
        | mavlink.POSITION_TARGET_TYPEMASK_VY_IGNORE
        | mavlink.POSITION_TARGET_TYPEMASK_VZ_IGNORE
        | mavlink.POSITION_TARGET_TYPEMASK_AX_IGNORE
        | mavlink.POSITION_TARGET_TYPEMASK_AY_IGNORE
        | mavlink.POSITION_TARGET_TYPEMASK_AZ_IGNORE
        | mavlink.POSITION_TARGET_TYPEMASK_YAW_IGNORE
        | mavlink.POSITION_TARGET_TYPEMASK_YAW_RATE_IGNORE
    )
    alt = v.world.geo.alt_m + (v.guided_alt_m or 0.0)
    return [
        codec.position_target_global_int_encode(
            _boot_ms(v),
            mavlink.MAV_FRAME_GLOBAL,
            ignore,
            round(lat * 1e7),
            round(lon * 1e7),
            alt,
            0,
            0,
            0,
            0,
            0,
            0,
            0,
            0,
        )
    ]


def autopilot_version(codec: mavlink.MAVLink, v: Vehicle) -> list[Message]:
    return [
        codec.autopilot_version_encode(
            CAPABILITIES, FLIGHT_SW_VERSION, 0, 0, 0, [0] * 8, [0] * 8, [0] * 8, 0, 0, v.id
        )
    ]


def distance_sensors(codec: mavlink.MAVLink, v: Vehicle) -> list[Message]:
    """One DISTANCE_SENSOR per 45-degree sector, clockwise from the heading."""
    if not v.settings.range_sensing:
        return []
    max_m = v.settings.range_max_m
    ranges = sector_distances_m(
        v.world.map, v.world.cell_size_m, v.north_m, v.east_m, v.heading_deg, 8, max_m
    )
    return [
        codec.distance_sensor_encode(
            _boot_ms(v),
            MIN_RANGE_CM,
            round(max_m * 100),
            round(r * 100),
            mavlink.MAV_DISTANCE_SENSOR_LASER,
            i,
            orientation,
            0,
            math.radians(45.0),
            math.radians(10.0),
        )
        for i, (orientation, r) in enumerate(zip(_SECTOR_ORIENTATIONS, ranges, strict=True))
    ]


def obstacle_distance(codec: mavlink.MAVLink, v: Vehicle) -> list[Message]:
    """72 sectors of 5 degrees in the body frame; max range + 1 cm means nothing seen."""
    if not v.settings.range_sensing:
        return []
    max_m = v.settings.range_max_m
    max_cm = round(max_m * 100)
    ranges = sector_distances_m(
        v.world.map,
        v.world.cell_size_m,
        v.north_m,
        v.east_m,
        v.heading_deg,
        OBSTACLE_SECTORS,
        max_m,
    )
    distances = [max_cm + 1 if r >= max_m else round(r * 100) for r in ranges]
    increment = 360.0 / OBSTACLE_SECTORS
    return [
        codec.obstacle_distance_encode(
            int(v.elapsed_s * 1e6),
            mavlink.MAV_DISTANCE_SENSOR_LASER,
            distances,
            round(increment),
            MIN_RANGE_CM,
            max_cm,
            increment,
            0.0,
            mavlink.MAV_FRAME_BODY_FRD,
        )
    ]


#: Message id -> builder, for streams and MAV_CMD_REQUEST_MESSAGE.
BUILDERS: dict[int, Builder] = {
    mavlink.MAVLINK_MSG_ID_HEARTBEAT: heartbeat,
    mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT: global_position_int,
    mavlink.MAVLINK_MSG_ID_ATTITUDE: attitude,
    mavlink.MAVLINK_MSG_ID_SYS_STATUS: sys_status,
    mavlink.MAVLINK_MSG_ID_BATTERY_STATUS: battery_status,
    mavlink.MAVLINK_MSG_ID_GPS_RAW_INT: gps_raw_int,
    mavlink.MAVLINK_MSG_ID_EXTENDED_SYS_STATE: extended_sys_state,
    mavlink.MAVLINK_MSG_ID_MISSION_CURRENT: mission_current,
    mavlink.MAVLINK_MSG_ID_HOME_POSITION: home_position,
    mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION: autopilot_version,
    mavlink.MAVLINK_MSG_ID_DISTANCE_SENSOR: distance_sensors,
    mavlink.MAVLINK_MSG_ID_OBSTACLE_DISTANCE: obstacle_distance,
    mavlink.MAVLINK_MSG_ID_POSITION_TARGET_GLOBAL_INT: position_target_global_int,
}

#: Default stream intervals (simulated seconds); messages not listed are sent on request only.
DEFAULT_INTERVALS_S: dict[int, float] = {
    mavlink.MAVLINK_MSG_ID_HEARTBEAT: 1.0,
    mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT: 0.25,
    mavlink.MAVLINK_MSG_ID_ATTITUDE: 0.25,
    mavlink.MAVLINK_MSG_ID_SYS_STATUS: 1.0,
    mavlink.MAVLINK_MSG_ID_BATTERY_STATUS: 1.0,
    mavlink.MAVLINK_MSG_ID_GPS_RAW_INT: 1.0,
    mavlink.MAVLINK_MSG_ID_EXTENDED_SYS_STATE: 1.0,
    mavlink.MAVLINK_MSG_ID_MISSION_CURRENT: 1.0,
    mavlink.MAVLINK_MSG_ID_DISTANCE_SENSOR: 0.5,
    mavlink.MAVLINK_MSG_ID_OBSTACLE_DISTANCE: 0.5,
    mavlink.MAVLINK_MSG_ID_POSITION_TARGET_GLOBAL_INT: 1.0,
}
