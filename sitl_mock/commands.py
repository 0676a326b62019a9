"""COMMAND_LONG / COMMAND_INT handling: a table from MAV_CMD to handler.

A handler returns the MAV_RESULT to acknowledge (and any messages to send
after the ACK), or raises ``CommandRefused``. Commands not in the table are
answered MAV_RESULT_UNSUPPORTED, like ArduPilot.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Protocol, TypeAlias

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sitl_mock.modes import Behaviour
from sitl_mock.vehicle import ARM_FORCE_MAGIC, DISARM_FORCE_MAGIC, CommandRefused, Vehicle

Message: TypeAlias = mavlink.MAVLink_message


@dataclass(frozen=True)
class Command:
    """One command, whichever message carried it; positions in degrees."""

    command: int
    params: tuple[float, float, float, float, float, float, float]
    is_int: bool = False

    @staticmethod
    def from_message(msg: Any) -> Command:
        if msg.get_type() == "COMMAND_INT":
            # x, y are latitude and longitude in 1e-7 degrees for position commands.
            p5, p6 = msg.x / 1e7, msg.y / 1e7
            params = (msg.param1, msg.param2, msg.param3, msg.param4, p5, p6, msg.z)
            return Command(int(msg.command), tuple(float(p) for p in params), True)  # type: ignore[arg-type]
        params = (
            msg.param1,
            msg.param2,
            msg.param3,
            msg.param4,
            msg.param5,
            msg.param6,
            msg.param7,
        )
        return Command(int(msg.command), tuple(float(p) for p in params))  # type: ignore[arg-type]

    def p(self, n: int) -> float:
        """Parameter ``n`` (1-based, as in the MAVLink documentation)."""
        return self.params[n - 1]

    def whole(self, n: int) -> int:
        """Parameter ``n`` as a whole number (an id, a mode, flags); NaN or
        infinity there is refused."""
        value = self.params[n - 1]
        if not math.isfinite(value):
            raise CommandRefused(f"Parameter {n} is {value}", mavlink.MAV_RESULT_DENIED)
        return int(value)


@dataclass(frozen=True)
class Outcome:
    result: int
    replies: list[Message] = field(default_factory=list)


class CommandHost(Protocol):
    """What command handlers may use of the endpoint."""

    vehicle: Vehicle

    def set_interval(self, message_id: int, interval_us: float) -> bool: ...

    def interval_us(self, message_id: int) -> int: ...

    def build(self, message_id: int) -> list[Message] | None: ...

    def encoder(self) -> mavlink.MAVLink: ...


Handler = Callable[[CommandHost, Command], Outcome]

ACCEPTED = Outcome(mavlink.MAV_RESULT_ACCEPTED)


def _arm_disarm(host: CommandHost, cmd: Command) -> Outcome:
    if cmd.p(1) >= 0.5:
        host.vehicle.arm(force=round(cmd.p(2)) == ARM_FORCE_MAGIC)
    else:
        host.vehicle.disarm(force=round(cmd.p(2)) == DISARM_FORCE_MAGIC)
    return ACCEPTED


def _set_mode(host: CommandHost, cmd: Command) -> Outcome:
    if not cmd.whole(1) & mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
        raise CommandRefused("Only custom modes are supported", mavlink.MAV_RESULT_DENIED)
    host.vehicle.set_mode(cmd.whole(2))
    return ACCEPTED


def _return_to_launch(host: CommandHost, cmd: Command) -> Outcome:
    host.vehicle.return_to_launch()
    return ACCEPTED


def _takeoff(host: CommandHost, cmd: Command) -> Outcome:
    host.vehicle.takeoff(cmd.p(7))
    return ACCEPTED


def _land(host: CommandHost, cmd: Command) -> Outcome:
    host.vehicle.land()
    return ACCEPTED


def _reposition(host: CommandHost, cmd: Command) -> Outcome:
    v = host.vehicle
    if v.behaviour is not Behaviour.GUIDED:
        if not cmd.whole(2) & mavlink.MAV_DO_REPOSITION_FLAGS_CHANGE_MODE:
            raise CommandRefused("Reposition: not in GUIDED")
        v.set_mode(v.profile.mode_for(Behaviour.GUIDED))
    north, east = v.world.geo.geo_to_local(cmd.p(5), cmd.p(6))
    v.goto(north, east, cmd.p(7))
    return ACCEPTED


def _mission_start(host: CommandHost, cmd: Command) -> Outcome:
    host.vehicle.start_mission(cmd.whole(1))
    return ACCEPTED


def _set_mission_current(host: CommandHost, cmd: Command) -> Outcome:
    host.vehicle.set_current(cmd.whole(1))
    return ACCEPTED


def _change_speed(host: CommandHost, cmd: Command) -> Outcome:
    if cmd.p(2) <= 0:
        raise CommandRefused("Speed must be positive")
    host.vehicle.speed_m_s = cmd.p(2)
    return ACCEPTED


def _set_message_interval(host: CommandHost, cmd: Command) -> Outcome:
    if not host.set_interval(cmd.whole(1), cmd.p(2)):
        raise CommandRefused(f"Message {cmd.whole(1)} cannot be streamed")
    return ACCEPTED


def _get_message_interval(host: CommandHost, cmd: Command) -> Outcome:
    message_id = cmd.whole(1)
    if not 0 <= message_id <= 0xFFFF:  # what MESSAGE_INTERVAL's message_id can hold
        raise CommandRefused(f"No message {message_id}", mavlink.MAV_RESULT_DENIED)
    reply = host.encoder().message_interval_encode(message_id, host.interval_us(message_id))
    return Outcome(mavlink.MAV_RESULT_ACCEPTED, [reply])


def _request_message(host: CommandHost, cmd: Command) -> Outcome:
    messages = host.build(cmd.whole(1))
    if messages is None:
        raise CommandRefused(f"Message {cmd.whole(1)} not available")
    return Outcome(mavlink.MAV_RESULT_ACCEPTED, messages)


def _set_reverse(host: CommandHost, cmd: Command) -> Outcome:
    host.vehicle.set_reverse(cmd.p(1) == 1.0)
    return ACCEPTED


def _battery_reset(host: CommandHost, cmd: Command) -> Outcome:
    """param1: mask of batteries (bit 0: the only one), param2: percent remaining."""
    percent = cmd.p(2)
    if not cmd.whole(1) & 1 or not math.isfinite(percent):
        return Outcome(mavlink.MAV_RESULT_FAILED)
    host.vehicle.battery.reset(percent)
    return ACCEPTED


def _autopilot_capabilities(host: CommandHost, cmd: Command) -> Outcome:
    return Outcome(
        mavlink.MAV_RESULT_ACCEPTED, host.build(mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION) or []
    )


HANDLERS: dict[int, Handler] = {
    mavlink.MAV_CMD_COMPONENT_ARM_DISARM: _arm_disarm,
    mavlink.MAV_CMD_DO_SET_MODE: _set_mode,
    mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH: _return_to_launch,
    mavlink.MAV_CMD_NAV_TAKEOFF: _takeoff,
    mavlink.MAV_CMD_NAV_LAND: _land,
    mavlink.MAV_CMD_DO_REPOSITION: _reposition,
    mavlink.MAV_CMD_MISSION_START: _mission_start,
    mavlink.MAV_CMD_DO_SET_MISSION_CURRENT: _set_mission_current,
    mavlink.MAV_CMD_DO_CHANGE_SPEED: _change_speed,
    mavlink.MAV_CMD_SET_MESSAGE_INTERVAL: _set_message_interval,
    mavlink.MAV_CMD_GET_MESSAGE_INTERVAL: _get_message_interval,
    mavlink.MAV_CMD_REQUEST_MESSAGE: _request_message,
    mavlink.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES: _autopilot_capabilities,
    mavlink.MAV_CMD_BATTERY_RESET: _battery_reset,
    mavlink.MAV_CMD_DO_SET_REVERSE: _set_reverse,
}


def execute(host: CommandHost, cmd: Command) -> tuple[Outcome, str | None]:
    """Run a command; returns the outcome and, for a refusal, the text to announce."""
    handler = HANDLERS.get(cmd.command)
    if handler is None:
        return Outcome(mavlink.MAV_RESULT_UNSUPPORTED), None
    try:
        return handler(host, cmd), None
    except CommandRefused as refusal:
        return Outcome(refusal.result), refusal.text
