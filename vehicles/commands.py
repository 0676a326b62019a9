"""COMMAND_LONG / COMMAND_INT with COMMAND_ACK matching, retries and IN_PROGRESS.

A command is resent (COMMAND_LONG with ``confirmation`` incremented) until an
ACK for it arrives or the retries run out. ``MAV_RESULT_IN_PROGRESS`` stops the
resending and waits longer for the final ACK. ACCEPTED returns the ACK; any
other result raises ``CommandDenied``; silence raises ``CommandTimeout``.
"""

from __future__ import annotations

import asyncio
import builtins
import logging
from collections import defaultdict
from collections.abc import Callable
from dataclasses import dataclass

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from vehicles.errors import CommandDenied, CommandTimeout, command_name
from vehicles.router import Message, MessageRouter

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class CommandSettings:
    timeout_s: float = 1.0
    retries: int = 3
    #: How long to wait for the final ACK after an IN_PROGRESS one.
    in_progress_timeout_s: float = 30.0


@dataclass(frozen=True)
class CommandAck:
    command: int
    result: int
    progress: int
    result_param2: int
    attempts: int


class CommandSender:
    def __init__(
        self,
        send: Callable[[Message], object],
        router: MessageRouter,
        own_system: int,
        target: Callable[[], tuple[int, int]],
        settings: CommandSettings | None = None,
    ) -> None:
        self._send = send
        self._router = router
        self._own_system = own_system
        self._target = target
        self.settings = settings or CommandSettings()
        self._locks: dict[int, asyncio.Lock] = defaultdict(asyncio.Lock)

    async def long(
        self,
        command: int,
        *params: float,
        timeout_s: float | None = None,
        retries: int | None = None,
        on_progress: Callable[[int], None] | None = None,
    ) -> CommandAck:
        """Send COMMAND_LONG with up to 7 params (missing ones are 0)."""
        if len(params) > 7:
            raise ValueError("COMMAND_LONG takes at most 7 params")
        p = [float(v) for v in params] + [0.0] * (7 - len(params))

        def make(attempt: int) -> Message:
            system, component = self._target()
            return mavlink.MAVLink_command_long_message(
                system, component, command, min(attempt, 255), *p
            )

        return await self._run(command, make, timeout_s, retries, on_progress)

    async def int(
        self,
        command: int,
        *,
        frame: int = mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
        params: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0),
        x: int = 0,
        y: int = 0,
        z: float = 0.0,
        timeout_s: float | None = None,
        retries: int | None = None,
        on_progress: Callable[[int], None] | None = None,
    ) -> CommandAck:
        """Send COMMAND_INT (x/y are degrees × 1e7 in global frames)."""

        def make(_attempt: int) -> Message:
            system, component = self._target()
            return mavlink.MAVLink_command_int_message(
                system, component, frame, command, 0, 0, *params, x, y, z
            )

        return await self._run(command, make, timeout_s, retries, on_progress)

    async def _run(
        self,
        command: builtins.int,  # builtins: the method ``int`` above hides the type here
        make: Callable[[builtins.int], Message],
        timeout_s: float | None,
        retries: builtins.int | None,
        on_progress: Callable[[builtins.int], None] | None,
    ) -> CommandAck:
        timeout = self.settings.timeout_s if timeout_s is None else timeout_s
        max_retries = self.settings.retries if retries is None else retries
        system, _ = self._target()

        def is_our_ack(msg: Message) -> bool:
            return (
                msg.get_type() == "COMMAND_ACK"
                and msg.command == command
                and msg.get_srcSystem() == system
                and getattr(msg, "target_system", 0) in (0, self._own_system)
            )

        async with self._locks[command], self._router.inbox(is_our_ack) as inbox:
            attempts = 0
            in_progress = False
            while True:
                if not in_progress:
                    if attempts > max_retries:
                        raise CommandTimeout(command, attempts, timeout)
                    self._send(make(attempts))
                    attempts += 1
                wait = self.settings.in_progress_timeout_s if in_progress else timeout
                try:
                    ack = await inbox.get(wait)
                except TimeoutError:
                    if in_progress:
                        raise CommandTimeout(command, attempts, wait) from None
                    log.debug("%s: no ACK, attempt %d", command_name(command), attempts)
                    continue
                if ack.result == mavlink.MAV_RESULT_IN_PROGRESS:
                    in_progress = True
                    if on_progress is not None:
                        on_progress(ack.progress)
                    continue
                result = CommandAck(command, ack.result, ack.progress, ack.result_param2, attempts)
                if ack.result == mavlink.MAV_RESULT_ACCEPTED:
                    return result
                raise CommandDenied(command, ack.result, ack.result_param2)
