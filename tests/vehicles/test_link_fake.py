"""An in-test fake vehicle written with the pymavlink codec, for the link tests.

It listens on UDP like a vehicle, answers commands from a script, runs the
vehicle side of the mission protocol (with knobs for the awkward things real
autopilots do: float MISSION_REQUEST, duplicate and out-of-order requests,
NO_SPACE after boot, error ACKs, NACKs for unrequested items) and can drop a
fraction of packets in either direction. The tests at the bottom check the
fake itself.
"""

from __future__ import annotations

import asyncio
import contextlib
import random
from collections import defaultdict, deque
from collections.abc import Coroutine
from dataclasses import dataclass, field
from typing import Any, TypeAlias

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from vehicles.mission_items import MissionItem
from vehicles.signing import SigningConfig, apply_signing

Message: TypeAlias = mavlink.MAVLink_message


@dataclass
class FakeOptions:
    system_id: int = 1
    component_id: int = 1
    mav_type: int = mavlink.MAV_TYPE_GROUND_ROVER
    autopilot: int = mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA
    custom_mode: int = 0
    heartbeat_period_s: float = 0.05
    drop_in: float = 0.0
    drop_out: float = 0.0
    seed: int = 1
    # mission protocol knobs
    float_requests: bool = False
    duplicate_requests: bool = False
    out_of_order: bool = False
    no_space_times: int = 0
    error_ack_at: int | None = None
    error_ack_result: int = mavlink.MAV_MISSION_INVALID_PARAM1
    nack_unexpected_items: bool = False
    item_timeout_s: float = 0.05
    item_retries: int = 20
    #: command id -> results to answer in turn (None = stay silent); then ACCEPTED.
    command_script: dict[int, list[int | None]] = field(default_factory=dict)
    signing: SigningConfig | None = None
    #: seq -> the message sent for that item when it is requested, whatever it holds (a
    #: vehicle that sends what it likes).
    raw_items: dict[int, Message] = field(default_factory=dict)
    #: Answer only every n-th request for a mission item (a peer that drags a download on).
    answer_every: int = 1
    #: On an upload, ask for item 0 again and again and never for the next.
    rerequest_first: bool = False


class FakeVehicle:
    def __init__(self, options: FakeOptions | None = None) -> None:
        self.o = options or FakeOptions()
        self.codec = mavlink.MAVLink(None, self.o.system_id, self.o.component_id)
        self.codec.robust_parsing = True
        apply_signing(self.codec, self.o.signing)
        self.rng = random.Random(self.o.seed)
        self.mission: list[MissionItem] = []
        self.received: list[Message] = []
        self.commands: list[Message] = []
        self.requests_sent: list[tuple[str, int]] = []
        self.bad_frames = 0
        self.peer: tuple[str, int] | None = None
        self.port = 0
        self.armed = False
        self._transport: asyncio.DatagramTransport | None = None
        self._tasks: set[asyncio.Task[None]] = set()
        self._items: asyncio.Queue[Message] = asyncio.Queue()
        self._receiving = False
        self._item_requests = 0
        self._script = {k: deque(v) for k, v in self.o.command_script.items()}
        self._waiters: dict[str, list[asyncio.Future[Message]]] = defaultdict(list)

    async def start(self) -> FakeVehicle:
        loop = asyncio.get_running_loop()
        self._transport, _ = await loop.create_datagram_endpoint(
            lambda: _Protocol(self), local_addr=("127.0.0.1", 0)
        )
        self.port = self._transport.get_extra_info("sockname")[1]
        self._spawn(self._heartbeats())
        return self

    async def close(self) -> None:
        for task in list(self._tasks):
            task.cancel()
        for task in list(self._tasks):
            with contextlib.suppress(asyncio.CancelledError, Exception):
                await task
        if self._transport is not None:
            self._transport.close()

    async def __aenter__(self) -> FakeVehicle:
        return await self.start()

    async def __aexit__(self, *exc: object) -> None:
        await self.close()

    @property
    def endpoint(self) -> str:
        """The connection string for the ground side."""
        return f"udpout:127.0.0.1:{self.port}"

    def _spawn(self, coro: Coroutine[Any, Any, None]) -> None:
        task = asyncio.get_running_loop().create_task(coro)
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)

    # -- wire ---------------------------------------------------------------------------

    def send(self, msg: Message, *, lossless: bool = False) -> None:
        buf = msg.pack(self.codec)
        self.codec.seq = (self.codec.seq + 1) % 256
        if self._transport is None or self.peer is None:
            return
        if not lossless and self.rng.random() < self.o.drop_out:
            return
        self._transport.sendto(bytes(buf), self.peer)

    def send_raw(self, data: bytes) -> None:
        if self._transport is not None and self.peer is not None:
            self._transport.sendto(data, self.peer)

    def _datagram(self, data: bytes, addr: tuple[str, int]) -> None:
        self.peer = addr
        if self.rng.random() < self.o.drop_in:
            return
        for msg in self.codec.parse_buffer(data) or []:
            if msg.get_type() == "BAD_DATA":
                self.bad_frames += 1
                continue
            self.received.append(msg)
            for fut in self._waiters.pop(msg.get_type(), []):
                if not fut.done():
                    fut.set_result(msg)
            handler = getattr(self, f"_on_{msg.get_type().lower()}", None)
            if handler is not None:
                handler(msg)

    async def wait_message(self, msg_type: str, timeout_s: float = 2.0) -> Message:
        fut: asyncio.Future[Message] = asyncio.get_running_loop().create_future()
        self._waiters[msg_type].append(fut)
        async with asyncio.timeout(timeout_s):
            return await fut

    def heartbeat(self) -> Message:
        base = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
        if self.armed:
            base |= mavlink.MAV_MODE_FLAG_SAFETY_ARMED
        return mavlink.MAVLink_heartbeat_message(
            self.o.mav_type, self.o.autopilot, base, self.o.custom_mode, 4, 3
        )

    async def _heartbeats(self) -> None:
        while True:
            self.send(self.heartbeat())
            await asyncio.sleep(self.o.heartbeat_period_s)

    # -- commands -----------------------------------------------------------------------

    def _answer_command(self, msg: Message) -> None:
        self.commands.append(msg)
        self._reply_command(msg)

    def _reply_command(self, msg: Message) -> None:
        script = self._script.get(msg.command)
        result = script.popleft() if script else mavlink.MAV_RESULT_ACCEPTED
        if result is None:
            return
        if result == mavlink.MAV_RESULT_ACCEPTED:
            self._apply_command(msg)
        self.send(
            mavlink.MAVLink_command_ack_message(
                msg.command, result, 50, 0, msg.get_srcSystem(), msg.get_srcComponent()
            )
        )
        if result == mavlink.MAV_RESULT_IN_PROGRESS and script is not None and script:
            # the final answer follows on its own, like a long-running command
            self._reply_command(msg)

    def _apply_command(self, msg: Message) -> None:
        if msg.command == mavlink.MAV_CMD_DO_SET_MODE:
            self.o.custom_mode = int(msg.param2)
        elif msg.command == mavlink.MAV_CMD_COMPONENT_ARM_DISARM:
            self.armed = msg.param1 == 1
        elif msg.command == mavlink.MAV_CMD_REQUEST_MESSAGE:
            reply = self.telemetry.get(int(msg.param1))
            if reply is not None:
                self.send(reply)

    @property
    def telemetry(self) -> dict[int, Message]:
        """What the fake answers to MAV_CMD_REQUEST_MESSAGE."""
        return {
            mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT: mavlink.MAVLink_global_position_int_message(
                0, 473977420, 85455940, 488_000, 0, 0, 0, 0, 0
            ),
            mavlink.MAVLINK_MSG_ID_SYS_STATUS: mavlink.MAVLink_sys_status_message(
                0, 0, 0, 0, 12600, 100, 87, 0, 0, 0, 0, 0, 0
            ),
        }

    _on_command_long = _answer_command
    _on_command_int = _answer_command

    # -- mission: vehicle side ----------------------------------------------------------

    def _on_mission_count(self, msg: Message) -> None:
        if self._receiving:
            return
        if self.o.no_space_times > 0:
            self.o.no_space_times -= 1
            self._mission_ack(mavlink.MAV_MISSION_NO_SPACE)
            return
        self._receiving = True
        self._items = asyncio.Queue()
        self._spawn(self._receive_mission(msg.count))

    def _on_mission_item_int(self, msg: Message) -> None:
        if self._receiving:
            self._items.put_nowait(msg)
        elif self.mission and msg.seq == len(self.mission) - 1:
            self._mission_ack(mavlink.MAV_MISSION_ACCEPTED)  # our final ACK was lost

    def _mission_ack(self, result: int) -> None:
        self.send(mavlink.MAVLink_mission_ack_message(255, 190, result, 0))

    def _request(self, seq: int) -> None:
        kind = "MISSION_REQUEST" if self.o.float_requests else "MISSION_REQUEST_INT"
        make = (
            mavlink.MAVLink_mission_request_message
            if self.o.float_requests
            else mavlink.MAVLink_mission_request_int_message
        )
        for _ in range(2 if self.o.duplicate_requests else 1):
            self.requests_sent.append((kind, seq))
            self.send(make(255, 190, seq, 0))

    async def _receive_mission(self, count: int) -> None:
        order = list(range(count))
        if self.o.out_of_order:
            self.rng.shuffle(order)
        got: dict[int, MissionItem] = {}
        try:
            while self.o.rerequest_first:
                self._request(0)
                await self._wait_item(0)
            for seq in order:
                for _attempt in range(self.o.item_retries):
                    self._request(seq)
                    item = await self._wait_item(seq)
                    if item is not None:
                        break
                else:
                    return  # give up silently, like a vehicle whose GCS vanished
                if self.o.error_ack_at == seq:
                    self._mission_ack(self.o.error_ack_result)
                    return
                got[seq] = item
            self.mission = [got[s] for s in range(count)]
            self._mission_ack(mavlink.MAV_MISSION_ACCEPTED)
        finally:
            self._receiving = False

    async def _wait_item(self, seq: int) -> MissionItem | None:
        loop = asyncio.get_running_loop()
        deadline = loop.time() + self.o.item_timeout_s
        while (remaining := deadline - loop.time()) > 0:
            try:
                async with asyncio.timeout(remaining):
                    msg = await self._items.get()
            except TimeoutError:
                return None
            if msg.seq == seq:
                return MissionItem.from_message(msg)
            if self.o.nack_unexpected_items:
                self._mission_ack(mavlink.MAV_MISSION_INVALID_SEQUENCE)
        return None

    def _on_mission_request_list(self, msg: Message) -> None:
        self.send(mavlink.MAVLink_mission_count_message(255, 190, len(self.mission), 0))

    def _on_mission_request_int(self, msg: Message) -> None:
        self._item_requests += 1
        if self._item_requests % self.o.answer_every:
            return
        if msg.seq in self.o.raw_items:
            self.send(self.o.raw_items[msg.seq])
        elif 0 <= msg.seq < len(self.mission):
            self.send(self.mission[msg.seq].to_message(255, 190))

    def _on_mission_clear_all(self, msg: Message) -> None:
        self.mission = []
        self._mission_ack(mavlink.MAV_MISSION_ACCEPTED)


class _Protocol(asyncio.DatagramProtocol):
    def __init__(self, owner: FakeVehicle) -> None:
        self.owner = owner

    def datagram_received(self, data: bytes, addr: tuple[str, int]) -> None:
        self.owner._datagram(data, addr)


def sample_items(n: int) -> list[MissionItem]:
    """Home + waypoints around Zürich, each different."""
    return [
        MissionItem.waypoint(seq, 47.397742 + seq * 1e-5, 8.545594 - seq * 2e-5, 10.0 + seq % 7)
        for seq in range(n)
    ]


# -- tests of the fake itself -------------------------------------------------------------


async def test_fake_binds_and_closes() -> None:
    async with FakeVehicle() as fake:
        assert fake.port > 0
        assert fake.endpoint.startswith("udpout:127.0.0.1:")


def test_sample_items_are_distinct() -> None:
    items = sample_items(10)
    assert len({(i.x, i.y) for i in items}) == 10
    assert [i.seq for i in items] == list(range(10))
