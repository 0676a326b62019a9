"""``gcs bench faults``: the fault campaign, one live mission per fault.

What it measures, as the operator reads it: ``gcs bench faults --help``
(``gcs.options.bench``).
"""

from __future__ import annotations

import argparse
import dataclasses
import enum
import json
import platform
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml
from rich.console import Console
from rich.table import Table

from gcs.bench.common import write_json
from gcs.bench.fault_runs import LOG_NAME, StationRun, end, fly_station, start_fleet, start_station
from gcs.console import output_console
from gcs.errors import EXIT_FAILED, EXIT_OK, UsageError
from gcs.log.reader import LogError, read_contents, read_log
from gcs.mission import MissionError, load_mission
from gcs.mock_fleet import SimFaults
from gcs.options.bench import LONG_CUT_S, SHORT_CUT_S, STRIKE_S
from gcs.outcome.report import report_dict
from vehicles.endpoints import free_loopback_udp_ports

#: Each sudden battery sag of the battery row (percent).
SAG_PCT = 15.0
#: Real seconds the first ground station of the SIGKILL row runs before the kill.
KILL_AFTER_S = 6.0


@dataclass(frozen=True)
class FaultCase:
    name: str
    #: What the mock fleet is made to suffer.
    faults: SimFaults = field(default_factory=SimFaults)
    #: Vehicles this fault must cost (it makes losing them the right outcome).
    expect_lost: int = 0
    #: Percent of charge the fault takes at once (a sag): it may eat into the reserve
    #: of a vehicle on its way home by that much, and nothing can prevent it.
    sag_pct: float = 0.0
    kill: bool = False


def fault_cases(victim: int, strike_s: float = STRIKE_S) -> list[FaultCase]:
    """The campaign; ``victim`` is the vehicle that cut and death faults hit at ``strike_s``."""
    at = strike_s
    return [
        FaultCase("no fault"),
        FaultCase("10 % packet loss", SimFaults(loss=0.1)),
        FaultCase("20 % packet loss", SimFaults(loss=0.2)),
        FaultCase("40 % packet loss", SimFaults(loss=0.4)),
        FaultCase("latency 0.2 s + jitter 0.3 s", SimFaults(latency_s=0.2, jitter_s=0.3)),
        FaultCase(f"link cut {SHORT_CUT_S:g} s", SimFaults(cuts=((victim, at, SHORT_CUT_S),))),
        FaultCase(
            f"link cut {LONG_CUT_S:g} s (> lost timeout)",
            SimFaults(cuts=((victim, at, LONG_CUT_S),)),
            expect_lost=1,
        ),
        FaultCase("vehicle dies", SimFaults(deaths=((victim, at),)), expect_lost=1),
        FaultCase(
            f"battery noise +-30 % and sags of {SAG_PCT:g} %",
            SimFaults(battery_noise=0.3, sags=((80.0, SAG_PCT), (200.0, SAG_PCT))),
            sag_pct=SAG_PCT,
        ),
        FaultCase("GCS killed (SIGKILL), resumed", kill=True),
    ]


# -- one row -----------------------------------------------------------------------------


def _outcome(out: Path, row: dict[str, Any]) -> dict[str, Any]:
    """The row's figures from the report and the log a run left in ``out``."""
    try:
        report = json.loads((out / "report.json").read_text())
    except (OSError, ValueError):
        return {**row, "error": row.get("error") or "no report"}
    reserve = report["reserve_pct"]
    low = min((a["min_battery_pct"] for a in report["agents"]), default=100.0)
    log = row.get("log")  # the killed row says what the first log lost
    if log is None:
        try:
            logged = json.loads(json.dumps(report_dict(read_log(out / LOG_NAME))))
            log = "complete" if logged == report else "differs from the report"
        except LogError as exc:
            log = f"unreadable ({exc})"
    return {
        **row,
        "coverage_pct": report["coverage_pct"],
        "lost": report["lost_agents"],
        "min_battery_pct": round(low, 1),
        "below_reserve": low < reserve - 1e-6,
        "reserve_eaten_pct": round(max(0.0, reserve - low), 1),
        "reserve_pct": reserve,
        "total_path_m": report["total_path_m"],
        "log": log,
    }


def on_free_ports(mission_path: Path, folder: Path) -> Path:
    """A copy of the mission whose vehicles use loopback ports free right now, so that
    the campaign never fights a ground station (or a test) on the mission's own ports."""
    mission = load_mission(mission_path)
    raw = yaml.safe_load(mission_path.read_text())
    raw["map"] = str((mission_path.parent / raw["map"]).resolve())
    ports = free_loopback_udp_ports(len(mission.fleet))
    raw["fleet"] = {
        "vehicles": [
            {
                **{f.name: _plain(getattr(v, f.name)) for f in dataclasses.fields(v)},
                "connection": f"udpin:127.0.0.1:{port}",
            }
            for v, port in zip(mission.fleet, ports, strict=True)
        ]
    }
    path = folder / "mission.yaml"
    path.write_text(yaml.safe_dump(raw, sort_keys=False))
    return path


def _plain(value: object) -> object:
    """A mission value as YAML writes it (an enum as its text)."""
    return value.value if isinstance(value, enum.Enum) else value


def run_case(
    case: FaultCase, mission: Path, args: argparse.Namespace, folder: Path
) -> dict[str, Any]:
    row: dict[str, Any] = {
        "fault": case.name,
        "expect_lost": case.expect_lost,
        "sag_pct": case.sag_pct,
    }
    mission = on_free_ports(mission, folder)
    out = folder / "out"
    t0 = time.perf_counter()
    if case.kill:
        row = _killed_and_resumed(mission, args, folder, row)
    else:
        run = StationRun(mission, out, args.seed, args.speedup, case.faults)
        row = _flown(run, args.case_limit, row)
    row["wall_s"] = round(time.perf_counter() - t0, 1)
    return _outcome(out, row)


def _flown(run: StationRun, limit_s: float, row: dict[str, Any]) -> dict[str, Any]:
    code, last = fly_station(run, limit_s)
    row["exit"] = code
    if code is None or code > EXIT_FAILED:
        row["error"] = last or f"exit {code}"
    return row


def _killed_and_resumed(
    mission: Path, args: argparse.Namespace, folder: Path, row: dict[str, Any]
) -> dict[str, Any]:
    """The fleet in a process of its own; a first station killed (SIGKILL) after
    ``KILL_AFTER_S``; a second one resumed from the first one's log."""
    first, out = folder / "first", folder / "out"
    fleet = start_fleet(mission, args.speedup)
    try:
        station, answer = start_station(StationRun(mission, first, args.seed, args.speedup, None))
        answer.close()
        station.join(KILL_AFTER_S)
        if not station.is_alive():
            return {
                **row,
                "error": f"the first ground station ended early (exit {station.exitcode})",
            }
        killed_at = time.time()
        station.kill()
        station.join(30)
        row["log"] = _log_loss(first / LOG_NAME, killed_at, args.speedup)
        run = StationRun(mission, out, args.seed, args.speedup, None, resume=first / LOG_NAME)
        return _flown(run, args.case_limit, row)
    finally:
        end(fleet)


def log_loss_s(log: Path, killed_at: float, speedup: float) -> float | None:
    """Real seconds between a killed ground station's last logged vehicle state and the
    kill (``killed_at``, Unix time); None when the log holds no run. Raises LogError."""
    contents = read_contents(log)
    if contents.meta is None or not contents.states:
        return None
    last_t = max(s[-1].t_s for s in contents.states.values() if s)
    return max(0.0, killed_at - (contents.meta["started_unix_s"] + last_t / speedup))


def _log_loss(log: Path, killed_at: float, speedup: float) -> str:
    """How much of the mission the killed ground station's log lost."""
    try:
        lost_s = log_loss_s(log, killed_at, speedup)
    except LogError as exc:
        return f"unreadable ({exc})"
    return "nothing readable" if lost_s is None else f"last {lost_s:.2f} s before the kill"


# -- the table ----------------------------------------------------------------------------


def verdict(row: dict[str, Any]) -> str:
    if "error" in row:
        return "FAILED: " + row["error"]
    if row["below_reserve"] and row["reserve_eaten_pct"] > row.get("sag_pct", 0.0):
        return "FAILED: below the reserve"
    if row["lost"] != row["expect_lost"]:
        return f"FAILED: {row['lost']} lost"
    if row["coverage_pct"] < 100:
        return "FAILED: incomplete"
    if row["expect_lost"]:
        return "ok, 1 lost as it must be"
    if row["below_reserve"]:
        return f"ok, a sag ate {row['reserve_eaten_pct']:g} % of the reserve"
    return "ok"


def faults_table(rows: list[dict[str, Any]], mission: str) -> Table:
    table = Table(title=f"fault campaign, gcs run --sim on {mission}")
    for name in ("fault", "coverage %", "lost", "min battery %", "log", "wall s", "verdict"):
        table.add_column(name, justify="left" if name in ("fault", "log", "verdict") else "right")
    for r in rows:
        if "coverage_pct" not in r:
            table.add_row(r["fault"], "", "", "", "", f"{r['wall_s']:.0f}", verdict(r))
            continue
        table.add_row(
            r["fault"],
            f"{r['coverage_pct']:.1f}",
            str(r["lost"]),
            f"{r['min_battery_pct']:.0f} (reserve {r['reserve_pct']:g})",
            r["log"],
            f"{r['wall_s']:.0f}",
            verdict(r),
        )
    return table


def _rows(only: str | None, count: int) -> list[int]:
    if only is None:
        return list(range(count))
    try:
        picked = sorted({int(x) - 1 for x in only.split(",") if x.strip()})
    except ValueError:
        raise UsageError(f"--only: expected row numbers like 1,3, got {only!r}") from None
    if not picked or picked[0] < 0 or picked[-1] >= count:
        raise UsageError(f"--only: rows are 1..{count}, got {only!r}")
    return picked


def run_faults(args: argparse.Namespace) -> int:
    try:
        mission = load_mission(args.mission)
    except MissionError as exc:
        raise UsageError(str(exc)) from exc
    if not args.speedup > 0 or not args.case_limit > 0 or not args.strike > 0:
        raise UsageError("--speedup, --case-limit and --strike must be positive")
    if len(mission.fleet) < 2:
        raise UsageError(f"{args.mission}: the campaign needs a fleet of 2 or more vehicles")
    cases = fault_cases(mission.fleet[-1].sysid, args.strike)
    console = output_console(quiet=False)
    progress = Console(stderr=True)
    rows = []
    for k in _rows(args.only, len(cases)):
        case = cases[k]
        progress.print(f"fault {k + 1}/{len(cases)}: {case.name} ...")
        with tempfile.TemporaryDirectory(prefix="gcs-bench-faults-") as tmp:
            rows.append(run_case(case, args.mission, args, Path(tmp)))
    console.print(faults_table(rows, mission.name))
    figures = {"machine": platform.platform(), "mission": mission.name, "rows": rows}
    write_json(args.json, figures, console)
    ok = all(verdict(r).startswith("ok") for r in rows)
    return EXIT_OK if ok else EXIT_FAILED
