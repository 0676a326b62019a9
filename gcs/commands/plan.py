"""``gcs plan``: the planner alone against a simulated world, fast, for studies."""

from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

from rich.console import Console
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

from gcs.console import output_console
from gcs.errors import EXIT_FAILED, EXIT_OK, UsageError
from gcs.log.log_process import LogProcess
from gcs.log.mcap_log import LoggedMission
from gcs.log.mission_log import MissionLog
from gcs.mission import Mission, MissionError, load_mission
from gcs.offline.simulate import SimOptions, simulate
from gcs.outcome.figures import write_figures
from gcs.outcome.report import print_summary, write_report
from gcs.outcome.result import RunResult
from gcs.planning import planner_settings
from gcs.preflight import check_range
from planner.settings import BmRule, TargetPolicy

#: The mission log's file name in ``--out``.
LOG_NAME = "mission.mcap"
#: Runs shorter than this many free cells finish before a progress bar is worth showing.
PROGRESS_MIN_CELLS = 5000


def load(args: argparse.Namespace) -> Mission:
    try:
        mission = load_mission(args.mission)
        if args.agents is not None:
            mission = mission.with_agents(args.agents)
    except MissionError as exc:
        raise UsageError(str(exc)) from exc
    return mission


def strategy_overrides(args: argparse.Namespace) -> dict[str, object]:
    overrides: dict[str, object] = {}
    if args.bm:
        overrides["bm_rule"] = BmRule(args.bm)
    if args.targets:
        overrides["target_policy"] = TargetPolicy(args.targets)
    if args.no_spread:
        overrides["spread"] = False
    if args.no_top_up:
        overrides["top_up_ratio"] = 0.0
    return overrides


def run(args: argparse.Namespace) -> int:
    mission = load(args)
    if args.path_planner:
        mission = dataclasses.replace(
            mission,
            planner=dataclasses.replace(mission.planner, path_planner=args.path_planner),
        )
    console = output_console(quiet=args.quiet)
    errors = Console(stderr=True, quiet=args.quiet)
    reach = check_range(mission)
    if reach.out_of_range:
        errors.print(f"[yellow]warning:[/] {reach.message()}")
    settings = planner_settings(mission, args.seed, **strategy_overrides(args))
    log = open_plan_log(mission, args.out) if args.out else None
    options = SimOptions(seed=args.seed, settings=settings, timed=args.timed)
    result = simulate_with_progress(mission, options, errors, log)
    if log is not None and log.failure is not None:  # simulate closed it
        print(f"gcs plan: warning: {log.failure}", file=sys.stderr)
    print_summary(result, console)
    if args.out:
        save_outputs(result, args.out, console, "plan")
    return EXIT_OK if result.complete else EXIT_FAILED


def save_outputs(result: RunResult, out: Path, console: Console, command: str) -> None:
    """report.json and the figures; one that cannot be written is a warning (the run's
    outcome is what it is whatever the disk says)."""
    try:
        write_outputs(result, out)
    except (OSError, UsageError) as exc:
        reason = getattr(exc, "strerror", None) or str(exc)
        print(
            f"gcs {command}: warning: outputs not all written to {out}: {reason}", file=sys.stderr
        )
        return
    console.print(f"wrote {out}/report.json, figures and {LOG_NAME}")


def open_plan_log(mission: Mission, out: Path) -> LogProcess:
    """The offline run's MCAP log in ``out`` (created), written by a process of its own
    while the planner plans."""
    try:
        out.mkdir(parents=True, exist_ok=True)
        return LogProcess(out / LOG_NAME, LoggedMission.of(mission, mission.reachable_cells))
    except OSError as exc:
        raise UsageError(f"--out: cannot write to {out}: {exc.strerror}") from exc


def simulate_with_progress(
    mission: Mission, options: SimOptions, console: Console, log: MissionLog | None = None
) -> RunResult:
    """Simulate, with a progress bar on the console for long runs."""
    free = int(mission.map.reachable().sum()) if mission.map.is_free(mission.charger) else 0
    if free < PROGRESS_MIN_CELLS or not console.is_terminal:
        return simulate(mission, options, log=log)
    with Progress(
        TextColumn("[bold]{task.description}"),
        BarColumn(),
        TextColumn("{task.completed}/{task.total} cells"),
        TextColumn("iteration {task.fields[iteration]}"),
        TimeElapsedColumn(),
        console=console,
        transient=True,
    ) as bar:
        task = bar.add_task(f"covering {mission.name}", total=free, iteration=0)

        def tick(iteration: int, covered: int, total: int) -> None:
            if iteration % 50 == 0:
                bar.update(task, completed=covered, iteration=iteration)

        return simulate(mission, options, progress=tick, log=log)


def write_outputs(result: RunResult, out: Path) -> None:
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise UsageError(f"--out: cannot create {out}: {exc.strerror}") from exc
    write_report(result, out)
    write_figures(result, out)
