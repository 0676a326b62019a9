"""Byte transports of the mock vehicles: UDP out, UDP in, TCP server, serial, on asyncio.

A transport turns a socket or device into ``Peer`` objects (a far end one can
write to) and reports bytes received from each to a ``PeerListener``. It knows
nothing of MAVLink. ``close`` closes every socket it opened (``sitl_mock.radio``
puts several vehicles behind one).
"""

from __future__ import annotations

import asyncio
import logging
from typing import Protocol

from sitl_mock.connection import Endpoint, LinkKind
from vehicles.serial_port import SerialPort

log = logging.getLogger(__name__)


class Peer(Protocol):
    name: str
    #: Whether each ``peer_received`` call is one datagram (whole frames only) or a
    #: slice of a byte stream (a frame may go on in the next call).
    datagrams: bool

    def write(self, data: bytes) -> None: ...


class PeerListener(Protocol):
    def peer_opened(self, peer: Peer) -> None: ...

    def peer_received(self, peer: Peer, data: bytes) -> None: ...

    def peer_closed(self, peer: Peer) -> None: ...


class Transport(Protocol):
    @property
    def local_port(self) -> int: ...

    async def start(self) -> None: ...

    async def close(self) -> None: ...


class _UdpPeer:
    datagrams = True

    def __init__(self, transport: asyncio.DatagramTransport, address: tuple[str, int]) -> None:
        self._transport = transport
        self.address = address
        self.name = f"udp:{address[0]}:{address[1]}"

    def write(self, data: bytes) -> None:
        if not self._transport.is_closing():
            self._transport.sendto(data, self.address)


class _UdpProtocol(asyncio.DatagramProtocol):
    def __init__(self, owner: _UdpTransport) -> None:
        self._owner = owner

    def datagram_received(self, data: bytes, addr: tuple[str, int]) -> None:
        self._owner.datagram(data, addr)

    def error_received(self, exc: Exception) -> None:
        # ICMP port unreachable while the ground station is not up yet: keep going.
        log.debug("udp error on %s: %s", self._owner.endpoint, exc)


class _UdpTransport:
    """udpout (send to a fixed address) or udpin (listen; answer the last sender)."""

    def __init__(self, endpoint: Endpoint, listener: PeerListener) -> None:
        self.endpoint = endpoint
        self._listener = listener
        self._transport: asyncio.DatagramTransport | None = None
        self._peer: _UdpPeer | None = None

    @property
    def local_port(self) -> int:
        assert self._transport is not None
        return int(self._transport.get_extra_info("sockname")[1])

    async def start(self) -> None:
        loop = asyncio.get_running_loop()
        listening = self.endpoint.kind is LinkKind.UDPIN
        local = (self.endpoint.host, self.endpoint.port if listening else 0)
        transport, _ = await loop.create_datagram_endpoint(
            lambda: _UdpProtocol(self), local_addr=local
        )
        self._transport = transport
        if not listening:
            self._peer = _UdpPeer(transport, (self.endpoint.host, self.endpoint.port))
            self._listener.peer_opened(self._peer)

    def datagram(self, data: bytes, addr: tuple[str, int]) -> None:
        assert self._transport is not None
        if self._peer is None:
            self._peer = _UdpPeer(self._transport, addr)
            self._listener.peer_opened(self._peer)
        elif self.endpoint.kind is LinkKind.UDPIN and self._peer.address != addr:
            self._peer.address = addr  # answer whoever spoke last, as pymavlink's udpin does
        self._listener.peer_received(self._peer, data)

    async def close(self) -> None:
        if self._transport is not None:
            self._transport.close()
            self._transport = None
        if self._peer is not None:
            self._listener.peer_closed(self._peer)
            self._peer = None


class _TcpPeer:
    datagrams = False

    def __init__(self, writer: asyncio.StreamWriter) -> None:
        self._writer = writer
        host, port = writer.get_extra_info("peername")[:2]
        self.name = f"tcp:{host}:{port}"

    def write(self, data: bytes) -> None:
        if not self._writer.is_closing():
            self._writer.write(data)


class _TcpServerTransport:
    """tcpin: a TCP server, one peer per connected client."""

    def __init__(self, endpoint: Endpoint, listener: PeerListener) -> None:
        self.endpoint = endpoint
        self._listener = listener
        self._server: asyncio.Server | None = None
        self._clients: set[asyncio.Task[None]] = set()
        self._writers: set[asyncio.StreamWriter] = set()

    @property
    def local_port(self) -> int:
        assert self._server is not None
        return int(self._server.sockets[0].getsockname()[1])

    async def start(self) -> None:
        self._server = await asyncio.start_server(
            self._serve, self.endpoint.host, self.endpoint.port, reuse_address=True
        )

    async def _serve(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        task = asyncio.current_task()
        assert task is not None
        self._clients.add(task)
        self._writers.add(writer)
        peer = _TcpPeer(writer)
        self._listener.peer_opened(peer)
        try:
            while data := await reader.read(65536):
                self._listener.peer_received(peer, data)
        except (ConnectionError, asyncio.CancelledError):
            pass
        finally:
            self._listener.peer_closed(peer)
            self._writers.discard(writer)
            writer.close()
            self._clients.discard(task)

    async def close(self) -> None:
        if self._server is not None:
            self._server.close()
        for writer in list(self._writers):
            writer.close()
        for task in list(self._clients):
            task.cancel()
        if self._clients:
            await asyncio.wait(list(self._clients), timeout=2.0)
        if self._server is not None:
            await self._server.wait_closed()
            self._server = None


class _SerialPeer:
    datagrams = False

    def __init__(self, port: SerialPort) -> None:
        self._port = port
        self.name = f"serial:{port.device}"

    def write(self, data: bytes) -> None:
        self._port.write(data)


class _SerialTransport:
    """A serial device (the vehicle's end of a radio), reopened when it comes back."""

    def __init__(self, endpoint: Endpoint, listener: PeerListener) -> None:
        self.endpoint = endpoint
        self._listener = listener
        self._port = SerialPort(
            endpoint.host,
            endpoint.baud,
            flow_control=endpoint.flow_control,
            on_data=self._received,
        )
        self._peer = _SerialPeer(self._port)

    @property
    def local_port(self) -> int:
        return 0

    async def start(self) -> None:
        await self._port.open()
        self._listener.peer_opened(self._peer)

    def _received(self, data: bytes) -> None:
        self._listener.peer_received(self._peer, data)

    async def close(self) -> None:
        await self._port.close()
        self._listener.peer_closed(self._peer)


def make_transport(endpoint: Endpoint, listener: PeerListener) -> Transport:
    if endpoint.kind is LinkKind.TCPIN:
        return _TcpServerTransport(endpoint, listener)
    if endpoint.kind is LinkKind.SERIAL:
        return _SerialTransport(endpoint, listener)
    return _UdpTransport(endpoint, listener)
