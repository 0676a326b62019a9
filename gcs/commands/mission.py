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

from rich.console import Console

from gcs.commands.keys import connection_signing, load_keys
from gcs.errors import EXIT_FAILED, EXIT_OK, UsageError
from vehicles.endpoints import Endpoint, parse_endpoint
from vehicles.errors import EndpointError, LinkError
from vehicles.link import VehicleLink
from vehicles.mission_files import FORMATS, MissionFileError, read_mission, write_mission
from vehicles.mission_items import MissionItem, renumber
from vehicles.signing import SigningConfig


def link_signing(args: argparse.Namespace, sysid: int | None) -> SigningConfig | None:
    """The signing of ``--keys`` for the vehicle ``sysid`` (None: the file's only key)."""
    if args.keys is None:
        return None
    return connection_signing(load_keys(args.keys, f"gcs {args.command}"), sysid)


def endpoint_from_args(text: str, args: argparse.Namespace) -> Endpoint:
    try:
        return parse_endpoint(text, allow_remote=args.allow_remote)
    except EndpointError as exc:
        raise UsageError(str(exc)) from None


def run(args: argparse.Namespace) -> int:
    endpoint = endpoint_from_args(args.endpoint, args)
    signing = link_signing(args, args.sysid)
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
