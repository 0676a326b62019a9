"""``gcs bench perf``, its live half: the live ground station flying the mock fleet
through the mission API (as ``gcs run --sim`` flies it), with the web page watched or
not; its rows and tables."""

from __future__ import annotations

import asyncio
import logging
import statistics
import tempfile
import time
from pathlib import Path
from typing import Any

from rich.table import Table

from gcs.bench.web import Watchers, watched
from gcs.errors import EXIT_FAILED, EXIT_OK
from gcs.generated_missions import MAP_SEED, RESERVE_PCT, case_mission
from gcs.live.mission import run_live
from gcs.live.run import LiveOptions, MissionRefused
from gcs.live.shared import Level
from gcs.log.mission_log import NullLog
from gcs.mission import Mission, load_mission
from gcs.mock_fleet import MockFleetRehearsal, SimFaults
from gcs.options.bench import LIVE_TIME_LIMIT_S, LOOP_BEHIND_MS
from gcs.outcome.report import report_dict
from gcs.outcome.result import RunResult
from sitl_mock import mapgen
from sitl_mock.gridmap import GridMap
from sitl_mock.maps import to_ascii
from vehicles.endpoints import free_loopback_udp_ports


def live_map(vehicles: int) -> GridMap:
    """An open map with work for every vehicle: about 25 free cells each, 150 at least."""
    side = max(14, round((25 * vehicles + 150) ** 0.5 * 1.15))
    return mapgen.open_field(side, side, MAP_SEED)


def write_live_mission(folder: Path, vehicles: int, links: str = "own") -> Path:
    grid = live_map(vehicles)
    ports = free_loopback_udp_ports(vehicles if links == "own" else 1) * (
        1 if links == "own" else vehicles
    )
    mission = case_mission(
        grid, vehicles, f"live{vehicles}", [f"udpin:127.0.0.1:{p}" for p in ports]
    )
    (folder / "map.txt").write_text(to_ascii(grid))
    lines = [f"name: {mission.name}", "map: map.txt", "fleet:", "  vehicles:"]
    for v in mission.fleet:
        lines.append(
            f"    - {{sysid: {v.sysid}, type: {v.type.value}, connection: '{v.connection}', "
            f"energy_per_m_pct: {v.energy_per_m_pct:.6f}, speed_m_s: {v.speed_m_s}, "
            f"charge_rate_pct_s: {v.charge_rate_pct_s}}}"
        )
    lines += ["planner:", f"  reserve_pct: {RESERVE_PCT:g}"]
    path = folder / "mission.yaml"
    path.write_text("\n".join(lines) + "\n")
    return path


def run_live_case(
    vehicles: int,
    speedup: float,
    links: str = "own",
    web_clients: int = 0,
    time_limit_s: float = LIVE_TIME_LIMIT_S,
) -> dict[str, Any]:
    """One live mission through the mission API, as ``gcs run --sim`` flies it (the mock
    fleet in this process), without a log, or with the web page served to
    ``web_clients`` readers (``gcs.bench.web``): the figures of its report."""
    if not logging.getLogger().handlers:
        # Library warnings (a link lost...) are the run's own business here.
        logging.getLogger().addHandler(logging.NullHandler())
    row: dict[str, Any] = {"vehicles": vehicles, "links": links, "web_clients": web_clients}
    with tempfile.TemporaryDirectory(prefix="gcs-bench-perf-") as tmp:
        mission = load_mission(write_live_mission(Path(tmp), vehicles, links))
        options = LiveOptions(speedup=speedup, time_limit_s=time_limit_s)
        t0 = time.perf_counter()
        try:
            result, watchers = asyncio.run(_fly(mission, options, web_clients))
        except MissionRefused as exc:
            return {**row, "error": str(exc)}
        wall = time.perf_counter() - t0
    r = report_dict(result)
    code = EXIT_OK if result.complete else EXIT_FAILED
    if watchers is not None:
        row["web_updates"] = watchers.updates
        row["web_mb"] = watchers.megabytes
        row["web_dropped"] = watchers.dropped
        row["web_clients_cpu_s"] = watchers.cpu_s
    return {
        **row,
        "free_cells": r["free_cells"],
        "exit": code,
        "wall_s": round(wall, 1),
        "mission_s": round(r["mission_s"], 1),
        "coverage_pct": r["coverage_pct"],
        "lost": r["lost_agents"],
        "decisions": r["decisions_timed"],
        "latency_ms_p50": r["decision_latency_ms_p50"],
        "latency_ms_p99": r["decision_latency_ms_p99"],
        "loop_lag_ms_p99": r["loop_lag_ms_p99"],
        "messages_per_s": r["messages_in_per_s"],
        "cpu_per_vehicle": round(r["cpu_s_per_s"] / vehicles, 4),
        "fell_behind": r["loop_lag_ms_p99"] > LOOP_BEHIND_MS,
    }


async def _fly(
    mission: Mission, options: LiveOptions, web_clients: int
) -> tuple[RunResult, Watchers | None]:
    def quiet(_text: str, _level: Level, _sysid: int | None) -> None:
        pass

    sim = MockFleetRehearsal(mission, SimFaults(), seed=options.seed)
    if not web_clients:
        return await run_live(mission, options, NullLog(), quiet, asyncio.Event(), sim=sim), None
    async with watched(mission, web_clients) as (log, watchers):
        result = await run_live(mission, options, log, quiet, asyncio.Event(), sim=sim)
    return result, watchers


def live_table(rows: list[dict[str, Any]], speedup: float) -> Table:
    table = Table(title=f"live ground station, gcs run --sim at speed-up {speedup:g}")
    for name in (
        "vehicles",
        "links",
        "web clients",
        "free cells",
        "coverage %",
        "lost",
        "wall s",
        "decisions",
        "latency p50 ms",
        "latency p99 ms",
        "loop lag p99 ms",
        "msgs/s",
        "CPU/vehicle",
        "fell behind",
    ):
        table.add_column(name, justify="right")
    for r in rows:
        if "error" in r:
            table.add_row(str(r["vehicles"]), r["links"], r["error"], *[""] * 11)
            continue
        table.add_row(
            str(r["vehicles"]),
            r["links"],
            str(r.get("web_clients") or "-"),
            str(r["free_cells"]),
            f"{r['coverage_pct']:.1f}",
            str(r["lost"]),
            f"{r['wall_s']:.1f}",
            str(r["decisions"]),
            f"{r['latency_ms_p50']:.2f}",
            f"{r['latency_ms_p99']:.2f}",
            f"{r['loop_lag_ms_p99']:.1f}",
            f"{r['messages_per_s']:.0f}",
            f"{100 * r['cpu_per_vehicle']:.1f} %",
            "yes" if r["fell_behind"] else "no",
        )
    return table


def web_pairs(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Each live case flown with the web page watched, beside the same case without: the
    median of each side's p99 over the repeats (``--repeat``), flown alternately."""
    sides: dict[tuple[int, str, int], list[dict[str, Any]]] = {}
    for r in rows:
        if "error" not in r and "latency_ms_p99" in r:
            sides.setdefault((r["vehicles"], r["links"], r.get("web_clients", 0)), []).append(r)
    pairs = []
    for (vehicles, links, clients), watched_rows in sides.items():
        alone = sides.get((vehicles, links, 0))
        if not clients or not alone:
            continue
        before = statistics.median(r["latency_ms_p99"] for r in alone)
        after = statistics.median(r["latency_ms_p99"] for r in watched_rows)
        pairs.append(
            {
                "vehicles": vehicles,
                "links": links,
                "web_clients": clients,
                "runs": len(watched_rows),
                "p99_ms_without": [r["latency_ms_p99"] for r in alone],
                "p99_ms_with": [r["latency_ms_p99"] for r in watched_rows],
                "median_p99_ms_without": before,
                "median_p99_ms_with": after,
                "ratio": round(after / before, 3) if before > 0 else None,
                "web_updates": sum(r.get("web_updates", 0) for r in watched_rows),
                "web_mb": round(sum(r.get("web_mb", 0.0) for r in watched_rows), 1),
                "web_dropped": sum(r.get("web_dropped", 0) for r in watched_rows),
                "web_clients_cpu_s": round(
                    sum(r.get("web_clients_cpu_s", 0.0) for r in watched_rows), 1
                ),
            }
        )
    return pairs


def web_table(pairs: list[dict[str, Any]]) -> Table:
    table = Table(title="the web page's cost: decision latency p99, without and with it watched")
    for name in ("vehicles", "links", "clients", "runs", "p99 ms without", "p99 ms with"):
        table.add_column(name, justify="right")
    for name in ("median with / without", "updates read", "MB read", "clients' CPU s"):
        table.add_column(name, justify="right")
    table.add_column("dropped", justify="right")
    for p in pairs:
        ratio = "-" if p["ratio"] is None else f"{p['ratio']:.3f}"
        table.add_row(
            str(p["vehicles"]),
            p["links"],
            str(p["web_clients"]),
            str(p["runs"]),
            ", ".join(f"{v:.1f}" for v in p["p99_ms_without"]),
            ", ".join(f"{v:.1f}" for v in p["p99_ms_with"]),
            ratio,
            str(p["web_updates"]),
            f"{p['web_mb']:.1f}",
            f"{p['web_clients_cpu_s']:.1f}",
            str(p["web_dropped"]),
        )
    return table
