"""What a mock vehicle tells the outside world as it happens (the endpoint turns these into
STATUSTEXT, MISSION_ITEM_REACHED and MISSION_CURRENT)."""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum

from pymavlink.dialects.v20 import ardupilotmega as mavlink


class Severity(IntEnum):
    EMERGENCY = mavlink.MAV_SEVERITY_EMERGENCY
    ALERT = mavlink.MAV_SEVERITY_ALERT
    CRITICAL = mavlink.MAV_SEVERITY_CRITICAL
    ERROR = mavlink.MAV_SEVERITY_ERROR
    WARNING = mavlink.MAV_SEVERITY_WARNING
    NOTICE = mavlink.MAV_SEVERITY_NOTICE
    INFO = mavlink.MAV_SEVERITY_INFO


@dataclass(frozen=True)
class StatusText:
    severity: Severity
    text: str


@dataclass(frozen=True)
class ItemReached:
    seq: int


@dataclass(frozen=True)
class MissionCurrentChanged:
    seq: int


@dataclass(frozen=True)
class VehicleDied:
    reason: str


VehicleEvent = StatusText | ItemReached | MissionCurrentChanged | VehicleDied
