"""The mission log's messages as the web page's records, kept for live clients.

A record is one log message as the page reads it: ``{"topic", "t", "data"}``,
with ``t`` the mission seconds and ``data`` the message's own JSON, untouched.
Some topics are a history the page needs whole (the events; the poses, which
draw the tracks), the others only their latest message matters (the map, the
statuses, the progress): a client that falls behind gets the latest of those,
never a backlog, so updates coalesce by themselves.

``LiveFeed`` is a :class:`gcs.log.mcap_log.LogSink`: the log hands it every message
as it writes it, on the event loop's thread, and it only files the bytes away;
the clients' own tasks read it (``since``) at their own pace.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import re
from dataclasses import dataclass
from enum import Enum

from gcs.log.topics import (
    BTPS_TOPIC,
    EVENTS_TOPIC,
    MAP_TOPIC,
    META_TOPIC,
    PROGRESS_TOPIC,
)


class Kind(Enum):
    """How the page takes a topic: every message, or the latest one."""

    HISTORY = "history"
    LATEST = "latest"


_VEHICLE_TOPIC = re.compile(r"/vehicle/\d+/(pose|status|battery)")
_HISTORY_VEHICLE = "pose"


def kind_of(topic: str) -> Kind | None:
    """What the page does with a topic's messages; None: it does not read them (raw
    MAVLink, fixes, the tracks scene, which the poses draw again, the result)."""
    if topic == EVENTS_TOPIC:
        return Kind.HISTORY
    if topic in (META_TOPIC, MAP_TOPIC, BTPS_TOPIC, PROGRESS_TOPIC):
        return Kind.LATEST
    match = _VEHICLE_TOPIC.fullmatch(topic)
    if match is None:
        return None
    return Kind.HISTORY if match.group(1) == _HISTORY_VEHICLE else Kind.LATEST


def record(topic: str, t_s: float, data: bytes) -> bytes:
    """One record's JSON text (``data`` is JSON already, and goes in as it is)."""
    return b'{"topic":%s,"t":%s,"data":%s}' % (
        json.dumps(topic).encode(),
        repr(float(t_s)).encode(),
        data,
    )


def message(records: list[bytes], *, complete: bool = False) -> bytes:
    """What a client is sent: records in order; ``complete``: the whole mission (a replay)."""
    return b'{"records":[%s],"complete":%s}' % (
        b",".join(records),
        b"true" if complete else b"false",
    )


@dataclass(frozen=True)
class Cursor:
    """What a client has been sent: the feed's sequence number then, and how much of the
    history."""

    seq: int = 0
    history: int = 0


class LiveFeed:
    def __init__(self) -> None:
        self._seq = 0
        self._history: list[tuple[int, bytes]] = []
        self._latest: dict[str, tuple[int, bytes]] = {}
        self._changed = asyncio.Event()

    def publish(self, topic: str, schema: str, t_s: float, data: bytes) -> None:
        kind = kind_of(topic)
        if kind is None:
            return
        self._seq += 1
        entry = (self._seq, record(topic, t_s, data))
        if kind is Kind.HISTORY:
            self._history.append(entry)
        else:
            self._latest[topic] = entry
        if not self._changed.is_set():
            self._changed.set()

    def wake(self) -> None:
        """End every client's ``wait`` now (the server is closing)."""
        self._changed.set()

    async def wait(self, cursor: Cursor, timeout_s: float) -> None:
        """Until the feed holds something ``cursor`` has not seen, or ``timeout_s``."""
        if self._seq > cursor.seq:
            return
        self._changed.clear()
        with contextlib.suppress(TimeoutError):
            async with asyncio.timeout(timeout_s):
                await self._changed.wait()

    def since(self, cursor: Cursor) -> tuple[bytes | None, Cursor]:
        """The message for a client that has seen ``cursor`` (None: nothing new), and its
        cursor once sent: the history after it and the latest of every other topic that
        changed since, in the order they were written."""
        if self._seq == cursor.seq:
            return None, cursor
        entries = self._history[cursor.history :]
        entries += [e for e in self._latest.values() if e[0] > cursor.seq]
        entries.sort(key=lambda e: e[0])
        return message([r for _, r in entries]), Cursor(self._seq, len(self._history))
