"""The station's MAVLink network: its connections, and one table of which vehicle is where.

On the field one connection often carries several vehicles: a telemetry radio
for the whole fleet, MAVProxy or mavlink-router on a companion computer, one
UDP port every vehicle sends to. A ``MavlinkNetwork`` opens each connection once,
however many vehicles name it, and sends the station's heartbeat on it once.
Each vehicle's ``VehicleLink`` reads and writes through a ``SystemPort``: it
receives the messages of its own system id only (from whichever connection
they came), and what it sends goes to the connection the vehicle was last heard
on (the one its mission names until then), where the transport picks the
vehicle's own address by ``target_system``.

A system the network has no link for (a vehicle the mission does not name,
another ground station) is reported once per connection through
``on_notice``, and its frames are counted, not raised; so is a serial device
that vanishes (a radio unplugged) and comes back.

``forward`` shares the traffic with another ground station, as MAVProxy's
``--out`` does: every frame heard from a vehicle is copied to it unchanged
(signed frames stay signed), and what it sends is passed on to the vehicles
only if ``commands`` allows it.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections.abc import AsyncIterator, Callable
from dataclasses import dataclass, field
from typing import TypeAlias

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from vehicles.endpoints import Endpoint, parse_endpoint
from vehicles.errors import LinkError, TransportClosed
from vehicles.link import LinkSettings, RejectedFrames, VehicleLink, send_heartbeats
from vehicles.signing import SigningConfig
from vehicles.transport import (
    DEFAULT_QUEUE_SIZE,
    MavlinkTransport,
    Tap,
    TransportStats,
    next_message,
)

log = logging.getLogger(__name__)

Message: TypeAlias = mavlink.MAVLink_message


@dataclass(frozen=True)
class Stranger:
    """A system heard on a connection that no link of the network is for."""

    system: int
    endpoint: Endpoint
    #: What its heartbeat says it is, when the first frame was one (``MAV_TYPE_...``).
    kind: str | None = None

    def __str__(self) -> str:
        what = f" ({self.kind})" if self.kind else ""
        return (
            f"system {self.system}{what} heard on {self.endpoint}: not in the mission, "
            "its frames are ignored"
        )


@dataclass
class Connection:
    """One open connection and what was heard on it."""

    endpoint: Endpoint
    transport: MavlinkTransport
    signing: SigningConfig | None
    #: The systems of the network's links heard on this connection.
    systems: set[int] = field(default_factory=set)
    #: Frames of systems no link is for.
    stranger_frames: int = 0
    strangers: set[int] = field(default_factory=set)
    tasks: list[asyncio.Task[None]] = field(default_factory=list)

    @property
    def rejected(self) -> RejectedFrames:
        return RejectedFrames.of(self.transport.stats, foreign_frames=self.stranger_frames)


class SystemPort:
    """One vehicle's share of the network (a ``vehicles.transport.MessagePort``)."""

    def __init__(self, network: MavlinkNetwork, system: int, home: Connection) -> None:
        self.network = network
        self.system = system
        self.home = home
        self._queue: asyncio.Queue[Message] = asyncio.Queue(DEFAULT_QUEUE_SIZE)
        self._closed = asyncio.Event()
        self._taps: list[Tap] = []

    @property
    def endpoint(self) -> Endpoint:
        return self.home.endpoint

    @property
    def stats(self) -> TransportStats:
        """The counters of the connection the vehicle is on (shared with its others)."""
        return self.network.where(self.system).transport.stats

    @property
    def peer(self) -> tuple[str, int] | None:
        return self.network.where(self.system).transport.peers.get(self.system)

    @property
    def closed(self) -> bool:
        return self._closed.is_set()

    def send(self, msg: Message) -> bool:
        if self.closed:
            raise TransportClosed(f"the link to system {self.system} is closed")
        connection = self.network.where(self.system)
        sent = connection.transport.send(msg)
        if sent:
            self._run_taps("out", bytes(msg.get_msgbuf()), msg)
        return sent

    def add_tap(self, tap: Tap) -> None:
        """``tap`` sees this vehicle's frames in, and what the station sends it."""
        self._taps.append(tap)

    def deliver(self, msg: Message) -> None:
        if self.closed:
            return
        if self._queue.full():  # a reader that fell behind: fresh telemetry beats complete
            self._queue.get_nowait()
        self._queue.put_nowait(msg)
        self._run_taps("in", bytes(msg.get_msgbuf()), msg)

    def heartbeat_sent(self, frame: bytes, msg: Message) -> None:
        self._run_taps("out", frame, msg)

    async def recv(self) -> Message:
        why = f"the link to system {self.system} is closed"
        return await next_message(self._queue, self._closed, why)

    async def __aiter__(self) -> AsyncIterator[Message]:
        while True:
            try:
                yield await self.recv()
            except TransportClosed:
                return

    async def close(self) -> None:
        """Stop reading; the vehicle's frames are dropped from now on (it is still known:
        not reported as a stranger)."""
        self._closed.set()

    def _run_taps(self, direction: str, frame: bytes, msg: Message) -> None:
        for tap in self._taps:
            try:
                tap(direction, frame, msg)
            except Exception:
                log.exception("tap of system %d failed", self.system)


@dataclass
class _Forward:
    endpoint: Endpoint
    transport: MavlinkTransport
    commands: bool
    #: Frames from the other station not passed on (``commands`` false).
    refused: int = 0
    task: asyncio.Task[None] | None = None


class MavlinkNetwork:
    """The station's connections and vehicles; ``close`` closes all of them."""

    def __init__(
        self,
        settings: LinkSettings | None = None,
        *,
        allow_remote: bool = False,
        on_notice: Callable[[str], None] | None = None,
    ) -> None:
        self.settings = settings or LinkSettings()
        self.allow_remote = allow_remote
        self.on_notice = on_notice
        self.connections: dict[str, Connection] = {}
        self._ports: dict[int, SystemPort] = {}
        self._where: dict[int, Connection] = {}
        self._forwards: list[_Forward] = []

    # -- connections --------------------------------------------------------------------

    async def open(self, connection: str | Endpoint, signing: SigningConfig | None) -> Connection:
        """The connection to ``connection``, opened on first use; ``LinkError`` if it
        cannot be opened, or if it is open already with another signing key (one link
        carries one key)."""
        endpoint = (
            connection
            if isinstance(connection, Endpoint)
            else parse_endpoint(connection, allow_remote=self.allow_remote)
        )
        key = str(endpoint)
        known = self.connections.get(key)
        if known is not None:
            if _key_of(known.signing) != _key_of(signing):
                raise LinkError(
                    f"{endpoint} is shared by vehicles with different signing keys: "
                    "one connection carries one key"
                )
            return known
        s = self.settings
        transport = await MavlinkTransport.open(
            endpoint,
            source_system=s.own_system,
            source_component=s.own_component,
            signing=signing,
        )
        transport.wanted = self._has_link
        transport.follow_moves = s.follow_address
        transport.on_device = lambda present: self._notice(
            f"{endpoint}: {'device back' if present else 'device gone (unplugged?): reopening'}"
        )
        opened = Connection(endpoint, transport, signing)
        self.connections[key] = opened
        loop = asyncio.get_running_loop()
        opened.tasks.append(loop.create_task(self._read(opened), name=f"mavlink-read-{key}"))
        opened.tasks.append(
            loop.create_task(self._heartbeats(opened), name=f"mavlink-heartbeat-{key}")
        )
        return opened

    async def link(
        self,
        connection: str | Endpoint,
        system: int,
        *,
        signing: SigningConfig | None = None,
        on_wait: Callable[[str], None] | None = None,
    ) -> VehicleLink:
        """A started link to vehicle ``system`` on ``connection`` (opened if need be)."""
        known = self._ports.get(system)
        if known is not None and not known.closed:
            raise LinkError(f"system {system} has a link already")
        home = await self.open(connection, signing)
        port = SystemPort(self, system, home)
        self._ports[system] = port
        link = VehicleLink(port, target_system=system, settings=self.settings, on_wait=on_wait)
        link.start()
        return link

    def where(self, system: int) -> Connection:
        """The connection ``system`` was last heard on (its own until it is heard)."""
        known = self._where.get(system)
        if known is not None:
            return known
        port = self._ports.get(system)
        if port is None:
            raise LinkError(f"no link to system {system}")
        return port.home

    @property
    def rejected(self) -> RejectedFrames:
        """What every connection threw away (the links count their own on top)."""
        total = RejectedFrames()
        for connection in self.connections.values():
            total += connection.rejected
        return total

    @property
    def forward_refused(self) -> int:
        """Frames another ground station sent that were not passed on."""
        return sum(f.refused for f in self._forwards)

    async def close(self) -> None:
        for port in list(self._ports.values()):
            await port.close()
        for forward in self._forwards:
            if forward.task is not None:
                forward.task.cancel()
                with contextlib.suppress(asyncio.CancelledError):
                    await forward.task
            await forward.transport.close()
        self._forwards.clear()
        for connection in self.connections.values():
            for task in connection.tasks:
                task.cancel()
            for task in connection.tasks:
                with contextlib.suppress(asyncio.CancelledError, Exception):
                    await task
            await connection.transport.close()
        self.connections.clear()

    async def __aenter__(self) -> MavlinkNetwork:
        return self

    async def __aexit__(self, *exc: object) -> None:
        await self.close()

    # -- sharing with another ground station ------------------------------------------

    async def forward(self, endpoint: str | Endpoint, *, commands: bool = False) -> None:
        """Copy every vehicle frame to ``endpoint`` (another ground station); pass what
        it sends on to the vehicles only with ``commands``."""
        parsed = (
            endpoint
            if isinstance(endpoint, Endpoint)
            else parse_endpoint(endpoint, allow_remote=self.allow_remote)
        )
        transport = await MavlinkTransport.open(parsed)
        forward = _Forward(parsed, transport, commands)
        forward.task = asyncio.get_running_loop().create_task(
            self._from_forward(forward), name=f"mavlink-forward-{parsed}"
        )
        self._forwards.append(forward)

    async def _from_forward(self, forward: _Forward) -> None:
        async for msg in forward.transport:
            if not forward.commands:
                forward.refused += 1
                if forward.refused == 1:
                    log.warning(
                        "%s sends %s: not passed on to the vehicles (--forward-commands)",
                        forward.endpoint,
                        msg.get_type(),
                    )
                continue
            frame = bytes(msg.get_msgbuf())
            target = getattr(msg, "target_system", 0)
            known = self._where.get(target)
            targets = [known] if known is not None else list(self.connections.values())
            for connection in targets:
                connection.transport.send_raw(frame, target)

    # -- reading ------------------------------------------------------------------------

    def _has_link(self, system: int) -> bool:
        port = self._ports.get(system)
        return port is not None and not port.closed

    async def _read(self, connection: Connection) -> None:
        async for msg in connection.transport:
            try:
                self._dispatch(connection, msg)
            except Exception:  # one odd message must not end the reader
                log.exception("%s: cannot dispatch %s", connection.endpoint, msg.get_type())

    def _dispatch(self, connection: Connection, msg: Message) -> None:
        system = msg.get_srcSystem()
        if self._forwards:
            frame = bytes(msg.get_msgbuf())
            for forward in self._forwards:
                forward.transport.send_raw(frame)
        port = self._ports.get(system)
        if port is None:
            self._stranger(connection, msg)
            return
        self._where[system] = connection
        if system not in connection.systems:
            connection.systems.add(system)
            if connection is not port.home:
                self._notice(
                    f"system {system} heard on {connection.endpoint} too: what the station "
                    "sends it goes where it was heard last"
                )
        if getattr(msg, "target_system", 0) in (0, self.settings.own_system):
            port.deliver(msg)  # not what a vehicle says to another station (a --forward one)

    def _stranger(self, connection: Connection, msg: Message) -> None:
        connection.stranger_frames += 1
        system = msg.get_srcSystem()
        if system in connection.strangers:
            return
        connection.strangers.add(system)
        kind = None
        if msg.get_type() == "HEARTBEAT":
            kind = mavlink.enums["MAV_TYPE"].get(msg.type)
            kind = kind.name if kind is not None else None
        self._notice(str(Stranger(system, connection.endpoint, kind)))

    def _notice(self, text: str) -> None:
        log.info("%s", text)
        if self.on_notice is not None:
            self.on_notice(text)

    async def _heartbeats(self, connection: Connection) -> None:
        """The station's heartbeat, once per connection however many vehicles it carries."""
        tap = self._tell_ports_heartbeat(connection)
        connection.transport.add_tap(tap)
        await send_heartbeats(connection.transport, self.settings.heartbeat_period_s)

    def _tell_ports_heartbeat(self, connection: Connection) -> Tap:
        def tap(direction: str, frame: bytes, msg: Message) -> None:
            if direction == "out" and msg.get_type() == "HEARTBEAT":
                for port in list(self._ports.values()):
                    if self.where(port.system) is connection:
                        port.heartbeat_sent(frame, msg)

        return tap


def _key_of(signing: SigningConfig | None) -> bytes | None:
    return None if signing is None else signing.key
