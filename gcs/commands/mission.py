"""``gcs mission upload|download|clear``: move a mission file to or from one vehicle.

The file format follows the extension: ``.waypoints``/``.txt`` are ``QGC WPL
110``, ``.plan`` is QGroundControl JSON. Files hold the home position as item
0 (ArduPilot's convention); for PX4, which has no home item, it is dropped on
upload and a placeholder is added on download.
"""

from __future__ import annotations

import argparse
import asyncio
import sys
import time
from pathlib import Path

from rich.console import Console

from gcs.errors import EXIT_FAILED, EXIT_OK, UsageError
from vehicles.endpoints import Endpoint, parse_endpoint
from vehicles.errors import EndpointError, LinkError
from vehicles.link import VehicleLink
from vehicles.mission_files import FORMATS, MissionFileError, read_mission, write_mission
from vehicles.mission_items import MissionItem, renumber
from vehicles.signing import SigningConfig

DEFAULT_HEARTBEAT_TIMEOUT_S = 10.0


# -- arguments shared with ``gcs status`` ------------------------------------------------


def add_link_arguments(p: argparse.ArgumentParser) -> None:
    """``--allow-remote`` and the signing options."""
    p.add_argument(
        "--allow-remote",
        action="store_true",
        help="allow endpoints that are not on this machine (loopback only by default)",
    )
    signing = p.add_argument_group("MAVLink 2 signing")
    key = signing.add_mutually_exclusive_group()
    key.add_argument("--signing-key", metavar="HEX", help="32-byte secret key as 64 hex digits")
    key.add_argument(
        "--signing-passphrase",
        metavar="TEXT",
        help="derive the key from a passphrase (SHA-256, as MAVProxy's 'signing setup')",
    )
    signing.add_argument(
        "--require-signed",
        action="store_true",
        help="drop unsigned messages from the vehicle (needs a key)",
    )


def signing_from_args(args: argparse.Namespace) -> SigningConfig | None:
    try:
        if args.signing_key:
            return SigningConfig.from_hex(args.signing_key, require_signed=args.require_signed)
        if args.signing_passphrase:
            return SigningConfig.from_passphrase(
                args.signing_passphrase, require_signed=args.require_signed
            )
    except ValueError as exc:
        raise UsageError(f"bad signing key: {exc}") from None
    if args.require_signed:
        raise UsageError("--require-signed needs --signing-key or --signing-passphrase")
    return None


def endpoint_from_args(text: str, args: argparse.Namespace) -> Endpoint:
    try:
        return parse_endpoint(text, allow_remote=args.allow_remote)
    except EndpointError as exc:
        raise UsageError(str(exc)) from None


def positive_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if value <= 0:
        raise argparse.ArgumentTypeError(f"must be positive, got {value:g}")
    return value


# -- the subcommand ----------------------------------------------------------------------


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
        add_link_arguments(a)
        a.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    endpoint = endpoint_from_args(args.endpoint, args)
    signing = signing_from_args(args)
    items: list[MissionItem] = []
    if args.action == "upload":
        try:
            items = read_mission(args.file)
        except MissionFileError as exc:
            raise UsageError(str(exc)) from None
    elif args.action == "download" and args.file.suffix.lower() not in FORMATS:
        raise UsageError(f"{args.file}: unknown mission file extension (use {', '.join(FORMATS)})")
    console = Console(stderr=True)
    try:
        return asyncio.run(_run(args, endpoint, signing, items, console))
    except LinkError as exc:
        print(f"gcs mission {args.action}: {exc}", file=sys.stderr)
        return EXIT_FAILED


async def _run(
    args: argparse.Namespace,
    endpoint: Endpoint,
    signing: SigningConfig | None,
    items: list[MissionItem],
    console: Console,
) -> int:
    def tell(text: str) -> None:
        console.print(f"waiting: {text}", markup=False, highlight=False, soft_wrap=True)

    link = await VehicleLink.connect(
        endpoint, target_system=args.sysid, allow_remote=True, signing=signing, on_wait=tell
    )
    async with link:
        status = await link.wait_heartbeat(timeout_s=args.timeout)
        flavour = link.profile.flavour if link.profile is not None else None
        has_home = flavour is None or flavour.mission_has_home
        start = time.monotonic()
        if args.action == "upload":
            to_send = items if has_home else renumber(items[1:])
            await link.upload_mission(to_send)
            _say(f"uploaded {len(to_send)} items to system {status.system_id}", start)
        elif args.action == "download":
            got = await link.download_mission()
            if not has_home:
                got = [_home_placeholder(link), *renumber(got, start=1)]
            write_mission(args.file, got)
            _say(
                f"downloaded {len(got)} items from system {status.system_id} to {args.file}", start
            )
        else:
            await link.clear_mission()
            _say(f"cleared the mission of system {status.system_id}", start)
    return EXIT_OK


def _home_placeholder(link: VehicleLink) -> MissionItem:
    pos = link.telemetry.position
    if pos is None:
        return MissionItem(seq=0, frame=0, command=16)
    return MissionItem.waypoint(0, pos.lat_deg, pos.lon_deg, pos.alt_msl_m, frame=0)


def _say(text: str, start: float) -> None:
    print(f"{text} in {time.monotonic() - start:.2f} s", file=sys.stdout)
