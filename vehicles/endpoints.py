"""Connection strings in pymavlink's syntax, from the ground station's point of view.

``udpin:HOST:PORT``   listen on HOST:PORT; reply to whoever spoke last.
``udpout:HOST:PORT``  send to HOST:PORT (the vehicle listens there).
``tcp:HOST:PORT``     connect to a vehicle serving TCP (ArduPilot SITL on 5760).
``tcpin:HOST:PORT``   accept one TCP client at a time on HOST:PORT.

The ``udpin://`` URL form that MAVSDK uses is accepted too. Only loopback
addresses are allowed unless the caller explicitly allows others, so a test or
a simulation never talks to a real vehicle by accident.
"""

from __future__ import annotations

import ipaddress
import socket
from dataclasses import dataclass
from enum import StrEnum

from vehicles.errors import EndpointError


class EndpointKind(StrEnum):
    UDP_IN = "udpin"
    UDP_OUT = "udpout"
    TCP = "tcp"
    TCP_IN = "tcpin"


_LOOPBACK_NAMES = {"localhost"}


@dataclass(frozen=True)
class Endpoint:
    kind: EndpointKind
    host: str
    port: int

    def __str__(self) -> str:
        return f"{self.kind.value}:{self.host}:{self.port}"

    @property
    def is_loopback(self) -> bool:
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
    kind_text, sep, rest = text.strip().partition(":")
    if not sep:
        raise EndpointError(text, "expected KIND:HOST:PORT, e.g. udpin:127.0.0.1:14550")
    rest = rest.removeprefix("//")
    try:
        kind = EndpointKind(kind_text.lower())
    except ValueError:
        kinds = ", ".join(k.value for k in EndpointKind)
        raise EndpointError(text, f"unknown kind {kind_text!r} (use one of {kinds})") from None
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


def free_loopback_udp_ports(count: int) -> list[int]:
    """``count`` distinct loopback UDP ports that nobody uses right now (for mock fleets)."""
    sockets = []
    try:
        for _ in range(count):
            s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            s.bind(("127.0.0.1", 0))
            sockets.append(s)
        return [s.getsockname()[1] for s in sockets]
    finally:
        for s in sockets:
            s.close()
