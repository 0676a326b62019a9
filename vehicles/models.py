"""What a vehicle is: rover or copter, its speeds and energy defaults, and its autopilot.

``VehicleProfile`` = ``VehicleModel`` (kind, speed, energy, take-off) +
``AutopilotFlavour`` (mode encoding, mission conventions). Profiles are found
through registries, from a HEARTBEAT (``profile_from_heartbeat``) or from a
mission file's type string such as ``"ardupilot-rover"`` or ``"copter"``
(``profile_from_name``).
"""

from __future__ import annotations

from dataclasses import dataclass

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from vehicles.autopilots import (
    ARDUPILOT,
    AutopilotFlavour,
    flavour_by_name,
    flavour_for_autopilot,
)
from vehicles.modes import FlightMode, VehicleKind


@dataclass(frozen=True)
class VehicleModel:
    """Defaults for one kind of vehicle; a mission file may override them."""

    kind: VehicleKind
    cruise_speed_m_s: float
    battery_capacity_mah: float
    #: Battery used per metre travelled, in percent of a full battery.
    drain_pct_per_m: float
    #: Battery used per second just staying up (0 for a rover standing still).
    idle_drain_pct_per_s: float
    reserve_pct: float
    #: True for vehicles that must arm + take off before moving and land after.
    needs_takeoff: bool
    cruise_alt_m: float


ROVER = VehicleModel(
    kind=VehicleKind.ROVER,
    cruise_speed_m_s=2.0,
    battery_capacity_mah=5000.0,
    drain_pct_per_m=0.1,
    idle_drain_pct_per_s=0.0,
    reserve_pct=20.0,
    needs_takeoff=False,
    cruise_alt_m=0.0,
)
COPTER = VehicleModel(
    kind=VehicleKind.COPTER,
    cruise_speed_m_s=5.0,
    battery_capacity_mah=5200.0,
    drain_pct_per_m=0.05,
    idle_drain_pct_per_s=0.05,
    reserve_pct=25.0,
    needs_takeoff=True,
    cruise_alt_m=10.0,
)

MODELS: dict[VehicleKind, VehicleModel] = {VehicleKind.ROVER: ROVER, VehicleKind.COPTER: COPTER}

#: Vehicle kind by HEARTBEAT.type.
KINDS_BY_MAV_TYPE: dict[int, VehicleKind] = {
    mavlink.MAV_TYPE_GROUND_ROVER: VehicleKind.ROVER,
    mavlink.MAV_TYPE_SURFACE_BOAT: VehicleKind.ROVER,
    mavlink.MAV_TYPE_QUADROTOR: VehicleKind.COPTER,
    mavlink.MAV_TYPE_COAXIAL: VehicleKind.COPTER,
    mavlink.MAV_TYPE_HELICOPTER: VehicleKind.COPTER,
    mavlink.MAV_TYPE_HEXAROTOR: VehicleKind.COPTER,
    mavlink.MAV_TYPE_OCTOROTOR: VehicleKind.COPTER,
    mavlink.MAV_TYPE_TRICOPTER: VehicleKind.COPTER,
    mavlink.MAV_TYPE_DODECAROTOR: VehicleKind.COPTER,
    mavlink.MAV_TYPE_DECAROTOR: VehicleKind.COPTER,
}
#: HEARTBEAT.type we announce for a kind (the mock uses the same table).
MAV_TYPE_BY_KIND: dict[VehicleKind, int] = {
    VehicleKind.ROVER: mavlink.MAV_TYPE_GROUND_ROVER,
    VehicleKind.COPTER: mavlink.MAV_TYPE_QUADROTOR,
}


@dataclass(frozen=True)
class VehicleProfile:
    model: VehicleModel
    flavour: AutopilotFlavour

    @property
    def kind(self) -> VehicleKind:
        return self.model.kind

    @property
    def name(self) -> str:
        return f"{self.flavour.name}-{self.model.kind.value}"

    def supports(self, mode: FlightMode) -> bool:
        return self.flavour.set_mode_params(self.kind, mode) is not None


def profile_from_heartbeat(mav_type: int, mav_autopilot: int) -> VehicleProfile | None:
    """The profile of a vehicle from its HEARTBEAT, or None if it is not a rover/copter."""
    kind = KINDS_BY_MAV_TYPE.get(mav_type)
    if kind is None:
        return None
    return VehicleProfile(MODELS[kind], flavour_for_autopilot(mav_autopilot))


def profile_from_name(name: str) -> VehicleProfile:
    """``"rover"``, ``"copter"``, ``"ardupilot-rover"``, ``"px4-copter"`` ... (ArduPilot if
    no autopilot is named). Raises ``ValueError`` naming the known values."""
    autopilot, _, kind_text = name.strip().lower().rpartition("-")
    try:
        kind = VehicleKind(kind_text)
    except ValueError:
        known = ", ".join(k.value for k in VehicleKind)
        raise ValueError(f"unknown vehicle type {name!r} (known: {known})") from None
    flavour = flavour_by_name(autopilot) if autopilot else ARDUPILOT
    return VehicleProfile(MODELS[kind], flavour)
