"""Connection strings, from both ends of the link.

Mission files write a vehicle's connection from the ground station's point
of view (``udpin:127.0.0.1:14550``: the ground station listens there). The
mock needs the other side (``udpout:127.0.0.1:14550``: it sends there);
``mirror`` turns one into the other. Both pymavlink's ``kind:host:port`` and
MAVSDK's ``kind://host:port`` spellings are read.

The mock's own sides:

- ``udpout:HOST:P`` sends to P and hears whatever comes back;
- ``udpin:HOST:P`` listens on P and answers the last sender (silent until
  someone talks to it);
- ``tcpin:HOST:P`` is a TCP server, like ArduPilot SITL, serving several
  clients at once.

Only loopback addresses are accepted unless explicitly allowed: the mock is
for tests and simulation on one machine.
"""

from __future__ import annotations

import ipaddress
from dataclasses import dataclass
from enum import StrEnum


class ConnectionStringError(ValueError):
    """A connection string the mock cannot use."""


class LinkKind(StrEnum):
    UDPOUT = "udpout"
    UDPIN = "udpin"
    TCPIN = "tcpin"
    TCP = "tcp"


#: Ground station side -> mock side.
_MIRROR = {
    "udpin": LinkKind.UDPOUT,
    "udp": LinkKind.UDPOUT,  # pymavlink's "udp:" listens, like udpin
    "udpout": LinkKind.UDPIN,
    "tcp": LinkKind.TCPIN,
    "tcpout": LinkKind.TCPIN,  # MAVSDK's TCP client
}


@dataclass(frozen=True)
class Endpoint:
    kind: LinkKind
    host: str
    port: int

    def __str__(self) -> str:
        return f"{self.kind.value}:{self.host}:{self.port}"


def _split(text: str) -> tuple[str, str, int]:
    raw = text.strip()
    if "://" in raw:
        kind, rest = raw.split("://", 1)
    elif ":" in raw:
        kind, rest = raw.split(":", 1)
    else:
        raise ConnectionStringError(f"connection {text!r}: expected KIND:HOST:PORT")
    host, sep, port_text = rest.rpartition(":")
    if not sep:
        raise ConnectionStringError(f"connection {text!r}: expected KIND:HOST:PORT")
    try:
        port = int(port_text)
    except ValueError as exc:
        raise ConnectionStringError(
            f"connection {text!r}: port {port_text!r} is not a number"
        ) from exc
    if not 0 < port < 65536:
        raise ConnectionStringError(f"connection {text!r}: port {port} out of range")
    return kind.lower(), host.strip("[]"), port


def is_loopback(host: str) -> bool:
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def parse_mock_side(text: str, allow_non_loopback: bool = False) -> Endpoint:
    """Parse the mock's own connection string (udpout, udpin or tcpin)."""
    kind_text, host, port = _split(text)
    try:
        kind = LinkKind(kind_text)
    except ValueError as exc:
        raise ConnectionStringError(
            f"connection {text!r}: the mock speaks udpout, udpin or tcpin, not {kind_text!r}"
        ) from exc
    if kind is LinkKind.TCP:
        raise ConnectionStringError(
            f"connection {text!r}: the mock serves TCP (tcpin), it does not dial"
        )
    host = host or "127.0.0.1"
    if not allow_non_loopback and not is_loopback(host):
        raise ConnectionStringError(
            f"connection {text!r}: {host} is not a loopback address (not allowed by default)"
        )
    return Endpoint(kind, host, port)


def mirror(gcs_connection: str) -> str:
    """The mock's side of a connection written from the ground station's side."""
    kind_text, host, port = _split(gcs_connection)
    kind = _MIRROR.get(kind_text)
    if kind is None:
        raise ConnectionStringError(
            f"connection {gcs_connection!r}: cannot serve a ground station that uses {kind_text!r}"
        )
    if host in ("", "0.0.0.0", "::"):
        host = "127.0.0.1"
    return f"{kind.value}:{host}:{port}"


def gcs_side(mock_connection: str) -> str:
    """What a ground station should use to reach a mock with this connection (pymavlink form)."""
    endpoint = parse_mock_side(mock_connection, allow_non_loopback=True)
    kind = {
        LinkKind.UDPOUT: "udpin",
        LinkKind.UDPIN: "udpout",
        LinkKind.TCPIN: "tcp",
    }[endpoint.kind]
    return f"{kind}:{endpoint.host}:{endpoint.port}"
