"""``gcs status``: who is out there, in what state (one table, then exit)."""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import sys
from dataclasses import dataclass, field

from pymavlink.dialects.v20 import ardupilotmega as mavlink
from rich.table import Table

from gcs.commands.mission import endpoint_from_args, link_signing
from gcs.console import output_console
from gcs.errors import EXIT_FAILED, EXIT_OK
from vehicles.endpoints import Endpoint
from vehicles.errors import LinkError, TransportClosed
from vehicles.link import send_heartbeats
from vehicles.signing import SigningConfig
from vehicles.telemetry import TelemetryCache
from vehicles.transport import MavlinkTransport

HEARTBEAT_PERIOD_S = 1.0
_WANTED = (mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT, mavlink.MAVLINK_MSG_ID_SYS_STATUS)


@dataclass
class _Seen:
    """Vehicles heard on one endpoint, by system id."""

    endpoint: Endpoint
    vehicles: dict[int, TelemetryCache] = field(default_factory=dict)

    def complete(self) -> bool:
        return bool(self.vehicles) and all(
            c.position is not None and c.battery.remaining_pct is not None
            for c in self.vehicles.values()
        )


def run(args: argparse.Namespace) -> int:
    endpoints = [endpoint_from_args(text, args) for text in args.endpoints]
    signing = link_signing(args, None)
    console = output_console()
    try:
        seen = asyncio.run(_collect(endpoints, signing, args.timeout))
    except LinkError as exc:
        print(f"gcs status: {exc}", file=sys.stderr)
        return EXIT_FAILED
    console.print(_table(seen))
    silent = [str(s.endpoint) for s in seen if not s.vehicles]
    if silent:
        print(
            f"gcs status: no heartbeat within {args.timeout:g} s on {', '.join(silent)}",
            file=sys.stderr,
        )
        return EXIT_FAILED
    return EXIT_OK


async def _collect(
    endpoints: list[Endpoint], signing: SigningConfig | None, timeout_s: float
) -> list[_Seen]:
    seen = [_Seen(ep) for ep in endpoints]
    changed = asyncio.Event()
    async with contextlib.AsyncExitStack() as stack:
        tasks = []
        for entry in seen:
            transport = await MavlinkTransport.open(entry.endpoint, signing=signing)
            stack.push_async_callback(transport.close)
            tasks.append(asyncio.create_task(_listen(transport, entry, changed)))
            tasks.append(asyncio.create_task(send_heartbeats(transport, HEARTBEAT_PERIOD_S)))
        try:
            async with asyncio.timeout(timeout_s):
                while not all(s.complete() for s in seen):
                    await changed.wait()
                    changed.clear()
        except TimeoutError:
            pass
        finally:
            for task in tasks:
                task.cancel()
            await asyncio.gather(*tasks, return_exceptions=True)
    return seen


async def _listen(transport: MavlinkTransport, entry: _Seen, changed: asyncio.Event) -> None:
    async for msg in transport:
        sysid = msg.get_srcSystem()
        cache = entry.vehicles.get(sysid)
        if cache is None:
            if msg.get_type() != "HEARTBEAT" or msg.type == mavlink.MAV_TYPE_GCS:
                continue
            cache = entry.vehicles[sysid] = TelemetryCache()
            _request_once(transport, sysid, msg.get_srcComponent())
        if cache.update(msg) is not None:
            changed.set()


def _request_once(transport: MavlinkTransport, sysid: int, compid: int) -> None:
    """Ask for position and battery now (fire and forget: many vehicles stream them anyway)."""
    for message_id in _WANTED:
        with contextlib.suppress(TransportClosed):
            transport.send(
                mavlink.MAVLink_command_long_message(
                    sysid, compid, mavlink.MAV_CMD_REQUEST_MESSAGE, 0, message_id, 0, 0, 0, 0, 0, 0
                )
            )


def _table(seen: list[_Seen]) -> Table:
    table = Table(title="Vehicles")
    for column in ("endpoint", "sysid", "type", "autopilot", "mode", "armed", "battery %"):
        table.add_column(column, justify="right" if column in ("sysid", "battery %") else "left")
    table.add_column("lat", justify="right")
    table.add_column("lon", justify="right")
    for entry in seen:
        for sysid, cache in sorted(entry.vehicles.items()):
            status, pos, battery = cache.status, cache.position, cache.battery
            table.add_row(
                str(entry.endpoint),
                str(sysid),
                status.type_name if status else "?",
                status.autopilot_name if status else "?",
                status.mode_name if status else "?",
                ("yes" if status.armed else "no") if status else "?",
                "?" if battery.remaining_pct is None else f"{battery.remaining_pct:.0f}",
                "?" if pos is None else f"{pos.lat_deg:.7f}",
                "?" if pos is None else f"{pos.lon_deg:.7f}",
            )
    return table
