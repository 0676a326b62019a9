"""Autopilot flavours: how ArduPilot and PX4 encode modes, and what a mission starts with.

A flavour is chosen from HEARTBEAT.autopilot (``flavour_for_autopilot``) or
from a name in a mission file (``flavour_by_name``) through registries; code
that talks to a vehicle asks its flavour and never branches on the autopilot.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum
from typing import Protocol

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from vehicles.modes import (
    ArduCopterMode,
    ArduRoverMode,
    FlightMode,
    Px4AutoSubMode,
    Px4MainMode,
    VehicleKind,
    px4_split_custom_mode,
)

_CUSTOM_MODE_ENABLED = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED


@dataclass(frozen=True)
class Param:
    """A parameter and the factor that turns its value into SI units."""

    name: str
    scale: float = 1.0


@dataclass(frozen=True)
class SetModeParams:
    """param1..param3 of MAV_CMD_DO_SET_MODE."""

    base_mode: float
    custom_mode: float
    custom_sub_mode: float = 0.0


class AutopilotFlavour(Protocol):
    # Read-only (properties), as the frozen dataclasses that implement it hold them.
    @property
    def name(self) -> str: ...

    @property
    def mav_autopilot(self) -> int: ...

    @property
    def mission_has_home(self) -> bool:
        """True when mission item 0 is the home position (ArduPilot), so the first real
        item is seq 1."""
        ...

    def set_mode_params(self, kind: VehicleKind, mode: FlightMode) -> SetModeParams | None:
        """DO_SET_MODE parameters for ``mode``, or None if this vehicle has no such mode."""
        ...

    def mode_name(self, kind: VehicleKind, custom_mode: int) -> str:
        """The autopilot's own name of a HEARTBEAT custom mode (for display)."""
        ...

    def flight_mode(self, kind: VehicleKind, custom_mode: int) -> FlightMode | None:
        """The ``FlightMode`` a HEARTBEAT custom mode stands for, if any."""
        ...

    def limit_params(self, kind: VehicleKind) -> dict[str, Param]:
        """The parameters that say how this vehicle moves (``vehicles.driving``)."""
        ...

    def fence_params(self, kind: VehicleKind) -> FenceParams:
        """How to switch a geofence on, with the breach action of the safe state (a
        rover holds, a copter lands)."""
        ...


@dataclass(frozen=True)
class FenceParams:
    #: Parameters set to these values.
    values: dict[str, float]
    #: Parameters whose bits are set (read, OR-ed, written back): the operator's own
    #: fences of other kinds stay.
    bits: dict[str, int]


@dataclass(frozen=True)
class ArduPilotFlavour:
    name: str = "ardupilot"
    mav_autopilot: int = mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA
    mission_has_home: bool = True

    def _table(self, kind: VehicleKind) -> dict[FlightMode, IntEnum]:
        return _ARDUPILOT_MODES[kind]

    def set_mode_params(self, kind: VehicleKind, mode: FlightMode) -> SetModeParams | None:
        custom = self._table(kind).get(mode)
        if custom is None:
            return None
        return SetModeParams(_CUSTOM_MODE_ENABLED, float(custom))

    def mode_name(self, kind: VehicleKind, custom_mode: int) -> str:
        enum = _ARDUPILOT_MODE_ENUMS[kind]
        try:
            return enum(custom_mode).name
        except ValueError:
            return f"MODE_{custom_mode}"

    def flight_mode(self, kind: VehicleKind, custom_mode: int) -> FlightMode | None:
        for mode, value in self._table(kind).items():
            if int(value) == custom_mode:
                return mode
        return None

    def limit_params(self, kind: VehicleKind) -> dict[str, Param]:
        return _ARDUPILOT_LIMIT_PARAMS.get(kind, {})

    def fence_params(self, kind: VehicleKind) -> FenceParams:
        # FENCE_ACTION 2: Hold on Rover, Land on Copter; FENCE_TYPE bit 4: polygons.
        return FenceParams({"FENCE_ACTION": 2.0, "FENCE_ENABLE": 1.0}, {"FENCE_TYPE": 4})


@dataclass(frozen=True)
class Px4Flavour:
    name: str = "px4"
    mav_autopilot: int = mavlink.MAV_AUTOPILOT_PX4
    mission_has_home: bool = False

    def set_mode_params(self, kind: VehicleKind, mode: FlightMode) -> SetModeParams | None:
        main_sub = _PX4_MODES.get(mode)
        if main_sub is None:
            return None
        main, sub = main_sub
        return SetModeParams(_CUSTOM_MODE_ENABLED, float(main), float(sub))

    def mode_name(self, kind: VehicleKind, custom_mode: int) -> str:
        main, sub = px4_split_custom_mode(custom_mode)
        try:
            main_name = Px4MainMode(main).name
        except ValueError:
            return f"MODE_{custom_mode:#x}"
        if main == Px4MainMode.AUTO:
            try:
                return f"AUTO_{Px4AutoSubMode(sub).name}"
            except ValueError:
                return f"AUTO_{sub}"
        return main_name

    def flight_mode(self, kind: VehicleKind, custom_mode: int) -> FlightMode | None:
        main, sub = px4_split_custom_mode(custom_mode)
        key = (main, sub if main == Px4MainMode.AUTO else 0)
        return next((mode for mode, value in _PX4_MODES.items() if value == key), None)

    def limit_params(self, kind: VehicleKind) -> dict[str, Param]:
        return {"acceptance_radius_m": Param("NAV_ACC_RAD")}

    def fence_params(self, kind: VehicleKind) -> FenceParams:
        # GF_ACTION 2: Hold mode, 5: Land mode; a PX4 fence is on once uploaded.
        return FenceParams({"GF_ACTION": 5.0 if kind is VehicleKind.COPTER else 2.0}, {})


_ARDUPILOT_MODES: dict[VehicleKind, dict[FlightMode, IntEnum]] = {
    VehicleKind.ROVER: {
        FlightMode.MANUAL: ArduRoverMode.MANUAL,
        FlightMode.HOLD: ArduRoverMode.HOLD,
        FlightMode.AUTO: ArduRoverMode.AUTO,
        FlightMode.RTL: ArduRoverMode.RTL,
        FlightMode.GUIDED: ArduRoverMode.GUIDED,
    },
    VehicleKind.COPTER: {
        FlightMode.MANUAL: ArduCopterMode.STABILIZE,
        FlightMode.HOLD: ArduCopterMode.LOITER,
        FlightMode.AUTO: ArduCopterMode.AUTO,
        FlightMode.GUIDED: ArduCopterMode.GUIDED,
        FlightMode.RTL: ArduCopterMode.RTL,
        FlightMode.LAND: ArduCopterMode.LAND,
    },
}
_ARDUPILOT_MODE_ENUMS: dict[VehicleKind, type[IntEnum]] = {
    VehicleKind.ROVER: ArduRoverMode,
    VehicleKind.COPTER: ArduCopterMode,
}
_PX4_MODES: dict[FlightMode, tuple[int, int]] = {
    FlightMode.MANUAL: (Px4MainMode.MANUAL, 0),
    FlightMode.HOLD: (Px4MainMode.AUTO, Px4AutoSubMode.LOITER),
    FlightMode.AUTO: (Px4MainMode.AUTO, Px4AutoSubMode.MISSION),
    # PX4 has no GUIDED: reposition commands are flown in AUTO_LOITER (hold).
    FlightMode.GUIDED: (Px4MainMode.AUTO, Px4AutoSubMode.LOITER),
    FlightMode.RTL: (Px4MainMode.AUTO, Px4AutoSubMode.RTL),
    FlightMode.LAND: (Px4MainMode.AUTO, Px4AutoSubMode.LAND),
    FlightMode.TAKEOFF: (Px4MainMode.AUTO, Px4AutoSubMode.TAKEOFF),
}

#: ArduPilot Rover's own figures (``vehicles.driving.DrivingLimits`` fields); Copter
#: reaches guided targets precisely and needs none.
_ARDUPILOT_LIMIT_PARAMS: dict[VehicleKind, dict[str, Param]] = {
    VehicleKind.ROVER: {
        "acceptance_radius_m": Param("WP_RADIUS"),
        "speed_m_s": Param("WP_SPEED"),
        "pivot_rate_deg_s": Param("WP_PIVOT_RATE"),
        "turn_radius_m": Param("TURN_RADIUS"),
    },
}

ARDUPILOT = ArduPilotFlavour()
PX4 = Px4Flavour()

#: Flavour by HEARTBEAT.autopilot. Anything else is treated as PX4-like, as MAVSDK does.
FLAVOURS_BY_AUTOPILOT: dict[int, AutopilotFlavour] = {
    mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA: ARDUPILOT,
    mavlink.MAV_AUTOPILOT_PX4: PX4,
}
#: Flavour by the name used in mission files.
FLAVOURS_BY_NAME: dict[str, AutopilotFlavour] = {
    "ardupilot": ARDUPILOT,
    "apm": ARDUPILOT,
    "px4": PX4,
}
DEFAULT_FLAVOUR: AutopilotFlavour = PX4


def flavour_for_autopilot(mav_autopilot: int) -> AutopilotFlavour:
    return FLAVOURS_BY_AUTOPILOT.get(mav_autopilot, DEFAULT_FLAVOUR)


def flavour_by_name(name: str) -> AutopilotFlavour:
    try:
        return FLAVOURS_BY_NAME[name.lower()]
    except KeyError:
        known = ", ".join(sorted(FLAVOURS_BY_NAME))
        raise ValueError(f"unknown autopilot {name!r} (known: {known})") from None
