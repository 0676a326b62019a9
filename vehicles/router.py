"""Routing of incoming messages: standing handlers by type, plus temporary inboxes.

An *inbox* collects every message matching a predicate while an operation
runs (a mission transfer, a command waiting for its ACK), so that nothing
arriving between two awaits is lost. ``expect`` is the one-shot form: a
future resolved by the first matching message.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections import defaultdict
from collections.abc import AsyncIterator, Callable
from typing import TypeAlias, TypeVar

from pymavlink.dialects.v20 import ardupilotmega as mavlink

log = logging.getLogger(__name__)

Message: TypeAlias = mavlink.MAVLink_message
Predicate = Callable[[Message], bool]
Handler = Callable[[Message], None]

INBOX_SIZE = 256
T = TypeVar("T")


class Inbox:
    """Messages that matched while the inbox was open, oldest first."""

    def __init__(self, predicate: Predicate, size: int = INBOX_SIZE) -> None:
        self.predicate = predicate
        self._queue: asyncio.Queue[Message] = asyncio.Queue(size)
        self.dropped = 0

    def offer(self, msg: Message) -> None:
        if not self.predicate(msg):
            return
        if self._queue.full():
            self._queue.get_nowait()
            self.dropped += 1
        self._queue.put_nowait(msg)

    async def get(self, timeout_s: float) -> Message:
        """The next message; ``TimeoutError`` if none within ``timeout_s``."""
        async with asyncio.timeout(timeout_s):
            return await self._queue.get()

    def get_nowait(self) -> Message | None:
        return None if self._queue.empty() else self._queue.get_nowait()


class MessageRouter:
    def __init__(self) -> None:
        self._handlers: dict[str, list[Handler]] = defaultdict(list)
        self._inboxes: set[Inbox] = set()

    def on(self, msg_type: str, handler: Handler) -> None:
        """Call ``handler`` for every message of ``msg_type`` (e.g. ``"HEARTBEAT"``)."""
        self._handlers[msg_type].append(handler)

    def dispatch(self, msg: Message) -> None:
        for handler in self._handlers.get(msg.get_type(), ()):
            try:
                handler(msg)
            except Exception:
                log.exception("handler for %s failed", msg.get_type())
        for inbox in list(self._inboxes):
            try:
                inbox.offer(msg)
            except Exception:
                log.exception("inbox predicate failed on %s", msg.get_type())

    @contextlib.asynccontextmanager
    async def inbox(self, predicate: Predicate, size: int = INBOX_SIZE) -> AsyncIterator[Inbox]:
        box = Inbox(predicate, size)
        self._inboxes.add(box)
        try:
            yield box
        finally:
            self._inboxes.discard(box)

    async def expect(self, predicate: Predicate, timeout_s: float) -> Message:
        """Wait for the first message matching ``predicate`` from now on."""
        async with self.inbox(predicate, size=1) as box:
            return await box.get(timeout_s)


async def send_and_wait(
    send: Callable[[], object],
    inbox: Inbox,
    accept: Callable[[Message], T | None],
    *,
    timeout_s: float,
    retries: int,
) -> T:
    """Send, then wait for a message that ``accept`` turns into a result; resend on
    timeout, ``retries`` times at most. ``accept`` returns None to skip a message
    (a duplicate, an answer to something else) and may raise to end the exchange.
    Raises ``TimeoutError`` after the last attempt."""
    loop = asyncio.get_running_loop()
    for _attempt in range(retries + 1):
        send()
        deadline = loop.time() + timeout_s
        while (remaining := deadline - loop.time()) > 0:
            try:
                msg = await inbox.get(remaining)
            except TimeoutError:
                break
            result = accept(msg)
            if result is not None:
                return result
    raise TimeoutError
