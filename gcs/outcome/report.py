"""The report of a finished run: ``report.json`` and the terminal summary.

Everything here is derived from a :class:`~gcs.outcome.result.RunResult`; nothing is
recomputed from logs or the world, so the report says exactly what the run said.
"""

from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
from rich.console import Console
from rich.table import Table

from gcs.outcome.result import AgentTrace, RunResult

REPORT_NAME = "report.json"
#: Decimals kept for every float in the report.
DECIMALS = 3


def _round(value: Any) -> Any:
    """Round floats (also inside lists and dicts) so the JSON stays readable.

    NumPy scalars become plain Python values, which ``json`` can write.
    """
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float):
        return round(value, DECIMALS)
    if isinstance(value, dict):
        return {k: _round(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_round(v) for v in value]
    return value


def homing_m(result: RunResult) -> float:
    """Metres all agents drove home once coverage was complete (or the mission recalled)."""
    return sum(a.homing_m for a in result.agents)


def charges_total(result: RunResult) -> int:
    return sum(a.charges for a in result.agents)


def us_per_agent_step(result: RunResult) -> float:
    """Planner time per agent per iteration, in microseconds.

    The denominator counts every agent in every iteration, lost or not, which
    slightly understates the cost for runs that lost agents early.
    """
    steps = result.iterations * len(result.agents)
    return result.planner_s * 1e6 / steps if steps else 0.0


def _agent_dict(agent: AgentTrace) -> dict[str, Any]:
    return {
        "id": agent.id,
        "path_m": agent.path_m,
        "homing_m": agent.homing_m,
        "charges": agent.charges,
        "min_battery_pct": agent.min_battery_pct,
        "lost": agent.lost,
    }


def report_dict(result: RunResult) -> dict[str, Any]:
    """The content of ``report.json``: JSON-ready, floats rounded.

    Keys of ``result.extra`` are added at the top level; they never override
    the standard keys.
    """
    report: dict[str, Any] = {
        "mission": result.mission,
        "complete": result.complete,
        "interrupted": result.interrupted,
        "shape": list(result.shape),
        "cell_size_m": result.cell_size_m,
        "agent_count": len(result.agents),
        "coverage_pct": result.coverage_pct,
        "free_cells": result.free_cells,
        "covered_cells": result.covered_cells,
        "out_of_range_cells": result.out_of_range_cells,
        "total_path_m": result.total_path_m,
        "homing_m": homing_m(result),
        "makespan_m": result.makespan_m,
        "iterations": result.iterations,
        "lost_agents": result.lost_agents,
        "wall_s": result.wall_s,
        "planner_s": result.planner_s,
        "us_per_agent_step": us_per_agent_step(result),
        "btps_detected": len(result.btps),
        "btps_covered": sum(1 for b in result.btps if b.covered_by is not None),
        "safety_net_fires": result.safety_net_fires,
        "charges_total": charges_total(result),
        "reserve_pct": result.reserve_pct,
        "agents": [_agent_dict(a) for a in result.agents],
    }
    for key, value in result.extra.items():
        report.setdefault(key, value)
    return _round(report)


def write_report(result: RunResult, out_dir: Path) -> Path:
    """Write ``report.json`` into ``out_dir`` atomically and return its path.

    The JSON goes to a temporary file in the same directory first, so a reader
    never sees a half-written report and a crash leaves the old one intact.
    """
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    target = out_dir / REPORT_NAME
    text = json.dumps(report_dict(result), indent=2) + "\n"
    fd, tmp_name = tempfile.mkstemp(prefix=".report-", suffix=".json.tmp", dir=out_dir)
    try:
        os.fchmod(fd, _READABLE & ~_umask())  # mkstemp's 0600: as any file written here
        with os.fdopen(fd, "w", encoding="utf-8") as handle:
            handle.write(text)
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(tmp_name, target)
    except BaseException:
        Path(tmp_name).unlink(missing_ok=True)
        raise
    return target


_READABLE = 0o666


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _verdict(result: RunResult) -> str:
    if result.interrupted:
        return "INTERRUPTED (the log ends before the run's result)"
    return "complete" if result.complete else "INCOMPLETE"


def _steps_label(result: RunResult) -> str:
    """What ``result.iterations`` counts, in the words the figures use: a plan's steps
    (every vehicle moves at most one cell), a timed plan's ticks, the cells the busiest
    vehicle of a live run moved, or what a cut log holds."""
    if result.interrupted:
        what = "Steps in the cut log"
    elif result.extra.get("live"):
        what = "Moves of the busiest vehicle"
    elif "mission_s" in result.extra:
        what = "Plan ticks"
    else:
        what = "Plan steps"
    return what + (" to full coverage" if result.covered_cells >= result.free_cells else "")


def summary_rows(result: RunResult) -> list[tuple[str, str]]:
    """Label/value pairs for the terminal summary table."""
    n_agents = len(result.agents)
    rows = [
        ("Mission", result.mission),
        ("Result", _verdict(result)),
        ("Map", f"{result.shape[0]} x {result.shape[1]} cells of {result.cell_size_m:g} m"),
        ("Vehicles", f"{n_agents} ({result.lost_agents} lost)"),
        (
            "Coverage",
            f"{result.coverage_pct:.1f} % ({result.covered_cells}/{result.free_cells} free cells)",
        ),
        ("Cells out of battery range", str(result.out_of_range_cells)),
        ("Path before the way home", f"{result.total_path_m:.1f} m"),
        ("Way home at the end", f"{homing_m(result):.1f} m"),
        ("Longest path of one vehicle", f"{result.makespan_m:.1f} m"),
        (_steps_label(result), str(result.iterations)),
        ("Charges", str(charges_total(result))),
        ("Backtracking points found", str(len(result.btps))),
        ("Targets taken by the safety net", str(result.safety_net_fires)),
        ("Wall time", f"{result.wall_s:.2f} s"),
        (
            "Planner time",
            f"{result.planner_s:.3f} s ({us_per_agent_step(result):.1f} µs per decision)",
        ),
    ]
    if "path_iterations" in result.extra:  # a plan's: the paper's count (gcs.offline.simulate)
        at = rows.index((_steps_label(result), str(result.iterations))) + 1
        rows.insert(at, ("The same, a planned path as one", str(result.extra["path_iterations"])))
    return rows


def _summary_table(result: RunResult) -> Table:
    table = Table(title=f"Run summary: {result.mission}", show_header=False)
    table.add_column("what", style="bold")
    table.add_column("value")
    for label, value in summary_rows(result):
        table.add_row(label, value)
    return table


def _agents_table(result: RunResult) -> Table:
    table = Table(title="Agents")
    for name in ("id", "path m", "homing m", "charges", "min battery %", "lost"):
        table.add_column(name, justify="left" if name == "lost" else "right")
    for a in result.agents:
        table.add_row(
            str(a.id),
            f"{a.path_m:.1f}",
            f"{a.homing_m:.1f}",
            str(a.charges),
            f"{a.min_battery_pct:.1f}",
            "[red]yes[/red]" if a.lost else "no",
        )
    return table


def print_summary(result: RunResult, console: Console) -> None:
    """Print the run summary and the per-agent table to ``console``."""
    console.print(_summary_table(result))
    console.print(_agents_table(result))
