"""``gcs bench plans``: compare planner settings on many generated maps.

What it measures, as the operator reads it: ``gcs bench plans --help``
(``gcs.options.bench``).
"""

from __future__ import annotations

import argparse
import contextlib
import hashlib
import math
import platform
from collections import defaultdict
from collections.abc import Iterator, Sequence
from dataclasses import asdict, dataclass
from typing import Any

from rich.console import Console
from rich.table import Table

from gcs.bench.common import (
    chosen,
    parse_settings,
    positive_numbers,
    write_json,
)
from gcs.bench.sweeps import Failed, Where, run_sweep
from gcs.console import output_console
from gcs.errors import EXIT_FAILED, EXIT_INTERRUPTED, EXIT_OK, UsageError
from gcs.generated_missions import MapMaker, case_mission
from gcs.offline.simulate import SimOptions, simulate
from gcs.planning import planner_settings
from sitl_mock import mapgen
from sitl_mock.gridmap import GridMap

#: The paper's bar maps (Table 2): this many bars on a square of this side.
PAPER_BARS, PAPER_SIDE = 13, 30


def paper_bars(height: int, width: int, seed: int) -> GridMap:
    """Bars of 4 to 9 cells as the paper's 30x30 benchmark places them, as many per
    area on a map of any size (seed 9 at 30x30 is ``missions/bob30.yaml``'s map)."""
    count = round(PAPER_BARS * height * width / PAPER_SIDE**2)
    return mapgen.bars(height, width, count=count, seed=seed)


GENERATORS: dict[str, MapMaker] = {
    "rooms": mapgen.rooms,
    "caves": mapgen.caves,
    "open": mapgen.open_field,
    "bars": paper_bars,
    "branching": mapgen.branching,
}


@dataclass(frozen=True)
class PlanCase:
    kind: str
    size: int
    agents: int
    seed: int
    #: False: no battery limit (the paper's Table 2); True: as ``gcs bench perf``.
    battery: bool = True


# -- the runs --------------------------------------------------------------------------


def run_case(case: PlanCase, overrides: dict[str, Any]) -> dict[str, Any]:
    """One run: the figures compared, and a digest of every agent's track (equal
    digests: the same plan, cell for cell)."""
    grid = GENERATORS[case.kind](case.size, case.size, case.seed)
    name = f"{case.kind}{case.size}-{case.seed}"
    mission = case_mission(grid, case.agents, name, battery=case.battery)
    settings = planner_settings(mission, 0, **overrides)
    result = simulate(mission, SimOptions(settings=settings))
    tracks = hashlib.sha256(repr([a.track for a in result.agents]).encode()).hexdigest()
    return {
        **asdict(case),
        "free_cells": result.free_cells,
        "path_per_free_cell": result.total_path_m / max(1, result.free_cells - 1),
        "iterations": result.iterations,
        "charges": sum(a.charges for a in result.agents),
        "planner_s": result.planner_s,
        "complete": result.complete,
        "lost": result.lost_agents,
        "tracks": tracks[:16],
    }


def _run(job: tuple[PlanCase, dict[str, Any]]) -> dict[str, Any]:
    case, overrides = job
    return run_case(case, overrides)


@dataclass(frozen=True)
class Finished:
    """A run as it finishes: its place in the sweep, its strategy and its row (a failed
    run's row holds its case and ``error``)."""

    index: int
    label: str
    row: dict[str, Any]


def run_all(
    cases: Sequence[PlanCase], strategies: dict[str, dict[str, Any]], where: Where
) -> Iterator[Finished]:
    """Every case under every strategy, as they finish (``gcs.bench.sweeps``)."""
    work = [(case, label, overrides) for case in cases for label, overrides in strategies.items()]
    jobs = [(case, overrides) for case, _, overrides in work]
    with contextlib.closing(run_sweep(_run, jobs, where)) as sweep:
        for index, answer in sweep:
            case, label, _ = work[index]
            row = {**asdict(case), "error": answer.error} if isinstance(answer, Failed) else answer
            yield Finished(index, label, row)


def _progress_line(done: int, total: int, label: str, row: dict[str, Any]) -> str:
    run = f"[{done}/{total}] {label}: {row['kind']} {row['size']}x{row['size']} "
    run += f"seed {row['seed']}, {row['agents']} agents: "
    if "error" in row:
        return run + f"failed: {row['error']}"
    return run + f"{row['path_per_free_cell']:.3f} m per free cell, {row['iterations']} iterations"


def _sound(row: dict[str, Any]) -> bool:
    """Ran to the end, covered its map, lost nobody."""
    return "error" not in row and row["complete"] and not row["lost"]


# -- the comparison --------------------------------------------------------------------


def geometric_mean(values: Sequence[float]) -> float:
    return math.exp(sum(math.log(v) for v in values) / len(values))


def _key(row: dict[str, Any]) -> tuple[str, int, int, int]:
    return row["kind"], row["size"], row["agents"], row["seed"]


def compare(base: list[dict[str, Any]], variant: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Per case run under both: the variant's ratios to the base, and whether the plan
    is the same."""
    by_case = {_key(row): row for row in base}
    pairs = []
    for row in sorted(variant, key=_key):
        was = by_case.get(_key(row))
        if was is None or "error" in was or "error" in row:
            continue  # interrupted before the base run of this case, or a run failed
        pairs.append(
            {
                **{k: row[k] for k in ("kind", "size", "agents", "seed")},
                "path_ratio": row["path_per_free_cell"] / was["path_per_free_cell"],
                "iterations_ratio": row["iterations"] / was["iterations"],
                "planner_s_ratio": row["planner_s"] / max(was["planner_s"], 1e-9),
                "same_plan": row["tracks"] == was["tracks"],
            }
        )
    return pairs


def summarise(pairs: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Geometric means of the ratios by map kind, size and fleet, then over all."""
    groups: dict[str, list[dict[str, Any]]] = defaultdict(list)
    for p in pairs:
        groups[f"{p['kind']} {p['size']}x{p['size']}, {p['agents']} agents"].append(p)
    groups["all"] = pairs
    return [
        {
            "group": name,
            "runs": len(members),
            "path_ratio": geometric_mean([p["path_ratio"] for p in members]),
            "iterations_ratio": geometric_mean([p["iterations_ratio"] for p in members]),
            "planner_s_ratio": geometric_mean([p["planner_s_ratio"] for p in members]),
            "same_plans": sum(p["same_plan"] for p in members),
        }
        for name, members in groups.items()
    ]


def runs_table(rows: dict[str, list[dict[str, Any]]], pairs: list[dict[str, Any]]) -> Table:
    """A row per case: each strategy's path per free cell and iterations (and with a
    variant, its ratios to the base and whether the plan is the same)."""
    table = Table(title="runs (path: metres per free cell)")
    table.add_column("map")
    for name in ("seed", "agents"):
        table.add_column(name, justify="right")
    for label in rows:
        for name in ("path", "iterations"):
            table.add_column(f"{label} {name}", justify="right")
    compared = len(rows) > 1
    if compared:
        for name in ("path ratio", "iterations ratio", "same plan"):
            table.add_column(name, justify="right")
    by_label = {label: {_key(r): r for r in found} for label, found in rows.items()}
    ratios = {_key(p): p for p in pairs}
    everywhere = set.intersection(*(set(found) for found in by_label.values()))
    for key in sorted(everywhere):
        kind, size, agents, seed = key
        cells = [f"{kind} {size}x{size}", str(seed), str(agents)]
        for found in by_label.values():
            r = found[key]
            if "error" in r:
                cells += ["[red]failed[/]", ""]
                continue
            path = f"{r['path_per_free_cell']:.3f}"
            if not r["complete"]:
                path += " [red]incomplete[/]"
            if r["lost"]:
                path += f" [red]{r['lost']} lost[/]"
            cells += [path, str(r["iterations"])]
        p = ratios.get(key)
        if p is not None:
            same = "yes" if p["same_plan"] else "no"
            cells += [f"{p['path_ratio']:.3f}", f"{p['iterations_ratio']:.3f}", same]
        elif compared:
            cells += ["", "", ""]  # not run under both
        table.add_row(*cells)
    return table


def summary_table(summary: list[dict[str, Any]]) -> Table:
    table = Table(title="variant / base, geometric means")
    table.add_column("group")
    for name in ("runs", "path", "iterations", "planner s", "same plans"):
        table.add_column(name, justify="right")
    for s in summary:
        table.add_row(
            s["group"],
            str(s["runs"]),
            f"{s['path_ratio']:.3f}",
            f"{s['iterations_ratio']:.3f}",
            f"{s['planner_s_ratio']:.2f}",
            f"{s['same_plans']}/{s['runs']}",
        )
    return table


def _cases(args: argparse.Namespace) -> list[PlanCase]:
    kinds = chosen(args.kinds, "kinds", list(GENERATORS))
    if args.jobs < 1:
        raise UsageError("--jobs must be at least 1")
    sizes = positive_numbers(args.sizes, "sizes")
    if min(sizes) < mapgen.MIN_SIZE:
        raise UsageError(f"--sizes: maps are at least {mapgen.MIN_SIZE} cells a side")
    return [
        PlanCase(kind, size, agents, seed, battery=args.battery == "limited")
        for kind in kinds
        for size in sizes
        for agents in positive_numbers(args.agents, "agents")
        for seed in positive_numbers(args.seeds, "seeds")
    ]


def _sweep(
    cases: list[PlanCase], strategies: dict[str, dict[str, Any]], where: Where
) -> tuple[dict[str, list[dict[str, Any]]], bool]:
    """Every run's row by strategy, in the order of the cases whatever order they
    finished in, and whether Ctrl-C stopped the sweep (the finished runs are kept)."""
    progress = Console(stderr=True)
    finished: list[Finished] = []
    total = len(cases) * len(strategies)
    interrupted = False
    try:
        for run in run_all(cases, strategies, where):
            finished.append(run)
            line = _progress_line(len(finished), total, run.label, run.row)
            progress.print(line, soft_wrap=True, highlight=False)
    except KeyboardInterrupt:
        interrupted = True
        progress.print(f"interrupted: {len(finished)} runs finished are kept", highlight=False)
    rows: dict[str, list[dict[str, Any]]] = {label: [] for label in strategies}
    for run in sorted(finished, key=lambda run: run.index):
        rows[run.label].append(run.row)
    return rows, interrupted


def run_plans(args: argparse.Namespace) -> int:
    cases = _cases(args)
    base = parse_settings(args.base, "base")
    strategies = {"base": base}
    if args.changes:
        strategies["variant"] = base | parse_settings(args.changes, "set")
    console = output_console(quiet=False)
    rows, interrupted = _sweep(cases, strategies, Where(args.jobs, args.scheduler))
    pairs = compare(rows["base"], rows["variant"]) if "variant" in rows else []
    console.print(runs_table(rows, pairs))
    figures: dict[str, Any] = {
        "machine": platform.platform(),
        "strategies": {label: {k: str(v) for k, v in s.items()} for label, s in strategies.items()},
        "battery": args.battery,
        "runs": rows,
        "interrupted": interrupted,
    }
    if pairs:
        figures["pairs"] = pairs
        figures["summary"] = summarise(pairs)
        console.print(summary_table(figures["summary"]))
    write_json(args.json, figures, console)
    if interrupted:
        return EXIT_INTERRUPTED
    ok = all(_sound(r) for found in rows.values() for r in found)
    return EXIT_OK if ok else EXIT_FAILED
