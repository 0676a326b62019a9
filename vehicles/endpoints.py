"""Connection strings in pymavlink's syntax, from the ground station's point of view.

``udpin:HOST:PORT``   listen on HOST:PORT; reply to whoever spoke last.
``udpout:HOST:PORT``  send to HOST:PORT (the vehicle listens there).
``tcp:HOST:PORT``     connect to a vehicle serving TCP (ArduPilot SITL on 5760).
``tcpin:HOST:PORT``   accept one TCP client at a time on HOST:PORT.
``serial:DEVICE:BAUD`` a serial device (a telemetry radio), e.g. ``serial:/dev/ttyUSB0:57600``;
                      also MAVSDK's ``serial:///dev/ttyUSB0:57600`` (``serial_flowcontrol:``
                      for RTS/CTS flow control) and MAVProxy's ``/dev/ttyUSB0,57600``.

The ``udpin://`` URL form that MAVSDK uses is accepted too. Only loopback
addresses are allowed unless the caller explicitly allows others, so a test or
a simulation never talks to a real vehicle by accident; a serial device is on
this machine and always allowed.
"""

from __future__ import annotations

import ipaddress
import random
import socket
from dataclasses import dataclass
from enum import StrEnum

from vehicles.errors import EndpointError


class EndpointKind(StrEnum):
    UDP_IN = "udpin"
    UDP_OUT = "udpout"
    TCP = "tcp"
    TCP_IN = "tcpin"
    SERIAL = "serial"


_LOOPBACK_NAMES = {"localhost"}
#: The usual rate of SiK and RFD telemetry radios (and pymavlink's default).
DEFAULT_BAUD = 57600
_SERIAL_KINDS = {"serial": False, "serial_flowcontrol": True}


@dataclass(frozen=True)
class Endpoint:
    """A network address, or for ``SERIAL`` a device (``host``) at ``baud``."""

    kind: EndpointKind
    host: str
    port: int = 0
    baud: int = 0
    #: ``SERIAL``: RTS/CTS hardware flow control.
    flow_control: bool = False

    def __str__(self) -> str:
        if self.kind is EndpointKind.SERIAL:
            kind = "serial_flowcontrol" if self.flow_control else "serial"
            return f"{kind}:{self.host}:{self.baud}"
        return f"{self.kind.value}:{self.host}:{self.port}"

    @property
    def device(self) -> str:
        return self.host

    @property
    def is_loopback(self) -> bool:
        if self.kind is EndpointKind.SERIAL:
            return True  # a device of this machine, never a network
        if self.host in _LOOPBACK_NAMES:
            return True
        try:
            return ipaddress.ip_address(self.host).is_loopback
        except ValueError:
            return False


def parse_endpoint(text: str, *, allow_remote: bool = False) -> Endpoint:
    """Parse ``kind:host:port`` (or ``kind://host:port``) into an ``Endpoint``.

    Raises ``EndpointError`` with the reason on bad syntax, an unknown kind, a
    port out of range, or a non-loopback host when ``allow_remote`` is false.
    """
    serial = parse_serial(text)
    if serial is not None:
        return serial
    kind_text, sep, rest = text.strip().partition(":")
    if not sep:
        raise EndpointError(text, "expected KIND:HOST:PORT, e.g. udpin:127.0.0.1:14550")
    rest = rest.removeprefix("//")
    try:
        kind = EndpointKind(kind_text.lower())
    except ValueError:
        kinds = ", ".join(k.value for k in EndpointKind if k is not EndpointKind.SERIAL)
        raise EndpointError(
            text, f"unknown kind {kind_text!r} (use one of {kinds}, or serial:DEVICE:BAUD)"
        ) from None
    host, sep, port_text = rest.rpartition(":")
    if not sep:
        raise EndpointError(text, "missing port")
    if not host:
        host = "0.0.0.0" if kind in (EndpointKind.UDP_IN, EndpointKind.TCP_IN) else "127.0.0.1"
    host = host.strip("[]")
    try:
        port = int(port_text)
    except ValueError:
        raise EndpointError(text, f"port {port_text!r} is not a number") from None
    listening = kind in (EndpointKind.UDP_IN, EndpointKind.TCP_IN)
    if not (0 if listening else 1) <= port < 65536:  # port 0: any free port, to listen on
        raise EndpointError(text, f"port {port} out of range 1..65535")
    endpoint = Endpoint(kind, host, port)
    if not allow_remote and not endpoint.is_loopback:
        raise EndpointError(text, f"host {host} is not loopback (--allow-remote allows it)")
    return endpoint


def parse_serial(text: str) -> Endpoint | None:
    """A serial device in any of the spellings of the module doc, else None.

    ``serial:/dev/ttyUSB0:57600``, ``serial:///dev/ttyUSB0:57600``,
    ``serial_flowcontrol:///dev/ttyUSB0:57600``, ``/dev/ttyUSB0,57600``,
    ``/dev/ttyUSB0`` (at ``DEFAULT_BAUD``), any absolute path (a link to a device);
    ``COM3,57600`` on Windows."""
    raw = text.strip()
    kind_text, sep, rest = raw.partition(":")
    flow_control = _SERIAL_KINDS.get(kind_text.lower())
    if sep and flow_control is not None:
        rest = rest.removeprefix("//")
        device, sep, baud_text = rest.rpartition(":")
        if not sep:
            device, baud_text = rest, ""
    elif raw.startswith("/") or raw.upper().startswith("COM"):  # a device's path
        flow_control = False
        device, _, baud_text = raw.partition(",")
    else:
        return None
    if not device:
        raise EndpointError(text, "no serial device, e.g. serial:/dev/ttyUSB0:57600")
    try:
        baud = int(baud_text) if baud_text else DEFAULT_BAUD
    except ValueError:
        raise EndpointError(text, f"baud rate {baud_text!r} is not a number") from None
    if baud <= 0:
        raise EndpointError(text, f"baud rate {baud} must be positive")
    return Endpoint(EndpointKind.SERIAL, device, baud=baud, flow_control=flow_control)


#: Ports handed out for mock fleets come from here: below the kernel's ephemeral
#: range (32768-60999 on Linux, 49152-65535 elsewhere), so no socket bound to port 0
#: (a sender, a client) can take one between the pick and its use, and above the
#: usual ports of ground stations and simulators (5760, 14550).
_PICK_PORTS = range(20000, 32768)
_pick = random.Random()


def free_loopback_udp_ports(count: int) -> list[int]:
    """``count`` distinct loopback UDP ports that nobody uses right now (for mock fleets)."""
    return _free_loopback_ports(count, socket.SOCK_DGRAM)


def free_loopback_tcp_ports(count: int) -> list[int]:
    """``count`` distinct loopback TCP ports that nobody uses right now."""
    return _free_loopback_ports(count, socket.SOCK_STREAM)


def _free_loopback_ports(count: int, kind: socket.SocketKind) -> list[int]:
    """Each port is bound to prove it free, all held until the last is found; the
    search starts at a random port so that two processes picking at once (two test
    workers, two ``gcs run --sim``) rarely try the same ones."""
    sockets: list[socket.socket] = []
    start = _pick.randrange(len(_PICK_PORTS))
    try:
        for i in range(len(_PICK_PORTS)):
            if len(sockets) == count:
                break
            port = _PICK_PORTS[(start + i) % len(_PICK_PORTS)]
            s = socket.socket(socket.AF_INET, kind)
            try:
                s.bind(("127.0.0.1", port))
            except OSError:
                s.close()
                continue
            sockets.append(s)
        while len(sockets) < count:  # the whole window taken: any free port will do
            s = socket.socket(socket.AF_INET, kind)
            s.bind(("127.0.0.1", 0))
            sockets.append(s)
        return [s.getsockname()[1] for s in sockets]
    finally:
        for s in sockets:
            s.close()
