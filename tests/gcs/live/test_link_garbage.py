"""Garbage on the link, over real UDP on loopback: counted, shown, and never fatal.

A raw socket sends the ground station's link and the mock vehicle random
bytes, truncated frames, frames with a bad CRC, frames of unknown message
ids, good frames from (or addressed to) a stranger, and a flood of thousands
of such datagrams in about a second. Each kind must move its own counter
(exactly, where nothing can be lost on the way; within the number sent, for
a flood the kernel may thin), and the link must keep working: the vehicle's
telemetry still comes, a command still gets its ACK, the ground station's
replies still go to the vehicle, not to the stranger. End to end, a
``gcs run --sim`` mission completes while one vehicle's port is flooded, and
its report counts the garbage.

Every wait has a timeout; every socket is closed.
"""

from __future__ import annotations

import asyncio
import contextlib
import random
import socket
import threading
from collections import Counter
from collections.abc import AsyncIterator, Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink
from rich.console import Console

from core.clocks import ScaledClock
from core.geo import GeoFrame
from gcs.live.display import LiveDisplay
from gcs.live.run import LiveRun
from gcs.mission import load_mission
from sitl_mock.endpoint import LinkSettings as MockLinkSettings
from sitl_mock.endpoint import VehicleEndpoint
from sitl_mock.fleet import MockFleet, MockVehicleConfig
from sitl_mock.gridmap import GridMap
from sitl_mock.modes import VehicleKind
from sitl_mock.vehicle import VehicleSettings
from tests import frames
from tests.gcs.live.test_mission import SMALL, assert_log_rebuilds_the_report, report, run_sim
from tests.gcs.live.test_mission import write_mission as write_live_mission
from vehicles.endpoints import free_loopback_udp_ports, parse_endpoint
from vehicles.link import RejectedFrames, VehicleLink
from vehicles.telemetry import Topic
from vehicles.transport import MavlinkTransport

pytestmark = pytest.mark.timeout(60)

SYSID = 1
STRANGER = 42
LOOPBACK = "127.0.0.1"
GEO = GeoFrame(47.397742, 8.545594, 488.0, 1.0)
#: Real seconds any single wait may take.
WAIT_S = 5.0
#: Datagrams of each kind in the counted (not flooded) tests.
EACH = 25
FLOOD_COUNT = 4000
FLOOD_S = 1.0
#: Datagrams sent back to back before the flood pauses (fewer than a default UDP
#: receive buffer holds, so the kernel drops little).
FLOOD_BATCH = 100
#: Kinds of datagram, by the counter they must move.
BAD, UNKNOWN, FOREIGN = "bad", "unknown", "foreign"

Address = tuple[str, int]
Datagrams = Sequence[tuple[str, bytes]]


# ---------------------------------------------------------------------- garbage


def garbage_for_the_ground_station(rng: random.Random) -> list[tuple[str, bytes]]:
    """``EACH`` datagrams of every kind, as the vehicle's own frames gone wrong and a
    stranger's good ones."""
    heartbeat = frames.vehicle_heartbeat(SYSID)
    return _mixed(rng, heartbeat, frames.vehicle_heartbeat(STRANGER))


def garbage_for_the_mock(rng: random.Random) -> list[tuple[str, bytes]]:
    """The same for the mock: a ground station's command gone wrong, and commands for
    another vehicle."""
    command = frames.gcs_command(SYSID, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    return _mixed(
        rng, command, frames.gcs_command(STRANGER, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    )


def _mixed(rng: random.Random, good: bytes, foreign: bytes) -> list[tuple[str, bytes]]:
    """Interleaved, so that no kind comes in one block."""
    out: list[tuple[str, bytes]] = []
    for i in range(EACH):
        out += [
            (BAD, frames.garbage(rng, rng.randint(1, 120))),
            (BAD, frames.truncated(good, 1 + i % (len(good) - 1))),
            (BAD, frames.bad_crc(good)),
            (UNKNOWN, frames.unknown_id_frame(SYSID)),
            (FOREIGN, foreign),
        ]
    return out


@contextlib.contextmanager
def raw_socket() -> Iterator[socket.socket]:
    """A non-blocking UDP socket on loopback, closed on the way out."""
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        sock.bind((LOOPBACK, 0))
        sock.setblocking(False)
        yield sock
    finally:
        sock.close()


async def send_all(sock: socket.socket, address: Address, datagrams: Datagrams) -> Counter[str]:
    loop = asyncio.get_running_loop()
    sent: Counter[str] = Counter()
    for kind, data in datagrams:
        await loop.sock_sendto(sock, data, address)
        sent[kind] += 1
    return sent


async def flood(sock: socket.socket, address: Address, datagrams: Datagrams) -> Counter[str]:
    """``FLOOD_COUNT`` datagrams, cycling through ``datagrams``, in about ``FLOOD_S``:
    batches of ``FLOOD_BATCH`` back to back, each followed by a pause (pacing, not a
    wait for anything) in which the receivers, on this event loop, read."""
    loop = asyncio.get_running_loop()
    pause_s = FLOOD_S * FLOOD_BATCH / FLOOD_COUNT
    sent: Counter[str] = Counter()
    for i in range(FLOOD_COUNT):
        kind, data = datagrams[i % len(datagrams)]
        await loop.sock_sendto(sock, data, address)
        sent[kind] += 1
        if (i + 1) % FLOOD_BATCH == 0:
            await asyncio.sleep(pause_s)
    return sent


async def until_answered(send: Callable[[], Any], answered: Callable[[], Any], what: str) -> int:
    """Send (a marker or a probe) until ``answered`` (an awaitable factory) completes,
    each try bounded; a datagram can be lost under a flood. Returns how many were sent."""
    for attempt in range(1, 6):
        await send()
        try:
            async with asyncio.timeout(WAIT_S / 5):
                await answered()
            return attempt
        except TimeoutError:
            continue
    raise AssertionError(f"no answer to {what} after 5 tries")


# ---------------------------------------------------------------------- set-up


def mock_config(connection: str) -> MockVehicleConfig:
    return MockVehicleConfig(
        SYSID,
        VehicleSettings(kind=VehicleKind.ROVER, start_cell=(0, 0)),
        MockLinkSettings(connection),
    )


def mock_fleet(connection: str) -> MockFleet:
    grid = GridMap(obstacle=np.zeros((4, 5), dtype=bool), pads=((0, 0),))
    return MockFleet([mock_config(connection)], grid, GEO, ScaledClock(1.0))


@dataclass
class Pair:
    fleet: MockFleet
    link: VehicleLink

    @property
    def transport(self) -> MavlinkTransport:
        """The link's transport of its own (the link was opened on an endpoint)."""
        assert isinstance(self.link.transport, MavlinkTransport)
        return self.link.transport

    @property
    def link_address(self) -> Address:
        assert self.transport.local_address is not None
        return self.transport.local_address

    @property
    def mock_address(self) -> Address:
        return (LOOPBACK, self.fleet.endpoints[SYSID].local_port)


@contextlib.asynccontextmanager
async def linked() -> AsyncIterator[Pair]:
    """Our link listening on loopback (udpin) and a mock rover sending to it (udpout)."""
    async with contextlib.AsyncExitStack() as stack:
        link = await VehicleLink.connect(f"udpin:{LOOPBACK}:0", target_system=SYSID)
        stack.push_async_callback(link.close)
        assert isinstance(link.transport, MavlinkTransport)
        assert link.transport.local_address is not None
        fleet = mock_fleet(f"udpout:{LOOPBACK}:{link.transport.local_address[1]}")
        await stack.enter_async_context(fleet)
        await link.wait_heartbeat(timeout_s=WAIT_S)
        yield Pair(fleet, link)


def marker_tap(link: VehicleLink, text: str) -> asyncio.Event:
    """An event set when the transport takes in ``text`` from the stranger: all that
    was sent before it from the same socket has been through the parser by then."""
    seen = asyncio.Event()

    def tap(direction: str, _frame: bytes, msg: Any) -> None:
        if direction == "in" and msg.get_type() == "STATUSTEXT" and msg.text == text:
            seen.set()

    link.transport.add_tap(tap)
    return seen


async def caught_up(link: VehicleLink) -> None:
    """Return once the link's reader took in a position sent after now (so it has read
    everything queued before it)."""
    await link.wait_for(Topic.POSITION, lambda _p: True, timeout_s=WAIT_S)


async def still_works(pair: Pair) -> None:
    """A command round trip, the link up, and our replies still going to the vehicle."""
    ack = await pair.link.set_message_interval(mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT, 4.0)
    assert ack.result == mavlink.MAV_RESULT_ACCEPTED
    assert pair.link.is_up
    assert pair.transport.peer == pair.mock_address


def delta(after: RejectedFrames, before: RejectedFrames) -> dict[str, int]:
    return {
        BAD: after.bad_frames - before.bad_frames,
        UNKNOWN: after.unknown_messages - before.unknown_messages,
        FOREIGN: after.foreign_frames - before.foreign_frames,
        "signatures": after.bad_signatures - before.bad_signatures,
    }


# ---------------------------------------------------------------------- ground station


async def test_ground_station_counts_every_kind_of_garbage() -> None:
    async with asyncio.timeout(30), linked() as pair:
        link = pair.link
        before = link.rejected
        marker = "end of garbage"
        seen = marker_tap(link, marker)
        with raw_socket() as sock:
            sent = await send_all(
                sock, pair.link_address, garbage_for_the_ground_station(random.Random(1))
            )
            sent += await send_all(
                sock, pair.link_address, [(FOREIGN, frames.statustext(STRANGER, marker))]
            )
            async with asyncio.timeout(WAIT_S):
                await seen.wait()
        # Garbage and a stranger's frames never take over the reply address.
        assert pair.transport.peer == pair.mock_address
        await caught_up(link)
        assert delta(link.rejected, before) == {
            BAD: 3 * EACH,
            UNKNOWN: EACH,
            FOREIGN: EACH + 1,
            "signatures": 0,
        }
        assert sent == {BAD: 3 * EACH, UNKNOWN: EACH, FOREIGN: EACH + 1}
        await still_works(pair)


async def test_ground_station_survives_a_flood() -> None:
    async with asyncio.timeout(40), linked() as pair:
        link = pair.link
        before = link.rejected
        marker = "end of flood"
        seen = marker_tap(link, marker)
        loop = asyncio.get_running_loop()
        with raw_socket() as sock:
            t0 = loop.time()
            sent = await flood(
                sock, pair.link_address, garbage_for_the_ground_station(random.Random(2))
            )
            flood_s = loop.time() - t0
            markers = await until_answered(
                lambda: loop.sock_sendto(
                    sock, frames.statustext(STRANGER, marker), pair.link_address
                ),
                seen.wait,
                "the end-of-flood marker",
            )
        await caught_up(link)
        counted = delta(link.rejected, before)
        sent[FOREIGN] += markers
        for kind in (BAD, UNKNOWN, FOREIGN):
            # The kernel may drop datagrams under a flood, never add any.
            assert sent[kind] // 10 <= counted[kind] <= sent[kind], (kind, counted, sent)
        assert counted["signatures"] == 0
        assert sum(sent.values()) >= FLOOD_COUNT and flood_s < 10 * FLOOD_S, flood_s
        await still_works(pair)


# ---------------------------------------------------------------------- mock vehicle


@contextlib.asynccontextmanager
async def lone_mock() -> AsyncIterator[tuple[MockFleet, Address]]:
    """A mock rover listening on loopback (udpin): whoever talks to it is its peer."""
    port = free_loopback_udp_ports(1)[0]
    fleet = mock_fleet(f"udpin:{LOOPBACK}:{port}")
    async with fleet:
        yield fleet, (LOOPBACK, port)


async def acked(sock: socket.socket, command: int) -> None:
    """Read the mock's datagrams until one holds the COMMAND_ACK of ``command``."""
    loop = asyncio.get_running_loop()
    codec = mavlink.MAVLink(None, frames.GCS_SYSTEM, frames.GCS_COMPONENT)
    codec.robust_parsing = True
    while True:
        data = await loop.sock_recv(sock, 65536)
        for msg in codec.parse_buffer(data) or []:
            if msg.get_type() == "COMMAND_ACK" and msg.command == command:
                assert msg.result == mavlink.MAV_RESULT_ACCEPTED
                return


def endpoint_counts(endpoint: VehicleEndpoint) -> dict[str, int]:
    return {
        BAD: endpoint.bad_frames,
        UNKNOWN: endpoint.unknown_messages,
        FOREIGN: endpoint.foreign_frames,
        "signatures": endpoint.rejected_signatures,
    }


PROBE_COMMAND = mavlink.MAV_CMD_SET_MESSAGE_INTERVAL
PROBE = frames.gcs_command(SYSID, PROBE_COMMAND, mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT, 2.5e5)


async def test_mock_counts_every_kind_of_garbage_and_still_answers() -> None:
    async with asyncio.timeout(30), lone_mock() as (fleet, address):
        endpoint = fleet.endpoints[SYSID]
        with raw_socket() as sock:
            sent = await send_all(sock, address, garbage_for_the_mock(random.Random(3)))
            # The ACK to this command comes after everything sent before it was read.
            await send_all(sock, address, [("probe", PROBE)])
            async with asyncio.timeout(WAIT_S):
                await acked(sock, PROBE_COMMAND)
        assert endpoint_counts(endpoint) == {**sent, "signatures": 0}
        assert sent == {BAD: 3 * EACH, UNKNOWN: EACH, FOREIGN: EACH}
        # The commands for another vehicle (arm) were not carried out here.
        assert not fleet.vehicles[SYSID].armed


async def test_mock_survives_a_flood() -> None:
    async with asyncio.timeout(40), lone_mock() as (fleet, address):
        endpoint = fleet.endpoints[SYSID]
        loop = asyncio.get_running_loop()
        with raw_socket() as sock:
            sent = await flood(sock, address, garbage_for_the_mock(random.Random(4)))
            await until_answered(
                lambda: loop.sock_sendto(sock, PROBE, address),
                lambda: acked(sock, PROBE_COMMAND),
                "a command after the flood",
            )
        counted = endpoint_counts(endpoint)
        for kind in (BAD, UNKNOWN, FOREIGN):
            assert sent[kind] // 10 <= counted[kind] <= sent[kind], (kind, counted, sent)
        assert counted["signatures"] == 0
        assert not fleet.vehicles[SYSID].armed


# ---------------------------------------------------------------------- shown


def test_display_shows_rejected_frames_per_vehicle() -> None:
    links: dict[int, Any] = {
        1: SimpleNamespace(rejected=RejectedFrames(bad_frames=12, foreign_frames=3)),
        2: SimpleNamespace(rejected=RejectedFrames()),
    }
    run = LiveRun(SimpleNamespace(name="garbage"), ScaledClock(1.0), {}, links=links)  # type: ignore[arg-type]
    display = LiveDisplay(quiet=True)
    display.attach(run)

    def shown() -> str:
        console = Console(record=True, width=200)
        console.print(display.render())
        return console.export_text()

    text = shown()
    assert "rejected frames: vehicle 1: 12 bad, 3 foreign" in text
    assert "vehicle 2:" not in text
    links[1] = SimpleNamespace(rejected=RejectedFrames())
    assert "rejected frames" not in shown()


# ---------------------------------------------------------------------- end to end


class Flooder(threading.Thread):
    """Floods one UDP port from its own socket until stopped; counts what it sent."""

    RATE_HZ = 2000
    BATCH = 20

    def __init__(self, port: int, datagrams: Datagrams) -> None:
        super().__init__(name="garbage-flooder", daemon=True)
        self.address = (LOOPBACK, port)
        self.datagrams = datagrams
        self.sent: Counter[str] = Counter()
        self.stop = threading.Event()

    def run(self) -> None:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
            i = 0
            while not self.stop.is_set():
                for _ in range(self.BATCH):
                    kind, data = self.datagrams[i % len(self.datagrams)]
                    i += 1
                    with contextlib.suppress(OSError):  # nobody listening yet
                        sock.sendto(data, self.address)
                        self.sent[kind] += 1
                self.stop.wait(self.BATCH / self.RATE_HZ)  # pacing; wakes at once when stopped


def test_mission_completes_while_a_vehicle_port_is_flooded(tmp_path: Path) -> None:
    mission = write_live_mission(tmp_path, SMALL, [{"type": "rover"}])
    port = parse_endpoint(load_mission(mission).fleet[0].connection).port
    out = tmp_path / "live"
    flooder = Flooder(port, garbage_for_the_ground_station(random.Random(5)))
    flooder.start()
    try:
        code = run_sim(mission, out, "--keep-ports")  # the port the flood is aimed at
    finally:
        flooder.stop.set()
        flooder.join(timeout=WAIT_S)
    assert not flooder.is_alive()
    got = report(out)
    assert code == 0, got
    assert got["complete"] and got["lost_agents"] == 0
    sent = flooder.sent
    assert sent[BAD] > 1000, sent
    # Counted, within what was sent (some arrived before the port was open or after
    # it closed).
    assert 0 < got["link_bad_frames"] <= sent[BAD], (got["link_bad_frames"], sent)
    assert 0 < got["link_unknown_messages"] <= sent[UNKNOWN]
    assert 0 < got["link_foreign_frames"] <= sent[FOREIGN]
    assert got["link_bad_signatures"] == 0
    assert_log_rebuilds_the_report(out, got, [SYSID])
