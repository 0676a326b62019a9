"""``gcs mission`` options, and the link options ``gcs status`` shares."""

from __future__ import annotations

import argparse
from pathlib import Path

from gcs.options import runs
from vehicles.mission_files import FORMATS

DEFAULT_HEARTBEAT_TIMEOUT_S = 10.0


def add_link_arguments(p: argparse.ArgumentParser, *, sysid: bool) -> None:
    """``--allow-remote`` and ``--keys``."""
    p.add_argument(
        "--allow-remote",
        action="store_true",
        help="allow endpoints that are not on this machine (loopback only by default)",
    )
    which = "the --sysid vehicle's key" if sysid else "its only key"
    p.add_argument(
        "--keys",
        type=Path,
        metavar="FILE",
        help=f"MAVLink 2 signing keys by system id (YAML, see README); {which} signs what "
        "is sent, and unsigned or wrongly signed frames are refused",
    )


def positive_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if value <= 0:
        raise argparse.ArgumentTypeError(f"must be positive, got {value:g}")
    return value


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    formats = ", ".join(FORMATS)
    p = sub.add_parser(
        "mission",
        help="upload, download or clear a vehicle's mission over MAVLink",
        description=(
            "Move a mission between a file and one vehicle with the MAVLink mission protocol. "
            f"The file format follows its extension ({formats}). ENDPOINT is a connection "
            "string: udpin:HOST:PORT (listen), udpout:HOST:PORT, tcp:HOST:PORT (e.g. "
            "ArduPilot SITL on tcp:127.0.0.1:5760), tcpin:HOST:PORT, or a serial radio "
            "(serial:/dev/ttyUSB0:57600, /dev/ttyUSB0,57600); when it carries several "
            "vehicles, --sysid picks one."
        ),
    )
    actions = p.add_subparsers(dest="action", metavar="ACTION", required=True)
    for name, help_text in (
        ("upload", "send FILE to the vehicle (replaces its mission)"),
        ("download", "read the vehicle's mission into FILE"),
        ("clear", "delete the vehicle's mission"),
    ):
        a = actions.add_parser(name, help=help_text, description=help_text)
        a.add_argument("endpoint", metavar="ENDPOINT", help="connection string of the vehicle")
        if name != "clear":
            a.add_argument("file", metavar="FILE", type=Path, help=f"mission file ({formats})")
        a.add_argument(
            "--sysid",
            type=int,
            metavar="N",
            help="MAVLink system id of the vehicle, on a link that carries several (default: "
            "the first one heard)",
        )
        a.add_argument(
            "--timeout",
            type=positive_float,
            default=DEFAULT_HEARTBEAT_TIMEOUT_S,
            metavar="S",
            help=f"seconds to wait for the vehicle's heartbeat (default "
            f"{DEFAULT_HEARTBEAT_TIMEOUT_S:g})",
        )
        add_link_arguments(a, sysid=True)
        runs(a, "gcs.commands.mission:run")
