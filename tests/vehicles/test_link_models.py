"""Vehicle models and autopilot flavours: registries keyed on HEARTBEAT or names."""

from __future__ import annotations

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from vehicles.autopilots import ARDUPILOT, PX4
from vehicles.models import profile_from_heartbeat, profile_from_name
from vehicles.modes import (
    ArduCopterMode,
    ArduRoverMode,
    FlightMode,
    Px4AutoSubMode,
    Px4MainMode,
    VehicleKind,
    px4_custom_mode,
)


def test_profile_from_heartbeat() -> None:
    rover = profile_from_heartbeat(
        mavlink.MAV_TYPE_GROUND_ROVER, mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA
    )
    assert rover is not None and rover.name == "ardupilot-rover"
    assert not rover.model.needs_takeoff
    copter = profile_from_heartbeat(mavlink.MAV_TYPE_QUADROTOR, mavlink.MAV_AUTOPILOT_PX4)
    assert copter is not None and copter.name == "px4-copter" and copter.model.needs_takeoff
    generic = profile_from_heartbeat(mavlink.MAV_TYPE_HEXAROTOR, mavlink.MAV_AUTOPILOT_GENERIC)
    assert generic is not None and generic.flavour is PX4  # as MAVSDK assumes
    assert profile_from_heartbeat(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID) is None


@pytest.mark.parametrize(
    ("name", "expected"),
    [("rover", "ardupilot-rover"), ("Copter", "ardupilot-copter"), ("px4-rover", "px4-rover")],
)
def test_profile_from_name(name: str, expected: str) -> None:
    assert profile_from_name(name).name == expected


def test_unknown_names_say_what_is_known() -> None:
    with pytest.raises(ValueError, match="known: rover, copter"):
        profile_from_name("plane")
    with pytest.raises(ValueError, match="unknown autopilot 'inav'"):
        profile_from_name("inav-rover")


@pytest.mark.parametrize(
    ("kind", "mode", "custom"),
    [
        (VehicleKind.ROVER, FlightMode.MANUAL, 0),
        (VehicleKind.ROVER, FlightMode.HOLD, 4),
        (VehicleKind.ROVER, FlightMode.AUTO, 10),
        (VehicleKind.ROVER, FlightMode.RTL, 11),
        (VehicleKind.ROVER, FlightMode.GUIDED, 15),
        (VehicleKind.COPTER, FlightMode.MANUAL, 0),
        (VehicleKind.COPTER, FlightMode.AUTO, 3),
        (VehicleKind.COPTER, FlightMode.GUIDED, 4),
        (VehicleKind.COPTER, FlightMode.RTL, 6),
        (VehicleKind.COPTER, FlightMode.LAND, 9),
    ],
)
def test_ardupilot_modes(kind: VehicleKind, mode: FlightMode, custom: int) -> None:
    params = ARDUPILOT.set_mode_params(kind, mode)
    assert params is not None
    assert (params.base_mode, params.custom_mode) == (1, custom)
    assert ARDUPILOT.flight_mode(kind, custom) is mode


def test_mode_names() -> None:
    assert ARDUPILOT.mode_name(VehicleKind.ROVER, ArduRoverMode.GUIDED) == "GUIDED"
    assert ARDUPILOT.mode_name(VehicleKind.COPTER, ArduCopterMode.LAND) == "LAND"
    assert ARDUPILOT.mode_name(VehicleKind.ROVER, 99) == "MODE_99"
    rtl = px4_custom_mode(Px4MainMode.AUTO, Px4AutoSubMode.RTL)
    assert rtl == 0x05040000
    assert PX4.mode_name(VehicleKind.COPTER, rtl) == "AUTO_RTL"
    assert PX4.flight_mode(VehicleKind.COPTER, rtl) is FlightMode.RTL
    assert PX4.mode_name(VehicleKind.COPTER, px4_custom_mode(Px4MainMode.OFFBOARD)) == "OFFBOARD"


def test_rover_cannot_land() -> None:
    assert ARDUPILOT.set_mode_params(VehicleKind.ROVER, FlightMode.LAND) is None
    assert ARDUPILOT.mission_has_home and not PX4.mission_has_home
