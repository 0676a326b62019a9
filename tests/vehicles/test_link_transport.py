"""The transport on its own: endpoints, UDP both ways, TCP both ways, garbage, signing."""

from __future__ import annotations

import asyncio
import socket

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from tests.vehicles.test_link_fake import FakeOptions, FakeVehicle
from vehicles import endpoints
from vehicles.endpoints import (
    EndpointKind,
    free_loopback_tcp_ports,
    free_loopback_udp_ports,
    parse_endpoint,
)
from vehicles.errors import EndpointError, HeartbeatTimeout, LinkError
from vehicles.link import LinkSettings, VehicleLink
from vehicles.signing import SigningConfig
from vehicles.transport import MavlinkTransport

pytestmark = pytest.mark.timeout(20)


def _heartbeat() -> mavlink.MAVLink_heartbeat_message:
    return mavlink.MAVLink_heartbeat_message(
        mavlink.MAV_TYPE_GROUND_ROVER, mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA, 0, 4, 4, 3
    )


@pytest.mark.parametrize(
    ("text", "kind", "host", "port"),
    [
        ("udpin:127.0.0.1:14550", EndpointKind.UDP_IN, "127.0.0.1", 14550),
        ("udpout:localhost:14550", EndpointKind.UDP_OUT, "localhost", 14550),
        ("tcp:127.0.0.1:5760", EndpointKind.TCP, "127.0.0.1", 5760),
        ("tcpin:127.0.0.1:5760", EndpointKind.TCP_IN, "127.0.0.1", 5760),
        ("udpin://127.0.0.1:14540", EndpointKind.UDP_IN, "127.0.0.1", 14540),
    ],
)
def test_parse_endpoint(text: str, kind: EndpointKind, host: str, port: int) -> None:
    ep = parse_endpoint(text)
    assert (ep.kind, ep.host, ep.port) == (kind, host, port)


@pytest.mark.parametrize(
    ("text", "why"),
    [
        ("serial:/dev/ttyUSB0:fast", "baud rate 'fast' is not a number"),
        ("/dev/ttyUSB0,0", "must be positive"),
        ("serial:", "no serial device"),
        ("radio:/dev/ttyUSB0", "unknown kind"),
        ("udpin:127.0.0.1", "missing port|not a number"),
        ("tcp:127.0.0.1:99999", "out of range"),
        ("tcp:10.0.0.1:5760", "not loopback"),
        ("nonsense", "expected KIND:HOST:PORT"),
    ],
)
def test_bad_endpoints(text: str, why: str) -> None:
    with pytest.raises(EndpointError, match=why):
        parse_endpoint(text)


@pytest.mark.parametrize(
    ("text", "device", "baud", "flow"),
    [
        ("serial:/dev/ttyUSB0:57600", "/dev/ttyUSB0", 57600, False),
        ("serial:///dev/ttyUSB0:115200", "/dev/ttyUSB0", 115200, False),
        ("serial_flowcontrol:///dev/ttyACM0:921600", "/dev/ttyACM0", 921600, True),
        ("/dev/ttyUSB1,57600", "/dev/ttyUSB1", 57600, False),
        ("/dev/serial/by-id/usb-radio", "/dev/serial/by-id/usb-radio", 57600, False),
    ],
)
def test_parse_serial_device(text: str, device: str, baud: int, flow: bool) -> None:
    """MAVSDK's, pymavlink's and MAVProxy's spellings; a serial device is local, so it
    needs no --allow-remote."""
    ep = parse_endpoint(text)
    assert (ep.kind, ep.device, ep.baud, ep.flow_control) == (
        EndpointKind.SERIAL,
        device,
        baud,
        flow,
    )
    assert parse_endpoint(str(ep)) == ep


def test_remote_allowed_explicitly() -> None:
    assert parse_endpoint("tcp:10.0.0.1:5760", allow_remote=True).host == "10.0.0.1"


@pytest.mark.parametrize("kind", [socket.SOCK_DGRAM, socket.SOCK_STREAM])
def test_free_ports_are_bindable_and_outside_the_ephemeral_range(kind: int) -> None:
    """A port picked for a mock fleet must not be one the kernel may hand to any
    socket bound to port 0 before the fleet binds it (the ephemeral range starts at
    32768 on Linux)."""
    pick = free_loopback_udp_ports if kind == socket.SOCK_DGRAM else free_loopback_tcp_ports
    ports = pick(40)
    assert len(set(ports)) == 40
    assert all(1024 < p < 32768 for p in ports)
    for port in ports:
        with socket.socket(socket.AF_INET, kind) as s:
            s.bind(("127.0.0.1", port))


def test_free_ports_skip_the_ones_in_use(monkeypatch: pytest.MonkeyPatch) -> None:
    """With the only port of the window taken, another free one is found."""
    (first,) = free_loopback_udp_ports(1)
    monkeypatch.setattr(endpoints, "_PICK_PORTS", range(first, first + 1))
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as held:
        held.bind(("127.0.0.1", first))
        (other,) = free_loopback_udp_ports(1)  # the window is full: any free port
    assert other != first


async def test_udpin_silent_until_heard_then_replies_to_sender() -> None:
    async with await MavlinkTransport.open("udpin:127.0.0.1:0") as ours:
        assert ours.send(_heartbeat()) is False
        assert ours.stats.unsent == 1
        local = ours.local_address
        assert local is not None
        async with await MavlinkTransport.open(
            f"udpout:127.0.0.1:{local[1]}", source_system=7, source_component=1
        ) as theirs:
            theirs.send(_heartbeat())
            msg = await asyncio.wait_for(ours.recv(), 2)
            assert msg.get_srcSystem() == 7
            assert ours.send(_heartbeat()) is True
            back = await asyncio.wait_for(theirs.recv(), 2)
            assert (back.get_srcSystem(), back.get_srcComponent()) == (255, 190)


async def test_garbage_and_crc_errors_are_counted_not_raised() -> None:
    async with await MavlinkTransport.open("udpin:127.0.0.1:0") as ours:
        port = ours.local_address[1]  # type: ignore[index]
        codec = mavlink.MAVLink(None, 3, 1)
        good = bytes(_heartbeat().pack(codec))
        corrupt = bytearray(good)
        corrupt[-1] ^= 0xFF
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            for data in (b"\x00\x01garbage\xff" * 10, bytes(corrupt), b"\xfd\x09", good):
                s.sendto(data, ("127.0.0.1", port))
            msg = await asyncio.wait_for(ours.recv(), 2)
        assert msg.get_type() == "HEARTBEAT"
        assert ours.stats.bad_frames >= 2
        assert ours.stats.frames_in == 1


async def test_recv_raises_once_closed() -> None:
    transport = await MavlinkTransport.open("udpin:127.0.0.1:0")
    waiter = asyncio.ensure_future(transport.recv())
    await asyncio.sleep(0)
    await transport.close()
    with pytest.raises(LinkError):
        await asyncio.wait_for(waiter, 2)


async def test_tcp_client_and_tcpin_server() -> None:
    port = free_loopback_tcp_ports(1)[0]
    async with await MavlinkTransport.open(
        f"tcpin:127.0.0.1:{port}", source_system=1, source_component=1
    ) as vehicle:
        link = await VehicleLink.connect(
            f"tcp:127.0.0.1:{port}", settings=LinkSettings(heartbeat_period_s=0.05)
        )
        try:
            gcs_heartbeat = await asyncio.wait_for(vehicle.recv(), 2)
            assert gcs_heartbeat.get_srcSystem() == 255
            vehicle.send(_heartbeat())
            status = await link.wait_heartbeat(2)
            assert status.mode_name == "HOLD"
        finally:
            await link.close()


async def test_tcp_connection_refused_is_a_link_error() -> None:
    with pytest.raises(LinkError, match="cannot open"):
        await MavlinkTransport.open(f"tcp:127.0.0.1:{free_loopback_tcp_ports(1)[0]}")


KEY = SigningConfig.from_passphrase("staying alive").key


async def test_signed_both_ways() -> None:
    options = FakeOptions(signing=SigningConfig(KEY, require_signed=True))
    async with FakeVehicle(options) as fake:
        link = await VehicleLink.connect(
            fake.endpoint,
            signing=SigningConfig(KEY, require_signed=True),
            settings=LinkSettings(heartbeat_period_s=0.05),
        )
        try:
            await link.wait_heartbeat(2)
            await link.arm()
            assert fake.armed
            assert fake.codec.signing.goodsig_count > 0
            assert isinstance(link.transport, MavlinkTransport)
            assert link.transport.codec.signing.goodsig_count > 0
        finally:
            await link.close()


async def test_wrong_key_is_rejected_and_counted() -> None:
    options = FakeOptions(signing=SigningConfig(bytes(32)))
    async with FakeVehicle(options) as fake:
        link = await VehicleLink.connect(
            fake.endpoint,
            signing=SigningConfig(KEY, require_signed=True),
            settings=LinkSettings(heartbeat_period_s=0.05),
        )
        try:
            with pytest.raises(HeartbeatTimeout):
                await link.wait_heartbeat(0.3)
            assert link.transport.stats.bad_signatures > 0
        finally:
            await link.close()


async def test_unsigned_rejected_when_signing_required() -> None:
    async with FakeVehicle() as fake:
        link = await VehicleLink.connect(
            fake.endpoint,
            signing=SigningConfig(KEY, require_signed=True),
            settings=LinkSettings(heartbeat_period_s=0.05),
        )
        try:
            with pytest.raises(HeartbeatTimeout):
                await link.wait_heartbeat(0.3)
        finally:
            await link.close()


async def test_unsigned_accepted_when_not_required() -> None:
    async with FakeVehicle() as fake:
        link = await VehicleLink.connect(
            fake.endpoint,
            signing=SigningConfig(KEY),
            settings=LinkSettings(heartbeat_period_s=0.05),
        )
        try:
            await link.wait_heartbeat(2)
            await fake.wait_message("HEARTBEAT")
            assert fake.codec.signing.sig_count > 0  # what we send carries a signature
        finally:
            await link.close()


def test_signing_key_must_be_32_bytes() -> None:
    with pytest.raises(ValueError, match="32 bytes"):
        SigningConfig(b"short")
