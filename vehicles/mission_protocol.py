"""The MAVLink mission protocol, ground side: upload, download, clear.

Follows https://mavlink.io/en/services/mission.html with its default timeouts
(1.5 s for an answer, 250 ms for an item, 5 retries) and what real vehicles do:

- either request kind (MISSION_REQUEST_INT or ArduPilot's float
  MISSION_REQUEST) is answered with MISSION_ITEM_INT;
- requests are answered in whatever order they come; a duplicate request
  already waiting in the inbox is answered once;
- an error MISSION_ACK ends the transfer with ``MissionError(result=...)``,
  except MAV_MISSION_INVALID_SEQUENCE mid-upload (ArduPilot NACKs an item it
  did not ask for and goes on);
- MAV_MISSION_NO_SPACE in answer to MISSION_COUNT (ArduPilot for its first
  seconds after boot) is retried after a pause, saying what we wait for, until
  ``no_space_wait_s`` has passed.
"""

from __future__ import annotations

import asyncio
import functools
import logging
import time
from collections.abc import Awaitable, Callable, Sequence
from dataclasses import dataclass

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from vehicles.errors import MissionError, MissionTimeout
from vehicles.mission_items import MISSION, MissionItem, MissionItemError
from vehicles.router import Inbox, Message, MessageRouter, send_and_wait

log = logging.getLogger(__name__)

_REQUESTS = frozenset({"MISSION_REQUEST", "MISSION_REQUEST_INT"})
_ITEMS = frozenset({"MISSION_ITEM", "MISSION_ITEM_INT"})
_ACCEPTED = mavlink.MAV_MISSION_ACCEPTED


@dataclass(frozen=True)
class MissionSettings:
    timeout_s: float = 1.5
    item_timeout_s: float = 0.25
    retries: int = 5
    #: Pause between uploads refused with MAV_MISSION_NO_SPACE.
    no_space_retry_s: float = 2.0
    #: Give up on MAV_MISSION_NO_SPACE after this long.
    no_space_wait_s: float = 30.0
    #: The whole transfer of the items has a deadline: ``timeout_s`` per resend allowed,
    #: plus this many of the round trips measured on its first exchange per item, and
    #: never less than ``min_transfer_s`` (a vehicle re-requests a lost item only every
    #: second or so: a short transfer on a lossy radio needs that time). A peer that
    #: answers one request in five, or asks for item 0 again and again, is given up
    #: instead of kept for hours.
    round_trips_per_item: float = 10.0
    min_transfer_s: float = 30.0


def _deadline_s(settings: MissionSettings, items: int, round_trip_s: float) -> float:
    """The time the items of a transfer may take, from its size and the link's pace."""
    pace = items * settings.round_trips_per_item * round_trip_s
    return settings.timeout_s * (settings.retries + 1) + max(settings.min_transfer_s, pace)


@dataclass(frozen=True)
class TransferReport:
    """How a transfer went, for logs and tests."""

    items: int
    resends: int = 0
    duplicate_requests: int = 0
    float_requests: int = 0
    no_space_waits: int = 0
    nacks_ignored: int = 0
    elapsed_s: float = 0.0


class MissionClient:
    def __init__(
        self,
        send: Callable[[Message], object],
        router: MessageRouter,
        target: Callable[[], tuple[int, int]],
        settings: MissionSettings | None = None,
        *,
        on_wait: Callable[[str], None] | None = None,
        pause: Callable[[float], Awaitable[None]] = asyncio.sleep,
    ) -> None:
        self._send = send
        self._router = router
        self._target = target
        self.settings = settings or MissionSettings()
        self.on_wait = on_wait
        self._pause = pause
        self._lock = asyncio.Lock()

    # -- helpers ------------------------------------------------------------------------

    def _from_target(self, types: frozenset[str], mission_type: int) -> Callable[[Message], bool]:
        system, _ = self._target()

        def match(msg: Message) -> bool:
            return (
                msg.get_type() in types
                and msg.get_srcSystem() == system
                and getattr(msg, "mission_type", MISSION) == mission_type
            )

        return match

    def _tell_wait(self, text: str) -> None:
        log.warning("%s", text)
        if self.on_wait is not None:
            self.on_wait(text)

    def _ack(self, result: int, mission_type: int) -> Message:
        system, component = self._target()
        return mavlink.MAVLink_mission_ack_message(system, component, result, mission_type)

    # -- upload -------------------------------------------------------------------------

    async def upload(
        self, items: Sequence[MissionItem], mission_type: int = MISSION
    ) -> TransferReport:
        """Send ``items`` (seq 0..n-1; on ArduPilot item 0 is home)."""
        for expected, item in enumerate(items):
            if item.seq != expected:
                raise ValueError(f"item {expected} has seq {item.seq}; renumber first")
        async with self._lock:
            return await self._upload(list(items), mission_type)

    async def _upload(self, items: list[MissionItem], mission_type: int) -> TransferReport:
        match = self._from_target(_REQUESTS | {"MISSION_ACK"}, mission_type)
        async with self._router.inbox(match) as inbox:
            return await _Upload(self, items, mission_type, inbox).run()

    # -- download -----------------------------------------------------------------------

    async def download(self, mission_type: int = MISSION) -> list[MissionItem]:
        """Read the vehicle's mission (item 0 is home on ArduPilot)."""
        async with self._lock:
            return await self._download(mission_type)

    async def _download(self, mission_type: int) -> list[MissionItem]:
        match = self._from_target(_ITEMS | {"MISSION_COUNT", "MISSION_ACK"}, mission_type)
        async with self._router.inbox(match) as inbox:
            asked = time.monotonic()
            count = await self._download_count(inbox, mission_type)
            now = time.monotonic()
            deadline = now + _deadline_s(self.settings, count, now - asked)
            items: list[MissionItem] = []
            for seq in range(count):
                if time.monotonic() > deadline:
                    raise MissionTimeout(
                        "download",
                        f"not done within {deadline - now:.1f} s for {count} items",
                        seq=seq,
                    )
                items.append(await self._download_item(inbox, seq, mission_type))
            self._send(self._ack(_ACCEPTED, mission_type))
            return items

    async def _download_count(self, inbox: Inbox, mission_type: int) -> int:
        """MISSION_REQUEST_LIST sent (and resent) until the vehicle tells its count."""
        s = self.settings
        system, component = self._target()
        request_list = mavlink.MAVLink_mission_request_list_message(system, component, mission_type)

        def accept_count(msg: Message) -> int | None:
            _refuse_on_error_ack(msg)
            return msg.count if msg.get_type() == "MISSION_COUNT" else None

        try:
            return await send_and_wait(
                lambda: self._send(request_list),
                inbox,
                accept_count,
                timeout_s=s.timeout_s,
                retries=s.retries,
            )
        except TimeoutError:
            raise MissionTimeout("download", "no MISSION_COUNT from the vehicle") from None

    async def _download_item(self, inbox: Inbox, seq: int, mission_type: int) -> MissionItem:
        """Item ``seq`` asked for (and asked again) until it comes."""
        s = self.settings
        system, component = self._target()
        request = mavlink.MAVLink_mission_request_int_message(system, component, seq, mission_type)

        def accept_item(msg: Message) -> MissionItem | None:
            _refuse_on_error_ack(msg)
            if msg.get_type() in _ITEMS and msg.seq == seq:
                try:
                    return MissionItem.from_message(msg)
                except MissionItemError as exc:
                    raise MissionError("download", f"the vehicle sent {exc}", seq=seq) from None
            return None  # a duplicate, a late item or a repeated count

        try:
            return await send_and_wait(
                functools.partial(self._send, request),
                inbox,
                accept_item,
                timeout_s=s.item_timeout_s,
                retries=s.retries,
            )
        except TimeoutError:
            raise MissionTimeout("download", "vehicle stopped sending items", seq=seq) from None

    # -- clear --------------------------------------------------------------------------

    async def clear(self, mission_type: int = MISSION) -> None:
        async with self._lock:
            s = self.settings
            system, component = self._target()
            clear = mavlink.MAVLink_mission_clear_all_message(system, component, mission_type)

            def accept(msg: Message) -> int:
                if msg.type != _ACCEPTED:
                    raise MissionError("clear", "vehicle refused", result=msg.type)
                return msg.type

            match = self._from_target(frozenset({"MISSION_ACK"}), mission_type)
            async with self._router.inbox(match) as inbox:
                try:
                    await send_and_wait(
                        lambda: self._send(clear),
                        inbox,
                        accept,
                        timeout_s=s.timeout_s,
                        retries=s.retries,
                    )
                except TimeoutError:
                    raise MissionTimeout("clear", "no MISSION_ACK from the vehicle") from None


def _refuse_on_error_ack(msg: Message) -> None:
    if msg.get_type() == "MISSION_ACK" and msg.type != _ACCEPTED:
        raise MissionError("download", "vehicle refused", result=msg.type)


@dataclass
class _UploadCounts:
    """What an upload went through, as ``TransferReport`` tells it."""

    resends: int = 0
    duplicate_requests: int = 0
    float_requests: int = 0
    no_space_waits: int = 0
    nacks_ignored: int = 0

    def report(self, items: int, elapsed_s: float) -> TransferReport:
        return TransferReport(
            items,
            resends=self.resends,
            duplicate_requests=self.duplicate_requests,
            float_requests=self.float_requests,
            no_space_waits=self.no_space_waits,
            nacks_ignored=self.nacks_ignored,
            elapsed_s=elapsed_s,
        )


class _Upload:
    """One upload, as the vehicle drives it: MISSION_COUNT sent, then each item it asks
    for, until its MISSION_ACK; resends on silence, waits out MAV_MISSION_NO_SPACE."""

    def __init__(
        self, client: MissionClient, items: list[MissionItem], mission_type: int, inbox: Inbox
    ) -> None:
        self.client, self.items, self.mission_type, self.inbox = client, items, mission_type, inbox
        self.s = client.settings
        self.start = time.monotonic()
        self.system, self.component = client._target()
        self.count_msg = mavlink.MAVLink_mission_count_message(
            self.system, self.component, len(items), mission_type
        )
        self.counts = _UploadCounts()
        self.last_sent: Message = self.count_msg
        self.highest_sent = -1
        self.retries_left = self.s.retries
        self.no_space_since: float | None = None
        self.deadline: float | None = None  # set by the first request
        self.count_sent = 0.0

    async def run(self) -> TransferReport:
        self.client._send(self.count_msg)
        self.count_sent = time.monotonic()
        while True:
            if self.deadline is not None and time.monotonic() > self.deadline:
                raise MissionTimeout(
                    "upload",
                    f"not done within {self.deadline - self.count_sent:.1f} s "
                    f"for {len(self.items)} items",
                    seq=self.highest_sent + 1,
                )
            try:
                msg = await self.inbox.get(self.s.timeout_s)
            except TimeoutError:
                self._resend()
                continue
            if msg.get_type() == "MISSION_ACK":
                report = await self._on_ack(msg.type)
                if report is not None:
                    return report
            else:  # MISSION_REQUEST or MISSION_REQUEST_INT
                self._on_request(msg)

    def _resend(self) -> None:
        s = self.s
        if self.retries_left == 0:
            raise MissionTimeout(
                "upload",
                f"no answer from the vehicle after {s.retries} resends of {s.timeout_s:g} s",
                seq=self.highest_sent + 1,
            ) from None
        self.retries_left -= 1
        self.counts.resends += 1
        self.client._send(self.last_sent)

    async def _on_ack(self, result: int) -> TransferReport | None:
        """The report when the upload is done; None when it goes on; or a refusal."""
        items, highest_sent = self.items, self.highest_sent
        if result == _ACCEPTED:
            if highest_sent == len(items) - 1:
                return self.counts.report(len(items), time.monotonic() - self.start)
            raise MissionError(
                "upload",
                f"vehicle ended the upload after item {highest_sent} of {len(items)}",
                seq=highest_sent + 1,
            )
        if result == mavlink.MAV_MISSION_NO_SPACE and highest_sent < 0:
            await self._wait_for_space(result)
            return None
        if result == mavlink.MAV_MISSION_INVALID_SEQUENCE and highest_sent >= 0:
            self.counts.nacks_ignored += 1
            log.debug("ignoring MAV_MISSION_INVALID_SEQUENCE mid-upload")
            return None
        raise MissionError(
            "upload",
            "vehicle refused the mission",
            result=result,
            seq=highest_sent + 1 if highest_sent + 1 < len(items) else None,
        )

    async def _wait_for_space(self, result: int) -> None:
        """MAV_MISSION_NO_SPACE to the count: the count sent again after a pause, until
        ``no_space_wait_s`` has passed."""
        s = self.s
        now = time.monotonic()
        self.no_space_since = now if self.no_space_since is None else self.no_space_since
        if now - self.no_space_since >= s.no_space_wait_s:
            raise MissionError(
                "upload",
                f"vehicle still has no space after {s.no_space_wait_s:g} s",
                result=result,
            )
        self.counts.no_space_waits += 1
        self.client._tell_wait(
            f"system {self.system} refuses the mission with MAV_MISSION_NO_SPACE "
            f"(ArduPilot does so for its first seconds after boot); "
            f"retrying in {s.no_space_retry_s:g} s"
        )
        await self.client._pause(s.no_space_retry_s)
        _drain(self.inbox)
        self.client._send(self.count_msg)
        self.last_sent = self.count_msg
        self.retries_left = s.retries

    def _on_request(self, msg: Message) -> None:
        """The item asked for, sent (a duplicate request waiting behind it answered once)."""
        items = self.items
        if self.deadline is None:
            now = time.monotonic()
            self.deadline = now + _deadline_s(self.s, len(items), now - self.count_sent)
        seq = msg.seq
        if not 0 <= seq < len(items):
            log.warning("vehicle asked for item %d of %d; ignored", seq, len(items))
            return
        if msg.get_type() == "MISSION_REQUEST":
            self.counts.float_requests += 1
        self.counts.duplicate_requests += _drop_queued_requests(self.inbox, seq)
        self.last_sent = items[seq].with_seq(seq).to_message(self.system, self.component)
        if self.mission_type != MISSION:
            self.last_sent.mission_type = self.mission_type
        self.client._send(self.last_sent)
        self.highest_sent = max(self.highest_sent, seq)
        self.retries_left = self.s.retries


def _drop_queued_requests(inbox: Inbox, seq: int) -> int:
    """Drop requests for ``seq`` already waiting (duplicates); keep the rest in order."""
    kept, dropped = [], 0
    while (msg := inbox.get_nowait()) is not None:
        if msg.get_type() in _REQUESTS and msg.seq == seq:
            dropped += 1
        else:
            kept.append(msg)
    for msg in kept:
        inbox.offer(msg)
    return dropped


def _drain(inbox: Inbox) -> None:
    while inbox.get_nowait() is not None:
        pass
