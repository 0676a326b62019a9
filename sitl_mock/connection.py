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
  clients at once;
- ``serial:DEVICE:BAUD`` (or ``/dev/ttyX,BAUD``) is a serial device, the
  vehicle's end of a telemetry radio (a serial link cannot be mirrored: its
  far end is another device).

Only loopback addresses are accepted unless explicitly allowed: the mock is
for tests and simulation on one machine.
"""

from __future__ import annotations

import ipaddress
from dataclasses import dataclass
from enum import StrEnum

from vehicles.endpoints import parse_serial
from vehicles.errors import EndpointError


class ConnectionStringError(ValueError):
    """A connection string the mock cannot use."""


class LinkKind(StrEnum):
    UDPOUT = "udpout"
    UDPIN = "udpin"
    TCPIN = "tcpin"
    TCP = "tcp"
    SERIAL = "serial"


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
    """A network address, or for ``SERIAL`` a device (``host``) at ``baud``."""

    kind: LinkKind
    host: str
    port: int = 0
    baud: int = 0
    flow_control: bool = False

    def __str__(self) -> str:
        if self.kind is LinkKind.SERIAL:
            return f"serial:{self.host}:{self.baud}"
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
    """Parse the mock's own connection string (udpout, udpin, tcpin or serial)."""
    serial = _serial(text)
    if serial is not None:
        return serial
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


def _serial(text: str) -> Endpoint | None:
    try:
        device = parse_serial(text)
    except EndpointError as exc:
        raise ConnectionStringError(str(exc)) from None
    if device is None:
        return None
    return Endpoint(
        LinkKind.SERIAL, device.host, baud=device.baud, flow_control=device.flow_control
    )


def mirror(gcs_connection: str) -> str:
    """The mock's side of a connection written from the ground station's side."""
    if _serial(gcs_connection) is not None:
        raise ConnectionStringError(
            f"connection {gcs_connection!r}: a serial link's far end is another device; run "
            "the mock on it (sitl-mock MISSION --one-link serial:DEVICE:BAUD)"
        )
    kind_text, host, port = _split(gcs_connection)
    kind = _MIRROR.get(kind_text)
    if kind is None:
        raise ConnectionStringError(
            f"connection {gcs_connection!r}: cannot serve a ground station that uses {kind_text!r}"
        )
    if host in ("", "0.0.0.0", "::"):
        host = "127.0.0.1"
    return f"{kind.value}:{host}:{port}"
