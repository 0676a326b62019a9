"""What can go wrong when we talk to a vehicle, as exceptions with structured fields.

An operation on a link either returns normally or raises one of these; callers
catch ``LinkError`` for "anything the vehicle link could not do".
"""

from __future__ import annotations

from pymavlink.dialects.v20 import ardupilotmega as mavlink


def _enum_name(enum: str, value: int | None) -> str:
    if value is None:
        return "none"
    entry = mavlink.enums.get(enum, {}).get(value)
    return entry.name if entry is not None else f"{enum}({value})"


def command_name(command: int) -> str:
    """``MAV_CMD_DO_SET_MODE`` for 176, and so on."""
    return _enum_name("MAV_CMD", command)


def result_name(result: int) -> str:
    """``MAV_RESULT_DENIED`` for 2, and so on."""
    return _enum_name("MAV_RESULT", result)


def mission_result_name(result: int | None) -> str:
    """``MAV_MISSION_NO_SPACE`` for 4, and so on."""
    return _enum_name("MAV_MISSION_RESULT", result)


class LinkError(Exception):
    """Base of every error raised by the vehicle link."""


class EndpointError(LinkError, ValueError):
    """A connection string that we cannot use (bad syntax, or not loopback when it must be)."""

    def __init__(self, endpoint: str, reason: str) -> None:
        super().__init__(f"bad endpoint {endpoint!r}: {reason}")
        self.endpoint = endpoint
        self.reason = reason


class TransportClosed(LinkError):
    """The transport was closed while an operation still needed it."""


class HeartbeatTimeout(LinkError):
    """No HEARTBEAT from the expected vehicle within the time allowed."""

    def __init__(self, target_system: int | None, timeout_s: float) -> None:
        who = "any vehicle" if target_system is None else f"system {target_system}"
        super().__init__(f"no heartbeat from {who} within {timeout_s:g} s")
        self.target_system = target_system
        self.timeout_s = timeout_s


class CommandError(LinkError):
    """A COMMAND_LONG / COMMAND_INT did not succeed."""

    def __init__(self, message: str, command: int) -> None:
        super().__init__(message)
        self.command = command


class CommandDenied(CommandError):
    """The vehicle answered a command with a COMMAND_ACK other than ACCEPTED."""

    def __init__(self, command: int, result: int, result_param2: int = 0) -> None:
        super().__init__(
            f"{command_name(command)} refused with {result_name(result)}", command=command
        )
        self.result = result
        self.result_param2 = result_param2


class CommandTimeout(CommandError):
    """No final COMMAND_ACK arrived after every retry."""

    def __init__(self, command: int, attempts: int, timeout_s: float) -> None:
        super().__init__(
            f"{command_name(command)}: no COMMAND_ACK after {attempts} attempt(s) "
            f"of {timeout_s:g} s",
            command=command,
        )
        self.attempts = attempts
        self.timeout_s = timeout_s


class ModeNotSupported(LinkError):
    """The vehicle's autopilot/type has no encoding for the requested mode."""

    def __init__(self, mode: str, profile: str) -> None:
        super().__init__(f"mode {mode} is not available on {profile}")
        self.mode = mode
        self.profile = profile


class MissionError(LinkError):
    """A mission upload, download or clear did not complete.

    ``result`` is the MAV_MISSION_RESULT the vehicle sent when it refused, or
    ``None`` when the failure is ours (timeout, protocol violation); ``reason``
    says what happened in words; ``seq`` is the item concerned, if any.
    """

    def __init__(
        self,
        operation: str,
        reason: str,
        *,
        result: int | None = None,
        seq: int | None = None,
    ) -> None:
        detail = reason if result is None else f"{reason} ({mission_result_name(result)})"
        where = "" if seq is None else f" at item {seq}"
        super().__init__(f"mission {operation} failed{where}: {detail}")
        self.operation = operation
        self.reason = reason
        self.result = result
        self.seq = seq


class MissionTimeout(MissionError):
    """The other side stopped answering during a mission transfer."""
