"""ArduPilot flight modes of the mock vehicles, one table per vehicle kind.

The vehicle reports ArduPilot's custom mode numbers; inside, each mode maps
to a ``Behaviour`` (what the state machine does), so that Rover and Copter
share one state machine and differ only by this registry.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from enum import Enum, IntEnum, StrEnum

from pymavlink.dialects.v20 import ardupilotmega as mavlink


class VehicleKind(StrEnum):
    ROVER = "rover"
    COPTER = "copter"


class RoverMode(IntEnum):
    MANUAL = 0
    HOLD = 4
    AUTO = 10
    RTL = 11
    GUIDED = 15


class CopterMode(IntEnum):
    STABILIZE = 0
    AUTO = 3
    GUIDED = 4
    LOITER = 5
    RTL = 6
    LAND = 9
    BRAKE = 17


class Behaviour(Enum):
    """What the state machine does in a mode."""

    MANUAL = "manual"  # no pilot input in a mock: stands (or hovers) still
    HOLD = "hold"
    AUTO = "auto"
    GUIDED = "guided"
    RTL = "rtl"
    LAND = "land"


@dataclass(frozen=True)
class KindProfile:
    """What one vehicle kind reports and which of its modes do what."""

    mav_type: int
    modes: Mapping[int, Behaviour]
    initial_mode: int
    #: Where a rover goes when its mission completes (None: stay in AUTO).
    mode_after_mission: int | None
    #: Modes one may not arm in (ArduPilot: RTL; Copter also LAND, BRAKE and AUTO
    #: without takeoff).
    unarmable: frozenset[int] = field(default_factory=frozenset)
    flies: bool = False
    #: Where the GCS failsafe's HOLD puts the vehicle (Rover HOLD; Copter BRAKE).
    failsafe_hold_mode: int | None = None

    def mode_for(self, behaviour: Behaviour) -> int:
        for number, b in self.modes.items():
            if b is behaviour:
                return number
        raise KeyError(behaviour)

    def name_of(self, mode: int) -> str:
        enum = RoverMode if self.mav_type == mavlink.MAV_TYPE_GROUND_ROVER else CopterMode
        try:
            return enum(mode).name
        except ValueError:
            return f"MODE{mode}"


PROFILES: Mapping[VehicleKind, KindProfile] = {
    VehicleKind.ROVER: KindProfile(
        mav_type=mavlink.MAV_TYPE_GROUND_ROVER,
        modes={
            RoverMode.MANUAL: Behaviour.MANUAL,
            RoverMode.HOLD: Behaviour.HOLD,
            RoverMode.AUTO: Behaviour.AUTO,
            RoverMode.RTL: Behaviour.RTL,
            RoverMode.GUIDED: Behaviour.GUIDED,
        },
        initial_mode=RoverMode.HOLD,
        mode_after_mission=RoverMode.HOLD,
        unarmable=frozenset({RoverMode.RTL}),
        failsafe_hold_mode=RoverMode.HOLD,
    ),
    VehicleKind.COPTER: KindProfile(
        mav_type=mavlink.MAV_TYPE_QUADROTOR,
        modes={
            CopterMode.STABILIZE: Behaviour.MANUAL,
            CopterMode.AUTO: Behaviour.AUTO,
            CopterMode.GUIDED: Behaviour.GUIDED,
            CopterMode.LOITER: Behaviour.HOLD,
            CopterMode.RTL: Behaviour.RTL,
            CopterMode.LAND: Behaviour.LAND,
            CopterMode.BRAKE: Behaviour.HOLD,
        },
        initial_mode=CopterMode.STABILIZE,
        mode_after_mission=None,
        unarmable=frozenset({CopterMode.RTL, CopterMode.LAND, CopterMode.BRAKE}),
        flies=True,
        failsafe_hold_mode=CopterMode.BRAKE,
    ),
}
