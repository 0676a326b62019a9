"""``gcs bench mavlink``: how fast our link and our mock move missions, and how many
vehicles one mock process keeps up with.

What it measures, as the operator reads it: ``gcs bench mavlink --help``
(``gcs.options.bench``).
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import dataclasses
import logging
import math
import multiprocessing
import statistics
import time
from collections import Counter
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from multiprocessing.connection import Connection
from pathlib import Path
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as mavlink
from rich.console import Console
from rich.table import Table

from core.clocks import ScaledClock
from gcs.bench.common import write_json
from gcs.errors import EXIT_OK, UsageError
from gcs.mission import MAX_SYSID, Mission, MissionError, load_mission
from gcs.mock_fleet import mock_fleet_configs
from gcs.options.bench import (
    MAVLINK_ITEMS,
    MAVLINK_LOSS_PCT,
    MAVLINK_MAX_LAG_MS,
    MAVLINK_MISSION,
    MAVLINK_WINDOW_S,
)
from gcs.percentile import percentile
from sitl_mock import telemetry
from sitl_mock.faults import LinkFaults, VehicleFaults
from sitl_mock.fleet import MockFleet
from sitl_mock.mission_server import MissionProtocolSettings
from vehicles.errors import LinkError
from vehicles.link import LinkSettings, VehicleLink
from vehicles.mission_items import MissionItem, same_items
from vehicles.mission_protocol import MissionSettings
from vehicles.transport import MavlinkTransport

#: Rate a vehicle must achieve, as a share of its configured rate, to keep up.
KEEP_UP_RATIO = 0.9
DEFAULT_WARMUP_S = 1.0
#: How long one transfer may take before it counts as hung.
TRANSFER_LIMIT_S = 300.0
#: How long the child fleet may take to be heard from every vehicle.
START_LIMIT_S = 30.0
_PROBE_S = 0.05
#: Frames one send of a stream carries (one DISTANCE_SENSOR per 45-degree sector).
_FRAMES_PER_SEND = {mavlink.MAVLINK_MSG_ID_DISTANCE_SENSOR: 8}
_MAV2_MAGIC, _MAV1_MAGIC = 0xFD, 0xFE


@dataclass(frozen=True)
class Timers:
    """Mission protocol timers of both ends (real seconds)."""

    name: str
    mock: MissionProtocolSettings
    link: MissionSettings


TIMERS = {
    "loopback": Timers(
        "loopback",
        MissionProtocolSettings(retry_s=0.02, timeout_s=2.0),
        MissionSettings(timeout_s=0.1, item_timeout_s=0.02, retries=20),
    ),
    "spec": Timers("spec", MissionProtocolSettings(), MissionSettings()),
}


# ---------------------------------------------------------------------- mission transfer


def bench_items(mission: Mission, count: int) -> list[MissionItem]:
    """Home, then waypoints over the map's free cells in reading order (repeating)."""
    geo = mission.geo
    rows, cols = mission.map.shape
    free = [(r, c) for r in range(rows) for c in range(cols) if mission.map.is_free((r, c))]
    items = [MissionItem.waypoint(0, *geo.cell_centre(mission.charger), 0.0)]
    items += [
        MissionItem.waypoint(seq, *geo.cell_centre(free[seq % len(free)]), 0.0)
        for seq in range(1, count)
    ]
    return items


class FrameCounter:
    """Counts frames by direction and type (a transport tap)."""

    def __init__(self) -> None:
        self.counts: Counter[tuple[str, str]] = Counter()

    def __call__(self, direction: str, _buf: bytes, msg: mavlink.MAVLink_message) -> None:
        self.counts[direction, msg.get_type()] += 1

    def take(self) -> Counter[tuple[str, str]]:
        counts, self.counts = self.counts, Counter()
        return counts


async def _timed(coro: Any) -> tuple[Any, float, str | None]:
    """Run a transfer; its result, real seconds, and the error text if it failed."""
    start = time.perf_counter()
    try:
        async with asyncio.timeout(TRANSFER_LIMIT_S):
            result = await coro
    except LinkError as exc:
        return None, time.perf_counter() - start, str(exc)
    except TimeoutError:
        return None, time.perf_counter() - start, f"hung for {TRANSFER_LIMIT_S:g} s"
    return result, time.perf_counter() - start, None


async def bench_transfer(
    mission: Mission, count: int, loss_pct: float, timers: Timers, seed: int = 0
) -> dict[str, Any]:
    """Upload then download ``count`` items to one mock with ``loss_pct`` loss each way."""
    items = bench_items(mission, count)
    loss = loss_pct / 100.0
    faults = VehicleFaults(link=LinkFaults(loss_to_gcs=loss, loss_from_gcs=loss))
    link = await VehicleLink.connect(
        "udpin:127.0.0.1:0", target_system=1, settings=LinkSettings(mission=timers.link)
    )
    try:
        assert isinstance(link.transport, MavlinkTransport)  # the link's own port
        assert link.transport.local_address is not None
        base = mock_fleet_configs(mission)[0]
        config = dataclasses.replace(
            base,
            sysid=1,
            link=dataclasses.replace(
                base.link,
                connection=f"udpout:127.0.0.1:{link.transport.local_address[1]}",
                mission=timers.mock,
            ),
            faults=faults,
        )
        async with MockFleet([config], mission.map, mission.geo, ScaledClock(1.0), seed=seed):
            await link.wait_heartbeat(timeout_s=10.0)
            counter = FrameCounter()
            link.transport.add_tap(counter)
            report, upload_s, upload_error = await _timed(link.upload_mission(items))
            up = counter.take()
            downloaded, download_s, download_error = await _timed(link.download_mission())
            down = counter.take()
    finally:
        await link.close()
    return {
        "loss_pct_each_way": loss_pct,
        "items": count,
        "upload_s": upload_s,
        "upload_error": upload_error,
        "items_resent": up["out", "MISSION_ITEM_INT"] - count,
        "requests_heard": up["in", "MISSION_REQUEST"] + up["in", "MISSION_REQUEST_INT"],
        "link_timeouts": report.resends if report else None,
        "duplicate_requests": report.duplicate_requests if report else None,
        "download_s": download_s,
        "download_error": download_error,
        "download_requests_resent": up_to_zero(
            down["out", "MISSION_REQUEST_INT"] + down["out", "MISSION_REQUEST_LIST"] - count - 1
        ),
        "identical": downloaded is not None and same_items(downloaded, items),
    }


def up_to_zero(value: int) -> int:
    return max(0, value)


# ---------------------------------------------------------------------- telemetry capacity


def configured_rates() -> dict[int, float]:
    """Sends per second of each default stream of one vehicle, by message id."""
    return {
        message_id: 1.0 / interval
        for message_id, interval in telemetry.DEFAULT_INTERVALS_S.items()
        if interval > 0
    }


def frames_per_s(rates: dict[int, float]) -> float:
    return sum(rate * _FRAMES_PER_SEND.get(mid, 1) for mid, rate in rates.items())


def fleet_sizes(max_vehicles: int) -> list[int]:
    """1, 2, 4 ... below ``max_vehicles``, then ``max_vehicles`` itself."""
    sizes, n = [], 1
    while n < max_vehicles:
        sizes.append(n)
        n *= 2
    return [*sizes, max_vehicles]


def _message_id(frame: bytes) -> int | None:
    if len(frame) >= 10 and frame[0] == _MAV2_MAGIC:
        return frame[7] | frame[8] << 8 | frame[9] << 16
    if len(frame) >= 6 and frame[0] == _MAV1_MAGIC:
        return frame[5]
    return None


class _Receiver(asyncio.DatagramProtocol):
    """One vehicle's ground-side socket: per stream, the sends that arrived inside the
    window, the first and the last. The mock sends one frame per datagram, so the header
    alone tells the type; frames of one stream closer than a quarter of its period are
    one send (DISTANCE_SENSOR sends 8 at once)."""

    def __init__(self, heard: Callable[[], None], periods_s: dict[int, float]) -> None:
        self.window: tuple[float, float] = (float("inf"), float("inf"))
        self.sends: Counter[int] = Counter()
        self.first: dict[int, float] = {}
        self.last: dict[int, float] = {}
        self._gaps = {mid: period / 4 for mid, period in periods_s.items()}
        self._previous: dict[int, float] = {}
        self._heard = heard
        self._first_datagram = True

    def datagram_received(self, data: bytes, addr: tuple[str, int]) -> None:
        if self._first_datagram:
            self._first_datagram = False
            self._heard()
        now = time.monotonic()
        message_id = _message_id(data)
        if message_id is None:
            return
        previous = self._previous.get(message_id, -math.inf)
        self._previous[message_id] = now
        new_send = now - previous > self._gaps.get(message_id, 0.0)
        if new_send and self.window[0] <= now < self.window[1]:
            self.sends[message_id] += 1
            self.first.setdefault(message_id, now)
            self.last[message_id] = now

    def rate(self, message_id: int, window_s: float) -> float:
        """Sends per second of one stream, from the spacing of its sends (not from a count
        in the window, which is off by one whenever a send falls on an edge)."""
        sends = self.sends[message_id]
        span = self.last.get(message_id, 0.0) - self.first.get(message_id, 0.0)
        if sends < 2 or span <= 0:
            return sends / window_s
        return (sends - 1) / span


def _serve_fleet(
    mission_path: str, ports: list[int], speedup: float, seed: int, conn: Connection
) -> None:
    """Child process: the mock fleet, until told to stop; then its probe samples."""
    samples = asyncio.run(_serve_fleet_async(mission_path, ports, speedup, seed, conn))
    conn.send(samples)
    conn.close()


async def _serve_fleet_async(
    mission_path: str, ports: list[int], speedup: float, seed: int, conn: Connection
) -> list[tuple[float, float, float, float]]:
    """Run the fleet and sample, every ``_PROBE_S``: (monotonic time, physics lag, event
    loop lag, process CPU), all in real seconds. Physics lag = clock time not yet
    simulated by the physics."""
    mission = load_mission(mission_path).with_agents(len(ports))
    configs = [
        dataclasses.replace(
            config, link=dataclasses.replace(config.link, connection=f"udpout:127.0.0.1:{port}")
        )
        for config, port in zip(mock_fleet_configs(mission), ports, strict=True)
    ]
    loop = asyncio.get_running_loop()
    stop = asyncio.Event()
    loop.add_reader(conn.fileno(), stop.set)
    clock = ScaledClock(speedup)
    samples: list[tuple[float, float, float, float]] = []
    async with MockFleet(configs, mission.map, mission.geo, clock, seed=seed) as fleet:
        t0 = clock.now()
        first = fleet.vehicles[configs[0].sysid]
        while not stop.is_set():
            before = time.monotonic()
            with contextlib.suppress(TimeoutError):
                async with asyncio.timeout(_PROBE_S):
                    await stop.wait()
            now = time.monotonic()
            physics_lag = clock.to_real(clock.now() - t0 - first.elapsed_s)
            samples.append(
                (now, physics_lag, max(0.0, now - before - _PROBE_S), time.process_time())
            )
    loop.remove_reader(conn.fileno())
    conn.recv()
    return samples


async def bench_fleet(
    mission_path: Path,
    vehicles: int,
    *,
    window_s: float,
    warmup_s: float,
    max_lag_ms: float,
    speedup: float = 1.0,
    seed: int = 0,
) -> dict[str, Any]:
    """Serve ``vehicles`` mock vehicles from one child process and measure what arrives."""
    loop = asyncio.get_running_loop()
    all_heard = asyncio.Event()
    waiting = [vehicles]

    def heard() -> None:
        waiting[0] -= 1
        if waiting[0] == 0:
            all_heard.set()

    sockets: list[asyncio.DatagramTransport] = []
    receivers: list[_Receiver] = []
    parent_conn, child_conn = multiprocessing.Pipe()
    process = None
    try:
        periods_s = {
            mid: interval / speedup for mid, interval in telemetry.DEFAULT_INTERVALS_S.items()
        }
        for _ in range(vehicles):
            transport, receiver = await loop.create_datagram_endpoint(
                lambda: _Receiver(heard, periods_s), local_addr=("127.0.0.1", 0)
            )
            sockets.append(transport)
            receivers.append(receiver)
        ports = [int(s.get_extra_info("sockname")[1]) for s in sockets]
        process = multiprocessing.get_context("spawn").Process(
            target=_serve_fleet,
            args=(str(mission_path), ports, speedup, seed, child_conn),
            name=f"mock-fleet-{vehicles}",
        )
        process.start()
        async with asyncio.timeout(START_LIMIT_S):
            await all_heard.wait()
        start = time.monotonic() + warmup_s
        window = (start, start + window_s)
        for receiver in receivers:
            receiver.window = window
        cpu_here = time.process_time()
        await asyncio.sleep(window[1] - time.monotonic())  # a measuring window, not an event
        cpu_here = time.process_time() - cpu_here
        parent_conn.send("stop")
        samples = await loop.run_in_executor(None, _recv_with_timeout, parent_conn)
    finally:
        for transport in sockets:
            transport.close()
        if process is not None:
            await loop.run_in_executor(None, _reap, process)
    return _fleet_figures(vehicles, receivers, samples, window, cpu_here, max_lag_ms, speedup)


def _recv_with_timeout(conn: Connection) -> list[tuple[float, float, float, float]]:
    if not conn.poll(START_LIMIT_S):
        raise TimeoutError("the mock fleet process did not report")
    samples: list[tuple[float, float, float, float]] = conn.recv()
    return samples


def _reap(process: multiprocessing.process.BaseProcess) -> None:
    process.join(10.0)
    if process.is_alive():
        process.terminate()
        process.join(5.0)


def _message_name(message_id: int) -> str:
    entry = mavlink.mavlink_map.get(message_id)
    return entry.msgname if entry is not None else str(message_id)


def _fleet_figures(
    vehicles: int,
    receivers: list[_Receiver],
    samples: list[tuple[float, float, float, float]],
    window: tuple[float, float],
    cpu_here_s: float,
    max_lag_ms: float,
    speedup: float,
) -> dict[str, Any]:
    window_s = window[1] - window[0]
    rates = {mid: rate * speedup for mid, rate in configured_rates().items()}
    per_vehicle_expected = frames_per_s(rates)
    achieved = [{mid: r.rate(mid, window_s) for mid in rates} for r in receivers]
    shares = [frames_per_s(a) / per_vehicle_expected for a in achieved]
    by_type = {
        _message_name(mid): min(a[mid] for a in achieved) / rate for mid, rate in rates.items()
    }
    inside = [s for s in samples if window[0] <= s[0] < window[1]]
    physics_lag = [s[1] for s in inside]
    loop_lag = [s[2] for s in inside]
    cpu = (inside[-1][3] - inside[0][3]) / (inside[-1][0] - inside[0][0]) if len(inside) > 1 else 0
    lag_p95_ms = 1e3 * percentile(physics_lag, 95)
    keeps_up = min(shares) >= KEEP_UP_RATIO and lag_p95_ms <= max_lag_ms
    return {
        "vehicles": vehicles,
        "configured_msgs_per_s": per_vehicle_expected,
        "achieved_msgs_per_s_mean": statistics.fmean(shares) * per_vehicle_expected,
        "worst_vehicle_share": min(shares),
        "worst_stream_share": min(by_type.values()),
        "worst_stream": min(by_type, key=by_type.__getitem__),
        "physics_lag_p95_ms": lag_p95_ms,
        "physics_lag_max_ms": 1e3 * max(physics_lag, default=float("nan")),
        "loop_lag_p95_ms": 1e3 * percentile(loop_lag, 95),
        "mock_cpu_share": cpu,
        "receiver_cpu_share": cpu_here_s / window_s,
        "keeps_up": keeps_up,
    }


# ---------------------------------------------------------------------- the whole bench


async def run_mavlink_bench(
    *,
    mission_path: Path = MAVLINK_MISSION,
    items: int = MAVLINK_ITEMS,
    loss_pct: Sequence[float] = MAVLINK_LOSS_PCT,
    max_vehicles: int = MAX_SYSID,
    timers: str = "loopback",
    window_s: float = MAVLINK_WINDOW_S,
    warmup_s: float = DEFAULT_WARMUP_S,
    max_lag_ms: float = MAVLINK_MAX_LAG_MS,
    speedup: float = 1.0,
    seed: int = 0,
    progress: Callable[[str], None] | None = None,
) -> dict[str, Any]:
    """Both measurements; the figures as a JSON-ready dict."""
    tell = progress or (lambda _text: None)
    mission = load_mission(mission_path)
    transfers = []
    for loss in loss_pct:
        tell(f"mission transfer: {items} items, {loss:g} % loss each way")
        transfers.append(await bench_transfer(mission, items, loss, TIMERS[timers], seed))
    capacity = []
    for n in fleet_sizes(max_vehicles):
        tell(f"telemetry capacity: {n} vehicle(s)")
        row = await bench_fleet(
            mission_path,
            n,
            window_s=window_s,
            warmup_s=warmup_s,
            max_lag_ms=max_lag_ms,
            speedup=speedup,
            seed=seed,
        )
        capacity.append(row)
        if not row["keeps_up"]:
            break
    keeping_up = [row["vehicles"] for row in capacity if row["keeps_up"]]
    return {
        "mission": str(mission_path),
        "timers": timers,
        "speedup": speedup,
        "transfer": transfers,
        "capacity": capacity,
        "largest_fleet_keeping_up": max(keeping_up, default=0),
        "keep_up_rule": {"min_share": KEEP_UP_RATIO, "max_physics_lag_p95_ms": max_lag_ms},
    }


# ---------------------------------------------------------------------- command line


def _check(args: argparse.Namespace) -> None:
    if not args.items >= 1:
        raise UsageError(f"--items must be at least 1, got {args.items}")
    if any(not 0 <= x < 100 for x in args.loss):
        raise UsageError(f"--loss must be in [0, 100), got {args.loss}")
    if args.max_vehicles < 1:
        raise UsageError(f"--max-vehicles must be at least 1, got {args.max_vehicles}")
    if not args.speedup > 0:
        raise UsageError(f"--speedup must be positive, got {args.speedup}")
    if not args.window > 0:
        raise UsageError(f"--window must be positive, got {args.window}")


def run_mavlink_command(args: argparse.Namespace) -> int:
    _check(args)
    console = Console()
    if not console.is_terminal:
        console = Console(width=200)  # many columns: keep them whole in files and pipes
    note = Console(stderr=True)
    # Heartbeats lost to the simulated loss make the link warn; the table says it all.
    logging.getLogger("vehicles").setLevel(logging.ERROR)
    max_vehicles = min(args.max_vehicles, MAX_SYSID)
    if max_vehicles < args.max_vehicles:
        note.print(f"--max-vehicles {args.max_vehicles}: one fleet has at most {MAX_SYSID}")
    try:
        figures = asyncio.run(
            run_mavlink_bench(
                mission_path=args.mission,
                items=args.items,
                loss_pct=args.loss,
                max_vehicles=max_vehicles,
                timers=args.timers,
                window_s=args.window,
                speedup=args.speedup,
                max_lag_ms=args.max_lag_ms,
                progress=lambda text: note.print(f"[dim]{text}[/]"),
            )
        )
    except MissionError as exc:
        raise UsageError(str(exc)) from exc
    console.print(transfer_table(figures))
    console.print(capacity_table(figures))
    console.print(
        f"largest fleet one mock process keeps up with: {figures['largest_fleet_keeping_up']}"
        f" vehicle(s) (every vehicle >= {KEEP_UP_RATIO:.0%} of its configured rate, physics "
        f"lag p95 <= {args.max_lag_ms:g} ms)"
    )
    write_json(args.json, figures, console)
    return EXIT_OK


def transfer_table(figures: dict[str, Any]) -> Table:
    timers = TIMERS[figures["timers"]]
    table = Table(
        title=(
            f"Mission transfer, link udpin <-> mock udpout on loopback ({figures['timers']} "
            f"timers: link {timers.link.timeout_s:g} s / item {timers.link.item_timeout_s:g} s "
            f"x{timers.link.retries}, mock re-request {timers.mock.retry_s:g} s)"
        )
    )
    for column in (
        "loss each way",
        "items",
        "upload s",
        "items resent",
        "requests heard",
        "link timeouts",
        "download s",
        "requests resent",
        "identical",
    ):
        table.add_column(column, justify="right")
    for row in figures["transfer"]:
        table.add_row(
            f"{row['loss_pct_each_way']:g} %",
            str(row["items"]),
            _seconds(row["upload_s"], row["upload_error"]),
            str(row["items_resent"]),
            str(row["requests_heard"]),
            "-" if row["link_timeouts"] is None else str(row["link_timeouts"]),
            _seconds(row["download_s"], row["download_error"]),
            str(row["download_requests_resent"]),
            "yes" if row["identical"] else "[red]NO[/]",
        )
    return table


def _seconds(value: float, error: str | None) -> str:
    return f"{value:.3f}" if error is None else f"[red]failed after {value:.1f}: {error}[/]"


def capacity_table(figures: dict[str, Any]) -> Table:
    table = Table(
        title=f"Telemetry of one mock process (speed-up {figures['speedup']:g}, default streams)"
    )
    for column in (
        "vehicles",
        "msgs/s/vehicle (configured)",
        "achieved (mean)",
        "worst vehicle",
        "worst stream",
        "physics lag p95 / max ms",
        "loop lag p95 ms",
        "mock CPU",
        "receiver CPU",
        "keeps up",
    ):
        table.add_column(column, justify="right")
    for row in figures["capacity"]:
        table.add_row(
            str(row["vehicles"]),
            f"{row['configured_msgs_per_s']:.1f}",
            f"{row['achieved_msgs_per_s_mean']:.1f}",
            f"{row['worst_vehicle_share']:.0%}",
            f"{row['worst_stream_share']:.0%} {row['worst_stream']}",
            f"{row['physics_lag_p95_ms']:.0f} / {row['physics_lag_max_ms']:.0f}",
            f"{row['loop_lag_p95_ms']:.1f}",
            f"{row['mock_cpu_share']:.0%}",
            f"{row['receiver_cpu_share']:.0%}",
            "yes" if row["keeps_up"] else "[red]no[/]",
        )
    return table
