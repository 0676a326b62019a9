"""Reading and setting a vehicle's parameters (the MAVLink parameter protocol, ground side).

Only what the ground station needs: one parameter by name, with
PARAM_REQUEST_READ answered by PARAM_VALUE, resent on silence; and PARAM_SET,
answered by the PARAM_VALUE of what the vehicle now holds (``ParameterRejected``
when that is not what was set)
(https://mavlink.io/en/services/parameter.html). A vehicle that does not
have the parameter stays silent (ArduPilot) or says so in a STATUSTEXT; after
the retries the read ends with ``ParameterUnavailable``, which callers treat
as "use the mission's own figure".
"""

from __future__ import annotations

import struct
from collections.abc import Callable
from dataclasses import dataclass

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from vehicles.errors import LinkError
from vehicles.router import Message, MessageRouter, send_and_wait

#: Longest parameter name (PARAM_VALUE.param_id is 16 characters, not always terminated).
PARAM_ID_LEN = 16


class ParameterUnavailable(LinkError):
    """The vehicle did not answer for a parameter (it may not have it)."""

    def __init__(self, name: str, attempts: int) -> None:
        super().__init__(f"no value for parameter {name} after {attempts} request(s)")
        self.name = name


class ParameterRejected(LinkError):
    """The vehicle answered a PARAM_SET with another value: it did not take it."""

    def __init__(self, name: str, wanted: float, got: float) -> None:
        super().__init__(f"parameter {name} not set to {wanted:g}: the vehicle holds {got:g}")
        self.name = name


@dataclass(frozen=True)
class ParameterSettings:
    timeout_s: float = 1.0
    #: A lossy radio loses one exchange in two at 30 % loss each way: six tries fail
    #: together less than twice in a hundred.
    retries: int = 5


def param_name(raw: str | bytes) -> str:
    """A param_id as sent: bytes or text, padded with NULs to 16 characters."""
    text = raw.decode("ascii", errors="replace") if isinstance(raw, bytes) else raw
    return text.split("\x00", 1)[0]


class ParameterClient:
    def __init__(
        self,
        send: Callable[[Message], object],
        router: MessageRouter,
        target: Callable[[], tuple[int, int]],
        settings: ParameterSettings | None = None,
    ) -> None:
        self._send = send
        self._router = router
        self._target = target
        self.settings = settings or ParameterSettings()

    async def read(self, name: str) -> float:
        """The value of parameter ``name``; ``ParameterUnavailable`` after the retries."""
        system, component = self._target()
        request = mavlink.MAVLink_param_request_read_message(
            system, component, _checked(name).encode(), -1
        )
        return await self._exchange(name, request)

    async def write(self, name: str, value: float) -> None:
        """Set parameter ``name`` (as a REAL32, as ArduPilot keeps them); the vehicle's
        answer must hold the value, else ``ParameterRejected``."""
        system, component = self._target()
        request = mavlink.MAVLink_param_set_message(
            system, component, _checked(name).encode(), value, mavlink.MAV_PARAM_TYPE_REAL32
        )
        got = await self._exchange(name, request)
        if got != _float32(value):
            raise ParameterRejected(name, value, got)

    async def _exchange(self, name: str, request: Message) -> float:
        system, _ = self._target()

        def ours(msg: Message) -> bool:
            return msg.get_type() == "PARAM_VALUE" and msg.get_srcSystem() == system

        def accept(msg: Message) -> float | None:
            return float(msg.param_value) if param_name(msg.param_id) == name else None

        s = self.settings
        async with self._router.inbox(ours) as inbox:
            try:
                return await send_and_wait(
                    lambda: self._send(request),
                    inbox,
                    accept,
                    timeout_s=s.timeout_s,
                    retries=s.retries,
                )
            except TimeoutError:
                raise ParameterUnavailable(name, s.retries + 1) from None


def _checked(name: str) -> str:
    if not 0 < len(name) <= PARAM_ID_LEN:
        raise ValueError(f"parameter names have 1 to {PARAM_ID_LEN} characters, got {name!r}")
    return name


def _float32(value: float) -> float:
    return float(struct.unpack("<f", struct.pack("<f", value))[0])
