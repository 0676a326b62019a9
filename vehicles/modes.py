"""Flight modes: what the ground station asks for, and how each autopilot numbers them.

The ground station thinks in ``FlightMode`` (MANUAL, HOLD, AUTO, GUIDED, RTL,
LAND, TAKEOFF). Each autopilot flavour (``vehicles.autopilots``) maps those to
its own custom modes, listed here as enums.
"""

from __future__ import annotations

from enum import IntEnum, StrEnum


class VehicleKind(StrEnum):
    ROVER = "rover"
    COPTER = "copter"


class FlightMode(StrEnum):
    """Autopilot-independent modes the ground station uses."""

    MANUAL = "MANUAL"
    HOLD = "HOLD"
    AUTO = "AUTO"
    GUIDED = "GUIDED"
    RTL = "RTL"
    LAND = "LAND"
    TAKEOFF = "TAKEOFF"


class ArduRoverMode(IntEnum):
    """ArduPilot Rover custom modes (HEARTBEAT.custom_mode)."""

    MANUAL = 0
    ACRO = 1
    STEERING = 3
    HOLD = 4
    LOITER = 5
    FOLLOW = 6
    SIMPLE = 7
    DOCK = 8
    CIRCLE = 9
    AUTO = 10
    RTL = 11
    SMART_RTL = 12
    GUIDED = 15
    INITIALISING = 16


class ArduCopterMode(IntEnum):
    """ArduPilot Copter custom modes (HEARTBEAT.custom_mode)."""

    STABILIZE = 0
    ACRO = 1
    ALT_HOLD = 2
    AUTO = 3
    GUIDED = 4
    LOITER = 5
    RTL = 6
    CIRCLE = 7
    LAND = 9
    DRIFT = 11
    SPORT = 13
    FLIP = 14
    AUTOTUNE = 15
    POSHOLD = 16
    BRAKE = 17
    THROW = 18
    AVOID_ADSB = 19
    GUIDED_NOGPS = 20
    SMART_RTL = 21


class Px4MainMode(IntEnum):
    MANUAL = 1
    ALTCTL = 2
    POSCTL = 3
    AUTO = 4
    ACRO = 5
    OFFBOARD = 6
    STABILIZED = 7
    RATTITUDE = 8


class Px4AutoSubMode(IntEnum):
    READY = 1
    TAKEOFF = 2
    LOITER = 3
    MISSION = 4
    RTL = 5
    LAND = 6
    FOLLOW_TARGET = 8
    PRECLAND = 9


def px4_custom_mode(main: int, sub: int = 0) -> int:
    """PX4's HEARTBEAT.custom_mode: main mode in bits 16-23, sub mode in bits 24-31."""
    return (main << 16) | (sub << 24)


def px4_split_custom_mode(custom_mode: int) -> tuple[int, int]:
    """(main, sub) of a PX4 custom mode."""
    return (custom_mode >> 16) & 0xFF, (custom_mode >> 24) & 0xFF
