"""``gcs bench``: benchmarks that measure and print figures (never timed tests).

``gcs bench paper`` reproduces the paper's Table 1 (scenario 1 with 1 to 11
agents: charges, iterations counted both ways (every move, and a planned path
as one: ``path_iterations``), compute time per step) and Table 2 (the 30x30
comparison with NB-MSTC and BoB, 4 agents, no battery limit) on our maps,
beside the paper's figures, with normalised ratios (docs/algorithm.md) so
that maps of slightly different size compare fairly.
"""

from __future__ import annotations

import argparse
import contextlib
import math
import platform
from dataclasses import dataclass
from pathlib import Path

from rich.console import Console
from rich.table import Table

from gcs.bench.common import write_json
from gcs.bench.sweeps import Failed, Where, run_sweep
from gcs.console import output_console
from gcs.errors import EXIT_FAILED, EXIT_OK, UsageError
from gcs.mission import Mission, MissionError, load_mission
from gcs.offline.simulate import SimOptions, simulate
from gcs.outcome.result import RunResult
from gcs.planning import planner_settings
from planner.settings import BmRule, PlannerSettings, TargetPolicy

#: The paper's Table 1 (scenario 1, 2068 m2): agents -> (charges per agent, s per step, iterations).
PAPER_TABLE1 = {
    1: (22, 0.13, 2365),
    3: (7, 0.36, 804),
    5: (5, 0.59, 491),
    7: (3, 0.81, 363),
    9: (3, 1.09, 314),
    11: (2, 1.39, 259),
}
PAPER_SCENARIO1_FREE = 2068
#: The paper's Table 2 (30x30, 4 agents): method -> path per agent (m), complete.
PAPER_TABLE2 = {
    "NB-MSTC": ((172, 400, 24, 21), False),
    "BoB": ((199, 215, 224, 233), True),
    "paper": ((171, 187, 178, 180), True),
}


@dataclass(frozen=True)
class Strategy:
    name: str
    overrides: dict[str, object]


#: The paper's rules as we read them first.
PAPER_RULES: dict[str, object] = {
    "bm_rule": BmRule.PAPER,
    "target_policy": TargetPolicy.OWN_FIRST,
    "spread": False,
    "replan_transit": False,
    "top_up_ratio": 0.0,
}

#: Our default planner, the paper's rules run by our code, and the reading of them
#: nearest the paper's Table 2 (docs/performance.md, "Reproducing the paper"): an
#: agent on its way decides again at every step, as Algorithm 4 runs Algorithm 3
#: at the top of every loop, and one without a BTP waits while others work.
STRATEGIES = (
    Strategy("ours", {}),
    Strategy("paper rules", PAPER_RULES),
    Strategy("paper, closest", PAPER_RULES | {"replan_transit": True, "net_when_alone": True}),
)


def _load(path: Path) -> Mission:
    try:
        return load_mission(path)
    except MissionError as exc:
        raise UsageError(str(exc)) from exc


def _settings(mission: Mission, strategy: Strategy) -> PlannerSettings:
    return planner_settings(mission, 0, **strategy.overrides)


def normalised(result: RunResult) -> dict[str, float]:
    agents = len(result.agents)
    work = max(1, result.free_cells - 1)
    return {
        "path_ratio": result.total_path_m / result.cell_size_m / work,
        "makespan_ratio": result.makespan_m / result.cell_size_m / math.ceil(work / agents),
        "iteration_ratio": result.iterations * agents / max(1, result.free_cells),
    }


#: A run's answer: its result, or how it failed.
Outcome = RunResult | Failed


@dataclass(frozen=True)
class PaperCase:
    """One run of the tables: the mission (with its fleet) under a strategy."""

    table: int
    mission: Mission
    strategy: Strategy


def _run(case: PaperCase) -> RunResult:
    return simulate(case.mission, SimOptions(settings=_settings(case.mission, case.strategy)))


def _run_all(cases: list[PaperCase], where: Where) -> list[Outcome]:
    """Every case's outcome, in the cases' order; a line on stderr as each finishes."""
    progress = Console(stderr=True)
    outcomes: dict[int, Outcome] = {}
    with contextlib.closing(run_sweep(_run, cases, where)) as sweep:
        for index, outcome in sweep:
            outcomes[index] = outcome
            case = cases[index]
            line = f"[{len(outcomes)}/{len(cases)}] Table {case.table}, "
            line += f"{len(case.mission.fleet)} agents, {case.strategy.name}: "
            line += f"failed: {outcome.error}" if isinstance(outcome, Failed) else "done"
            progress.print(line, soft_wrap=True, highlight=False)
    return [outcomes[index] for index in range(len(cases))]


def run_paper(args: argparse.Namespace) -> int:
    if args.jobs < 1:
        raise UsageError("--jobs must be at least 1")
    console = output_console()
    scenario = _load(args.missions / "scenario1.yaml")
    bob = _load(args.missions / "bob30.yaml").with_agents(4)
    figures: dict[str, object] = {"machine": platform.processor() or platform.machine()}
    cases = [PaperCase(1, scenario.with_agents(n), s) for n in args.agents for s in STRATEGIES]
    cases += [PaperCase(2, bob, s) for s in STRATEGIES]
    outcomes = _run_all(cases, Where(args.jobs, args.scheduler))
    first = len(args.agents) * len(STRATEGIES)
    table1, rows1, ok1 = _table1(scenario, args.agents, outcomes[:first])
    console.print(table1)
    figures["table1"] = rows1
    table2, rows2, ok2, bob_free = _table2(bob, outcomes[first:])
    console.print(table2)
    console.print(
        f"* the paper's map is not published; its ratios use our map's {bob_free} free cells."
    )
    figures["table2"] = rows2
    ok = ok1 and ok2
    write_json(args.json, figures, console)
    return EXIT_OK if ok else EXIT_FAILED


TABLE1_COLUMNS = (
    "agents",
    "strategy",
    "charges/agent",
    "paper",
    "iterations: moves / paths",
    "paper",
    "/ paper",
    "path / (free-1)",
    "makespan ratio",
    "planner s",
    "ms / step",
    "paper s / step",
    "x faster / step",
    "us / agent-step",
    "complete",
    "lost",
)


def _table1(
    scenario: Mission, agents: list[int], outcomes: list[Outcome]
) -> tuple[Table, list[dict[str, object]], bool]:
    """Table 1: scenario 1 with each number of agents and strategy (``outcomes`` in that
    order), beside the paper's figures; its rows for ``--json``, and whether every run
    completed."""
    energy = scenario.fleet[0].energy_per_m_pct if scenario.fleet else 0.0
    table = Table(
        title=(
            f"Table 1: {scenario.name}, {scenario.map.reachable().sum()} free cells "
            f"(paper {PAPER_SCENARIO1_FREE} m2), energy {energy} %/m, reserve "
            f"{scenario.planner.reserve_pct:g} %"
        ),
        caption=(
            "iterations: every move one / a planned path (to a target or the charger) one, "
            "a sweep step one; until coverage is complete"
        ),
    )
    for column in TABLE1_COLUMNS:
        table.add_column(column, justify="right")
    rows: list[dict[str, object]] = []
    ok = True
    runs = iter(outcomes)
    for n in agents:
        for strategy in STRATEGIES:
            result = next(runs)
            if isinstance(result, Failed):
                ok = False
                table.add_row(str(n), strategy.name, f"[red]failed: {result.error}[/]")
                rows.append({"agents": n, "strategy": strategy.name, "error": result.error})
                continue
            ok &= result.complete
            rows.append(_table1_row(table, n, strategy, result))
    return table, rows, ok


def _table1_row(table: Table, n: int, strategy: Strategy, result: RunResult) -> dict[str, object]:
    """One run of Table 1: its row added to ``table``, and returned for ``--json``."""
    norm = normalised(result)
    charges = sum(a.charges for a in result.agents) / n
    paper = PAPER_TABLE1.get(n)
    steps = int(result.extra.get("total_iterations", 1))
    ms_step = 1e3 * result.planner_s / max(1, steps)
    us_agent_step = 1e6 * result.planner_s / max(1, steps * n)
    path_iterations = int(result.extra.get("path_iterations", 0))
    table.add_row(
        str(n),
        strategy.name,
        f"{charges:.1f}",
        str(paper[0]) if paper else "-",
        f"{result.iterations} / {path_iterations}",
        str(paper[2]) if paper else "-",
        f"{result.iterations / paper[2]:.2f} / {path_iterations / paper[2]:.2f}" if paper else "-",
        f"{norm['path_ratio']:.3f}",
        f"{norm['makespan_ratio']:.3f}",
        f"{result.planner_s:.3f}",
        f"{ms_step:.3f}",
        f"{paper[1]:.2f}" if paper else "-",
        f"{1e3 * paper[1] / ms_step:.0f}" if paper and ms_step > 0 else "-",
        f"{us_agent_step:.1f}",
        "yes" if result.complete else "[red]NO[/]",
        str(result.lost_agents),
    )
    return {
        "agents": n,
        "strategy": strategy.name,
        "charges_per_agent": charges,
        "iterations": result.iterations,
        "path_iterations": path_iterations,
        "planner_s": result.planner_s,
        "us_per_agent_step": us_agent_step,
        "complete": result.complete,
        "lost": result.lost_agents,
        "btps_detected": result.extra.get("btps_detected"),
        "safety_net_fires": result.safety_net_fires,
        **norm,
    }


TABLE2_COLUMNS = (
    "method",
    "agent paths (m)",
    "total (m)",
    "path / (free-1)",
    "longest/shortest",
    "complete",
    "BTPs",
    "safety net",
)


def _table2(
    bob: Mission, outcomes: list[Outcome]
) -> tuple[Table, list[dict[str, object]], bool, int]:
    """Table 2: the 30x30 map with 4 agents and no battery limit, each strategy
    (``outcomes`` in that order) beside the paper's methods; its rows, whether every run
    completed, and the free cells."""
    table = Table(title=f"Table 2: {bob.name}, 4 agents, no battery limit")
    for column in TABLE2_COLUMNS:
        table.add_column(column, justify="right")
    bob_free = int(bob.map.reachable().sum())
    for method, (paper_paths, complete) in PAPER_TABLE2.items():
        table.add_row(
            f"{method} (paper's figures)",
            " / ".join(map(str, paper_paths)),
            str(sum(paper_paths)),
            f"{sum(paper_paths) / (bob_free - 1):.3f}*",
            f"{max(paper_paths) / min(paper_paths):.2f}",
            "yes" if complete else "no",
            "-",
            "-",
        )
    rows: list[dict[str, object]] = []
    ok = True
    for strategy, result in zip(STRATEGIES, outcomes, strict=True):
        if isinstance(result, Failed):
            ok = False
            table.add_row(f"{strategy.name} (ours)", f"[red]failed: {result.error}[/]")
            rows.append({"strategy": strategy.name, "error": result.error})
            continue
        ok &= result.complete
        paths = [a.path_m for a in result.agents]
        table.add_row(
            f"{strategy.name} (ours)",
            " / ".join(f"{p:.0f}" for p in paths),
            f"{result.total_path_m:.0f}",
            f"{normalised(result)['path_ratio']:.3f}",
            f"{max(paths) / max(1e-9, min(paths)):.2f}",
            "yes" if result.complete else "[red]NO[/]",
            str(result.extra.get("btps_detected")),
            str(result.safety_net_fires),
        )
        rows.append(
            {
                "strategy": strategy.name,
                "paths_m": paths,
                "total_m": result.total_path_m,
                "balance": max(paths) / max(1e-9, min(paths)),
                "complete": result.complete,
                **normalised(result),
            }
        )
    return table, rows, ok, bob_free
