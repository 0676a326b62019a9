"""An asyncio MAVLink 2 transport over UDP, TCP or serial, with pymavlink as codec only.

One connection = one parser and one bounded queue of decoded messages. A
datagram protocol (UDP), one reader task per TCP connection, or a serial port
(``vehicles.serial_port``, reopened when the device comes back) parses incoming
bytes and puts messages into the queue; when the queue is full the oldest
message is dropped (telemetry is periodic, so fresh beats complete). Garbage,
CRC errors and bad signatures are counted, never raised.

A ``udpin`` transport may hear several vehicles, each from its own address (one
port for the fleet, as behind a router) or all from one (a radio): it keeps a
table of system id -> address and sends each message to the address of its
``target_system`` (broadcasts, and targets not heard yet, to every address).
"""

from __future__ import annotations

import asyncio
import contextlib
import errno
import logging
from collections.abc import AsyncIterator, Callable
from dataclasses import dataclass
from typing import Any, Protocol

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from vehicles.endpoints import Endpoint, EndpointKind, parse_endpoint
from vehicles.errors import LinkError, TransportClosed
from vehicles.serial_port import SerialPort
from vehicles.signing import SigningConfig, apply_signing

log = logging.getLogger(__name__)

GCS_SYSTEM_ID = 255
GCS_COMPONENT_ID = mavlink.MAV_COMP_ID_MISSIONPLANNER  # 190
DEFAULT_QUEUE_SIZE = 1000
TCP_RECONNECT_S = 0.5

#: A tap sees every frame: ("in" | "out", raw bytes, decoded message).
Tap = Callable[[str, bytes, mavlink.MAVLink_message], None]

Address = tuple[str, int]


class MessagePort(Protocol):
    """What a vehicle's link reads and writes: a transport of its own, or its share
    of a connection that carries several vehicles (``vehicles.network.SystemPort``)."""

    @property
    def endpoint(self) -> Endpoint: ...

    @property
    def stats(self) -> TransportStats: ...

    @property
    def closed(self) -> bool: ...

    def send(self, msg: mavlink.MAVLink_message) -> bool: ...

    async def recv(self) -> mavlink.MAVLink_message: ...

    def __aiter__(self) -> AsyncIterator[mavlink.MAVLink_message]: ...

    def add_tap(self, tap: Tap) -> None: ...

    async def close(self) -> None: ...


@dataclass
class TransportStats:
    """Counters of one transport; read them for diagnostics, they never raise."""

    frames_in: int = 0
    frames_out: int = 0
    bytes_in: int = 0
    bytes_out: int = 0
    bad_frames: int = 0
    bad_signatures: int = 0
    unknown_messages: int = 0
    dropped_in: int = 0
    unsent: int = 0
    #: TCP reconnections, and serial devices opened again after they vanished.
    reconnects: int = 0
    #: ``udpin``: datagrams speaking for our vehicle from an address other than the one it
    #: first spoke from (an impostor, unless the operator lets the address move).
    other_address: int = 0


class MavlinkTransport:
    """Send and receive MAVLink messages on one endpoint.

    Use ``await MavlinkTransport.open("udpin:127.0.0.1:14550")`` or ``async with``.
    ``recv()`` (or ``async for``) gives decoded messages from any system on the
    endpoint; ``send(msg)`` packs with our system/component id (and signature).
    A ``udpin`` transport is silent (``send`` counts ``unsent``) until it has
    heard someone. The first good message of a system that ``wanted`` accepts fixes
    that system's address (garbage never sets one); a datagram from another address
    speaking for it later is dropped whole and counted (``stats.other_address``),
    unless ``follow_moves`` (a vehicle whose address may change). Without signing,
    any host that can reach the port can still speak first; signing is the real
    protection.
    """

    def __init__(
        self,
        endpoint: Endpoint,
        *,
        source_system: int = GCS_SYSTEM_ID,
        source_component: int = GCS_COMPONENT_ID,
        signing: SigningConfig | None = None,
        queue_size: int = DEFAULT_QUEUE_SIZE,
    ) -> None:
        self.endpoint = endpoint
        self.codec = mavlink.MAVLink(None, source_system, source_component)
        self.codec.robust_parsing = True
        apply_signing(self.codec, signing)
        self.stats = TransportStats()
        self._queue: asyncio.Queue[mavlink.MAVLink_message] = asyncio.Queue(queue_size)
        self._taps: list[Tap] = []
        self._closed = asyncio.Event()
        self._datagram: asyncio.DatagramTransport | None = None
        self._writer: asyncio.StreamWriter | None = None
        self._server: asyncio.Server | None = None
        self._serial: SerialPort | None = None
        self._tasks: set[asyncio.Task[None]] = set()
        #: Where the last message came from (``udpin``), or where we send (``udpout``).
        self.peer: Address | None = None
        #: ``udpin``: the address of each system heard, by system id.
        self.peers: dict[int, Address] = {}
        #: ``udpin``: the systems whose address we keep (the vehicles we talk to), so
        #: that garbage or a stranger's frames cannot divert what we send.
        self.wanted: Callable[[int], bool] = _any_system
        self.follow_moves = False
        #: Serial: told False when the device vanishes, True when it is back.
        self.on_device: Callable[[bool], None] | None = None

    # -- life cycle -----------------------------------------------------------------

    @classmethod
    async def open(
        cls, endpoint: str | Endpoint, *, allow_remote: bool = False, **kwargs: Any
    ) -> MavlinkTransport:
        if isinstance(endpoint, str):
            endpoint = parse_endpoint(endpoint, allow_remote=allow_remote)
        transport = cls(endpoint, **kwargs)
        try:
            await transport._start()
        except OSError as exc:
            await transport.close()
            raise LinkError(f"cannot open {endpoint}: {_open_failure(endpoint, exc)}") from exc
        return transport

    async def _start(self) -> None:
        loop = asyncio.get_running_loop()
        ep = self.endpoint
        if ep.kind is EndpointKind.UDP_IN:
            self._datagram, _ = await loop.create_datagram_endpoint(
                lambda: _DatagramProtocol(self), local_addr=(ep.host, ep.port)
            )
        elif ep.kind is EndpointKind.UDP_OUT:
            local = "127.0.0.1" if ep.is_loopback else "0.0.0.0"
            self._datagram, _ = await loop.create_datagram_endpoint(
                lambda: _DatagramProtocol(self), local_addr=(local, 0)
            )
            self.peer = (ep.host, ep.port)
        elif ep.kind is EndpointKind.TCP:
            reader, writer = await asyncio.open_connection(ep.host, ep.port)
            self._attach_stream(reader, writer, reconnect=True)
        elif ep.kind is EndpointKind.TCP_IN:
            self._server = await asyncio.start_server(
                lambda r, w: self._attach_stream(r, w, reconnect=False), ep.host, ep.port
            )
        elif ep.kind is EndpointKind.SERIAL:
            self._serial = SerialPort(
                ep.device,
                ep.baud,
                flow_control=ep.flow_control,
                on_data=self._feed_serial,
                on_state=self._device_state,
            )
            await self._serial.open()

    async def close(self) -> None:
        if self._closed.is_set():
            return
        self._closed.set()
        if self._datagram is not None:
            self._datagram.close()
        if self._writer is not None:
            self._writer.close()
        if self._server is not None:
            self._server.close()
        if self._serial is not None:
            await self._serial.close()
        for task in list(self._tasks):
            task.cancel()
        for task in list(self._tasks):
            with contextlib.suppress(asyncio.CancelledError, Exception):
                await task
        if self._server is not None:
            with contextlib.suppress(Exception):
                await self._server.wait_closed()

    @property
    def closed(self) -> bool:
        return self._closed.is_set()

    @property
    def local_address(self) -> Address | None:
        """The bound address (useful with port 0)."""
        if self._datagram is not None:
            return self._datagram.get_extra_info("sockname")[:2]
        if self._server is not None and self._server.sockets:
            return self._server.sockets[0].getsockname()[:2]
        return None

    async def __aenter__(self) -> MavlinkTransport:
        return self

    async def __aexit__(self, *exc: object) -> None:
        await self.close()

    # -- sending ----------------------------------------------------------------------

    def add_tap(self, tap: Tap) -> None:
        """Call ``tap`` for every frame in and out (raw traffic logging)."""
        self._taps.append(tap)

    def send(self, msg: mavlink.MAVLink_message) -> bool:
        """Pack and send ``msg``; false when there is nobody to send to yet."""
        if self.closed:
            raise TransportClosed(f"{self.endpoint} is closed")
        buf = bytes(msg.pack(self.codec))
        self.codec.seq = (self.codec.seq + 1) % 256
        sent = self._write(buf, getattr(msg, "target_system", 0))
        if not sent:
            self.stats.unsent += 1
            return False
        self.stats.frames_out += 1
        self.stats.bytes_out += len(buf)
        self._run_taps("out", buf, msg)
        return True

    def send_raw(self, frame: bytes, target_system: int = 0) -> bool:
        """Send a frame as it is (another station's, passed on with its own sequence
        number and signature); False when there is nobody to send to."""
        if self.closed:
            return False
        sent = self._write(frame, target_system)
        if sent:
            self.stats.bytes_out += len(frame)
        return sent

    def _write(self, buf: bytes, target_system: int) -> bool:
        if self._datagram is not None:
            if self._datagram.is_closing():
                return False
            for address in self._addresses(target_system):
                self._datagram.sendto(buf, address)
            return self.peer is not None
        if self._writer is not None and not self._writer.is_closing():
            self._writer.write(buf)
            return True
        if self._serial is not None:
            return self._serial.write(buf)
        return False

    def _addresses(self, target_system: int) -> list[Address]:
        """Where a message for ``target_system`` goes: its own address when known, else
        every address heard (a broadcast, or a vehicle not heard yet)."""
        if self.endpoint.kind is not EndpointKind.UDP_IN:
            return [] if self.peer is None else [self.peer]
        address = self.peers.get(target_system)
        if address is not None:
            return [address]
        return list(dict.fromkeys(self.peers.values()))

    # -- receiving ------------------------------------------------------------------

    async def recv(self) -> mavlink.MAVLink_message:
        """The next message; raises ``TransportClosed`` once closed."""
        return await next_message(self._queue, self._closed, f"{self.endpoint} is closed")

    async def __aiter__(self) -> AsyncIterator[mavlink.MAVLink_message]:
        while True:
            try:
                yield await self.recv()
            except TransportClosed:
                return

    def _feed_serial(self, data: bytes) -> None:
        """Bytes from a serial device (``SerialPort.on_data``)."""
        self._feed(data)

    def _feed(
        self, data: bytes, *, whole_frames: bool = False, source: Address | None = None
    ) -> list[mavlink.MAVLink_message]:
        """Parse ``data``, queue every good message (called by the readers) and
        return them.

        ``whole_frames``: ``data`` is a datagram (from ``source``), which holds whole
        frames only, so a truncated frame left at its end is garbage, not the start of
        the next."""
        self.stats.bytes_in += len(data)
        try:
            msgs = self.codec.parse_buffer(data) or []
        except Exception as exc:  # pymavlink raises a few things; never let them out
            log.debug("%s: unparsable data: %s", self.endpoint, exc)
            self.stats.bad_frames += 1
            reset_parser(self.codec)
            return []
        if (whole_frames or source is not None) and self.codec.buf_len() > 0:
            self.stats.bad_frames += 1
            reset_parser(self.codec)
        udp_in = source is not None and self.endpoint.kind is EndpointKind.UDP_IN
        if udp_in and not self._take_peer(source, msgs):  # type: ignore[arg-type]
            return []
        return [msg for msg in msgs if self._accept(msg)]

    def _take_peer(self, source: Address, msgs: list[mavlink.MAVLink_message]) -> bool:
        """``udpin``: note where each wanted system speaks from; False drops a datagram
        that speaks for a system from another address than the one it first used."""
        systems = {m.get_srcSystem() for m in msgs if _is_message(m)}
        ours = [s for s in systems if self.wanted(s)]
        if not ours:
            return True
        address = (source[0], source[1])
        for system in ours:
            known = self.peers.get(system)
            if known is not None and known != address and not self.follow_moves:
                self.stats.other_address += 1
                if self.stats.other_address == 1:
                    log.warning(
                        "%s: %s speaks for system %d heard from %s: ignored",
                        self.endpoint,
                        address,
                        system,
                        known,
                    )
                return False
        for system in ours:
            self.peers[system] = address
        self.peer = address
        return True

    def _device_state(self, present: bool) -> None:
        if present:
            self.stats.reconnects += 1  # a serial device opened again after it vanished
            reset_parser(self.codec)
        if self.on_device is not None:
            self.on_device(present)

    def _accept(self, msg: mavlink.MAVLink_message) -> bool:
        """Count ``msg``; queue it and say true if it is a good message."""
        if isinstance(msg, mavlink.MAVLink_bad_data):
            if "signature" in str(msg.reason).lower():
                self.stats.bad_signatures += 1
            else:
                self.stats.bad_frames += 1
            return False
        if isinstance(msg, mavlink.MAVLink_unknown):
            self.stats.unknown_messages += 1
            return False
        self.stats.frames_in += 1
        self._run_taps("in", bytes(msg.get_msgbuf()), msg)
        if self._queue.full():
            self._queue.get_nowait()
            self.stats.dropped_in += 1
        self._queue.put_nowait(msg)
        return True

    def _run_taps(self, direction: str, buf: bytes, msg: mavlink.MAVLink_message) -> None:
        for tap in self._taps:
            try:
                tap(direction, buf, msg)
            except Exception:
                log.exception("transport tap failed")

    # -- TCP ------------------------------------------------------------------------

    def _attach_stream(
        self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter, *, reconnect: bool
    ) -> None:
        if self.closed:
            writer.close()
            return
        if self._writer is not None:  # tcpin: the newest client replaces the old one
            self._writer.close()
        self._writer = writer
        reset_parser(self.codec)
        task = asyncio.get_running_loop().create_task(self._read_stream(reader, reconnect))
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)

    async def _read_stream(self, reader: asyncio.StreamReader, reconnect: bool) -> None:
        try:
            while data := await reader.read(65536):
                self._feed(data)
        except (ConnectionError, OSError) as exc:
            log.info("%s: connection lost: %s", self.endpoint, exc)
        if reconnect and not self.closed:
            await self._reconnect()

    async def _reconnect(self) -> None:
        """Reconnect a TCP client until it succeeds or the transport is closed."""
        while not self.closed:
            try:
                async with asyncio.timeout(TCP_RECONNECT_S):
                    await self._closed.wait()
                return
            except TimeoutError:
                pass
            try:
                reader, writer = await asyncio.open_connection(
                    self.endpoint.host, self.endpoint.port
                )
            except OSError:
                continue
            self.stats.reconnects += 1
            self._attach_stream(reader, writer, reconnect=True)
            return


class _DatagramProtocol(asyncio.DatagramProtocol):
    def __init__(self, owner: MavlinkTransport) -> None:
        self.owner = owner

    def datagram_received(self, data: bytes, addr: Address) -> None:
        self.owner._feed(data, source=addr)

    def error_received(self, exc: Exception) -> None:
        # ICMP port unreachable and the like: the peer is not there (yet).
        log.debug("%s: %s", self.owner.endpoint, exc)


async def next_message(
    queue: asyncio.Queue[mavlink.MAVLink_message], closed: asyncio.Event, why: str
) -> mavlink.MAVLink_message:
    """The next message of ``queue``; ``TransportClosed(why)`` once ``closed`` is set and
    nothing is left."""
    if not queue.empty():
        return queue.get_nowait()
    if closed.is_set():
        raise TransportClosed(why)
    getter = asyncio.ensure_future(queue.get())
    closer = asyncio.ensure_future(closed.wait())
    try:
        await asyncio.wait({getter, closer}, return_when=asyncio.FIRST_COMPLETED)
    finally:
        closer.cancel()
        if not getter.done():
            getter.cancel()
    if getter.done() and not getter.cancelled():
        return getter.result()
    raise TransportClosed(why)


def _any_system(_system: int) -> bool:
    return True


def _is_message(msg: mavlink.MAVLink_message) -> bool:
    """A good message, not garbage or an id the dialect does not know."""
    return not isinstance(msg, mavlink.MAVLink_bad_data | mavlink.MAVLink_unknown)


def reset_parser(codec: mavlink.MAVLink) -> None:
    """Drop whatever partial frame the parser holds (pymavlink has no call for it); the
    mock vehicles' endpoints and radio use it too."""
    codec.buf = bytearray()
    codec.buf_index = 0
    codec.expected_length = mavlink.HEADER_LEN_V1 + 2


def _open_failure(endpoint: Endpoint, exc: OSError) -> str:
    """Why a connection did not open, with what probably holds a port in use."""
    if exc.errno != errno.EADDRINUSE:
        return str(exc)
    protocol = "udp" if endpoint.kind is EndpointKind.UDP_IN else "tcp"
    return (
        f"{protocol.upper()} port {endpoint.port} is already in use, probably by another ground "
        "station (another gcs run, QGroundControl, MAVProxy) or a simulator; "
        f"'ss -{protocol[0]}lpn sport = :{endpoint.port}' names the program"
    )
