"""The parameters a mock vehicle answers for (the MAVLink parameter protocol, vehicle side).

Only what describes how the vehicle moves and what a ground station reads to
plan with it, under ArduPilot's names: WP_RADIUS, WP_SPEED, WP_PIVOT_RATE,
TURN_RADIUS for a driving rover, BATT_CAPACITY for every vehicle; and the
geofence's FENCE_ENABLE, FENCE_TYPE and FENCE_ACTION. Only the fence's can be
set: a PARAM_SET of another is answered with the value unchanged, which tells
the sender it did not take.
"""

from __future__ import annotations

from typing import TypeAlias

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sitl_mock.vehicle import Vehicle

Message: TypeAlias = mavlink.MAVLink_message
_REAL32 = mavlink.MAV_PARAM_TYPE_REAL32
#: The parameters a ground station may set: the geofence's, by ``Fence`` field.
_FENCE_FIELDS = {"FENCE_ENABLE": "enable", "FENCE_TYPE": "kind", "FENCE_ACTION": "action"}


def parameter_values(vehicle: Vehicle) -> dict[str, float]:
    """Name -> value, in a fixed order (the index of PARAM_VALUE)."""
    values = {"BATT_CAPACITY": vehicle.battery.settings.capacity_mah}
    values |= {name: getattr(vehicle.fence, field) for name, field in _FENCE_FIELDS.items()}
    drive = vehicle.settings.drive
    if vehicle.drive is not None and drive is not None:
        values |= {
            "WP_RADIUS": drive.wp_radius_m,
            "WP_SPEED": vehicle.settings.speed_m_s,
            "WP_PIVOT_RATE": drive.pivot_rate_deg_s,
            "TURN_RADIUS": drive.turn_radius_m,
        }
    return values


def _name(raw: str | bytes) -> str:
    text = raw.decode("ascii", errors="replace") if isinstance(raw, bytes) else raw
    return text.split("\x00", 1)[0]


def param_value(codec: mavlink.MAVLink, vehicle: Vehicle, name: str) -> Message | None:
    values = parameter_values(vehicle)
    if name not in values:
        return None
    index = list(values).index(name)
    return codec.param_value_encode(name.encode(), values[name], _REAL32, len(values), index)


def answer(codec: mavlink.MAVLink, vehicle: Vehicle, msg: Message) -> list[Message]:
    """The PARAM_VALUE messages a parameter request is answered with (none for a
    parameter the vehicle does not have, as ArduPilot)."""
    kind = msg.get_type()
    if kind == "PARAM_REQUEST_LIST":
        return [m for n in parameter_values(vehicle) if (m := param_value(codec, vehicle, n))]
    if kind == "PARAM_REQUEST_READ":
        name = _name(msg.param_id)
        if msg.param_index >= 0:
            names = list(parameter_values(vehicle))
            name = names[msg.param_index] if msg.param_index < len(names) else ""
        reply = param_value(codec, vehicle, name)
        return [] if reply is None else [reply]
    if kind == "PARAM_SET":
        name = _name(msg.param_id)
        field = _FENCE_FIELDS.get(name)
        if field is not None:
            setattr(vehicle.fence, field, float(msg.param_value))
        reply = param_value(codec, vehicle, name)
        return [] if reply is None else [reply]
    return []
