"""``gcs bench perf``: how the planner and the live ground station scale.

What it measures, as the operator reads it: ``gcs bench perf --help``
(``gcs.options.bench``).
"""

from __future__ import annotations

import argparse
import multiprocessing
import platform
import resource
import tempfile
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from multiprocessing.connection import Connection
from pathlib import Path
from typing import Any

from rich.console import Console
from rich.table import Table

from gcs.bench.common import chosen, parse_settings, positive_numbers, write_json
from gcs.bench.machine_pace import reference_seconds
from gcs.bench.perf_live import live_table, run_live_case, web_pairs, web_table
from gcs.bench.perf_log import Goal, log_goals, log_pairs, log_table
from gcs.console import output_console
from gcs.errors import EXIT_FAILED, EXIT_OK, UsageError
from gcs.generated_missions import GENERATORS, MAP_SEED, case_mission
from gcs.log.log_process import LogProcess
from gcs.log.mcap_log import LoggedMission
from gcs.offline.simulate import SimOptions, simulate
from gcs.options.bench import PERF_LINKS
from gcs.planning import planner_settings
from planner import native

#: A logged planner case's log file (in a folder of its own, removed after the case).
LOG_FILE = "mission.mcap"
#: Wall seconds between a planner case's reports of its coverage so far.
PROGRESS_EVERY_S = 1.0
#: The scaling goals, judged on the figures of the cases that measure them: the
#: planner on a map this many cells a side with this many agents, complete with
#: none lost, under these wall seconds and peak megabytes; the live ground
#: station with this many vehicles, complete with none lost, under this decision
#: latency at the 99th percentile.
GOAL_SIDE, GOAL_AGENTS, GOAL_WALL_S, GOAL_PEAK_MB = 1000, 50, 60.0, 2048
GOAL_VEHICLES, GOAL_P99_MS = 64, 20.0
#: The web page watched by several clients may cost the live mission at most this much
#: decision latency (p99, with over without).
GOAL_WEB_RATIO = 1.10
#: Map kinds judged against the planner's goal as a stretch beyond the goal's own
#: maps (rooms and corridors, open ground): the maze, whose ways are 7 times the
#: Manhattan distance.
STRETCH_KINDS = frozenset({"rooms"})
#: The maze's own goal (the stretch kinds, at the goal's size and crowd): under these
#: wall seconds, walking under these metres per free cell (a crowd that divides the
#: maze's branches well, where one that does not walks it several times over).
GOAL_MAZE_WALL_S, GOAL_MAZE_M_PER_CELL = 100.0, 2.5


# -- the offline planner ---------------------------------------------------------------


@dataclass(frozen=True)
class PlannerCase:
    kind: str
    size: int
    agents: int
    #: Planner settings other than the defaults, as (name, value) pairs.
    settings: tuple[tuple[str, Any], ...] = ()
    #: Written to a mission log, as ``gcs plan --out`` does.
    log: bool = False

    def figures(self) -> dict[str, Any]:
        return {**asdict(self), "settings": dict(self.settings)}


def _run_case(case: PlannerCase, out: Connection, folder: Path) -> None:
    """In a child process: generate, simulate, send back the figures (and, every
    ``PROGRESS_EVERY_S`` meanwhile, the coverage so far: a case stopped at its limit
    is reported with how far it got). A logged case writes its log in ``folder``."""
    t0 = time.perf_counter()
    grid = GENERATORS[case.kind](case.size, case.size, MAP_SEED)
    mission = case_mission(grid, case.agents, f"{case.kind}{case.size}")
    settings = planner_settings(mission, 0, **dict(case.settings))
    setup_s = time.perf_counter() - t0
    next_report = time.perf_counter()

    def report(iteration: int, covered: int, free: int) -> None:
        nonlocal next_report
        if time.perf_counter() >= next_report:
            next_report += PROGRESS_EVERY_S
            out.send({"iterations": iteration, "coverage_pct": round(100 * covered / free, 2)})

    log = None
    if case.log:
        free = mission.reachable_cells
        log = LogProcess(folder / LOG_FILE, LoggedMission.of(mission, free))
    started = time.perf_counter()
    result = simulate(mission, SimOptions(settings=settings), progress=report, log=log)
    run_s = time.perf_counter() - started  # with the log's last writes and its close
    steps = max(1, result.iterations * case.agents)
    out.send(
        {
            "done": True,
            **case.figures(),
            "free_cells": result.free_cells,
            "setup_s": round(setup_s, 2),
            "wall_s": round(result.wall_s, 2),
            "run_s": round(run_s, 2),
            "log_bytes": (folder / LOG_FILE).stat().st_size if case.log else None,
            "planner_s": round(result.planner_s, 2),
            "us_per_agent_step": round(1e6 * result.planner_s / steps, 1),
            "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss // 1024,
            # The log's writer: a process of its own, ended by the log's close.
            **(_writer_figures() if case.log else {}),
            "coverage_pct": round(result.coverage_pct, 2),
            "lost": result.lost_agents,
            "total_path_m": result.total_path_m,
            "path_per_free_cell": round(result.total_path_m / max(1, result.free_cells - 1), 3),
            "iterations": result.iterations,
            "charges": sum(a.charges for a in result.agents),
        }
    )
    out.close()


def _writer_figures() -> dict[str, float]:
    """The log writer's peak memory and processor time (the case's only child)."""
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return {
        "log_peak_mb": usage.ru_maxrss // 1024,
        "log_cpu_s": round(usage.ru_utime + usage.ru_stime, 2),
    }


#: The map side and fleet of the runs that compile the planner before the cases.
WARM_UP_SIDE = 100
WARM_UP_AGENTS = 10


def compile_planner(kinds: list[str], settings: dict[str, Any]) -> None:
    """Run the planner on a small map of each kind in this process, so that every
    compiled function the cases use is compiled (or loaded from numba's cache)
    before they fork: after an update numba's cache is stale, and each case
    would compile again and count that in its time."""
    for kind in kinds:
        grid = GENERATORS[kind](WARM_UP_SIDE, WARM_UP_SIDE, MAP_SEED)
        mission = case_mission(grid, WARM_UP_AGENTS, f"warm-up-{kind}")
        simulate(mission, SimOptions(settings=planner_settings(mission, 0, **settings)))


def run_planner_case(case: PlannerCase, limit_s: float) -> dict[str, Any]:
    """One case in a fresh child process, stopped after ``limit_s`` wall seconds."""
    context = multiprocessing.get_context("fork")
    receive, send = context.Pipe(duplex=False)
    folder = tempfile.TemporaryDirectory(prefix="gcs-perf-")
    # Not a daemon: a logged case starts its log's writer (``gcs plan --out`` does); it
    # is ended below whatever happens.
    child = context.Process(target=_run_case, args=(case, send, Path(folder.name)), daemon=False)
    child.start()
    send.close()
    deadline = time.perf_counter() + limit_s
    so_far: dict[str, Any] = {}
    try:
        while receive.poll(max(0.0, deadline - time.perf_counter())):
            try:
                message = receive.recv()
            except EOFError:
                return {**case.figures(), "error": "the case failed (see stderr)"}
            if message.pop("done", False):
                return message
            so_far = message
        return {**case.figures(), **so_far, "error": f"over {limit_s:g} s"}
    finally:
        if child.is_alive():
            child.terminate()
        child.join(5)
        receive.close()
        folder.cleanup()


def settings_text(settings: dict[str, Any]) -> str:
    """Planner settings as a table title or a goal names them: ", key value" each."""
    return "".join(f", {key} {value}" for key, value in settings.items())


def planner_table(rows: list[dict[str, Any]], settings: dict[str, Any] | None = None) -> Table:
    title = "offline planner (one process per case)" + settings_text(settings or {})
    table = Table(title=title)
    for name in (
        "map",
        "free cells",
        "agents",
        "wall s",
        "planner s",
        "us/agent-step",
        "peak MB",
        "coverage %",
        "lost",
        "path m",
        "path/free",
        "charges",
    ):
        table.add_column(name, justify="left" if name == "map" else "right")
    for r in rows:
        label = f"{r['kind']} {r['size']}x{r['size']}" + (" +log" if r.get("log") else "")
        if "error" in r:
            reached = f"{r['coverage_pct']:.1f}" if "coverage_pct" in r else ""
            table.add_row(label, "", str(r["agents"]), r["error"], *[""] * 3, reached, *[""] * 4)
            continue
        table.add_row(
            label,
            str(r["free_cells"]),
            str(r["agents"]),
            f"{r['wall_s']:.2f}",
            f"{r['planner_s']:.2f}",
            f"{r['us_per_agent_step']:.1f}",
            str(r["peak_mb"]),
            f"{r['coverage_pct']:.1f}",
            str(r["lost"]),
            f"{r['total_path_m']:.0f}",
            f"{r['path_per_free_cell']:.3f}",
            str(r["charges"]),
        )
    return table


def _complete(row: dict[str, Any]) -> bool:
    return "error" not in row and row["coverage_pct"] >= 100 and not row["lost"]


def goals(planner_rows: list[dict[str, Any]], live_rows: list[dict[str, Any]]) -> list[Goal]:
    """The scaling goals that these figures measure, each met or not."""
    found = []
    for r in planner_rows:
        if (r["size"], r["agents"]) != (GOAL_SIDE, GOAL_AGENTS) or r.get("log"):
            continue  # the goal is the planner's; the log's is judged on its pairs
        found += _planner_goals(r)
    for r in live_rows:
        if r["vehicles"] != GOAL_VEHICLES or r.get("web_clients"):
            continue
        what = (
            f"live, {GOAL_VEHICLES} vehicles ({r['links']} link): complete, none lost, "
            f"decision latency p99 under {GOAL_P99_MS:g} ms"
        )
        found.append(
            _judged(
                what,
                r,
                lambda r: (f"p99 {r['latency_ms_p99']:.2f} ms", r["latency_ms_p99"] < GOAL_P99_MS),
            )
        )
    for pair in web_pairs(live_rows):
        if pair["vehicles"] != GOAL_VEHICLES or pair["ratio"] is None:
            continue
        found.append(
            Goal(
                f"live, {GOAL_VEHICLES} vehicles ({pair['links']} link) with "
                f"{pair['web_clients']} web clients: decision latency p99 within "
                f"{100 * (GOAL_WEB_RATIO - 1):.0f} % of the same run without the page",
                f"median p99 {pair['median_p99_ms_with']:.2f} ms against "
                f"{pair['median_p99_ms_without']:.2f} ms (x{pair['ratio']:.3f}) over "
                f"{pair['runs']} run(s) each, {pair['web_dropped']} clients dropped",
                pair["ratio"] <= GOAL_WEB_RATIO and pair["web_dropped"] == 0,
            )
        )
    return found


def _planner_goals(r: dict[str, Any]) -> list[Goal]:
    """A planner case's goal, and the maze's own for the stretch kinds."""
    size, settings = f"{GOAL_SIDE}x{GOAL_SIDE}", settings_text(r.get("settings", {}))
    found = [
        _judged(
            f"planner, {r['kind']} {size}, {GOAL_AGENTS} agents{settings}: complete, none "
            f"lost, under {GOAL_WALL_S:g} s and {GOAL_PEAK_MB} MB",
            r,
            lambda r: (
                f"{r['wall_s']:.1f} s, {r['peak_mb']} MB",
                r["wall_s"] < GOAL_WALL_S and r["peak_mb"] < GOAL_PEAK_MB,
            ),
            stretch=r["kind"] in STRETCH_KINDS,
        )
    ]
    if r["kind"] in STRETCH_KINDS:
        found.append(
            _judged(
                f"planner, the maze ({r['kind']} {size}), {GOAL_AGENTS} agents{settings}: "
                f"complete, none lost, under {GOAL_MAZE_WALL_S:g} s and "
                f"{GOAL_MAZE_M_PER_CELL:g} m per free cell",
                r,
                lambda r: (
                    f"{r['wall_s']:.1f} s, {r['path_per_free_cell']:.3f} m per free cell",
                    r["wall_s"] < GOAL_MAZE_WALL_S
                    and r["path_per_free_cell"] < GOAL_MAZE_M_PER_CELL,
                ),
            )
        )
    return found


def _judged(
    what: str,
    row: dict[str, Any],
    figures: Callable[[dict[str, Any]], tuple[str, bool]],
    stretch: bool = False,
) -> Goal:
    """``figures``: the row's own measure of the goal, and whether it is within it."""
    if "error" in row:
        return Goal(what, row["error"], False, stretch)
    measured, within = figures(row)
    covered = f"{row['coverage_pct']:.1f} % covered, {row['lost']} lost, {measured}"
    return Goal(what, covered, _complete(row) and within, stretch)


def goals_table(found: list[Goal]) -> Table:
    table = Table(title="scaling goals, judged on these figures")
    for name in ("goal", "measured", "met"):
        table.add_column(name)
    for goal in found:
        met = "yes" if goal.met else "NO"
        table.add_row(goal.what, goal.measured, f"{met} (stretch)" if goal.stretch else met)
    if any(goal.stretch for goal in found):
        table.caption = "stretch: the maze, beyond the goal's maps (rooms and corridors, open)"
    return table


def planner_build() -> str:
    """How the planner runs, for the figures: compiled, or Python and why."""
    if native.compiled():
        return "compiled (mypyc: " + ", ".join(native.COMPILED) + ")"
    changed = native.stale()
    if changed:
        return "Python: " + ", ".join(changed) + " changed since the build (pip install -e .)"
    return "Python (installed without compiling: STAYING_ALIVE_PURE, or no C compiler)"


@dataclass(frozen=True)
class _PerfCases:
    """The cases ``gcs bench perf`` was asked for, checked before anything runs."""

    kinds: list[str]
    sizes: list[int]
    agents: list[int]
    vehicles: list[int]
    settings: dict[str, Any]
    #: Each planner case without its log, with it, or both (in that order).
    logs: tuple[bool, ...]

    @classmethod
    def of(cls, args: argparse.Namespace) -> _PerfCases:
        return cls(
            sizes=positive_numbers(args.sizes, "sizes"),
            agents=positive_numbers(args.agents, "agents"),
            vehicles=positive_numbers(args.vehicles, "vehicles"),
            kinds=chosen(args.kinds, "kinds", list(GENERATORS)),
            settings=parse_settings(args.changes, "set"),
            logs={"off": (False,), "on": (True,), "both": (False, True)}[args.log],
        )


def run_perf(args: argparse.Namespace) -> int:
    cases = _PerfCases.of(args)
    if args.live_speedup <= 0 or args.case_limit <= 0 or args.live_time_limit <= 0:
        raise UsageError("--live-speedup, --case-limit and --live-time-limit must be positive")
    if args.web_clients < 0 or args.repeat < 1:
        raise UsageError("--web-clients must be 0 or more, --repeat 1 or more")
    console = output_console(quiet=False)
    progress = Console(stderr=True)
    pace_s = reference_seconds()
    figures: dict[str, Any] = {
        "machine": platform.platform(),
        "python": platform.python_version(),
        "reference_s": round(pace_s, 3),
        "planner_compiled": native.compiled(),
    }
    console.print(
        f"machine pace: the reference workload took {pace_s:.3f} s "
        "(gcs/bench/machine_pace.py; compare figures only at like paces)"
    )
    console.print(f"planner: {planner_build()}")
    planner_rows: list[dict[str, Any]] = []
    logged: list[dict[str, Any]] = []
    live_rows: list[dict[str, Any]] = []
    if not args.skip_planner:
        planner_rows = _planner_rows(cases, args.case_limit, progress)
        figures["planner"] = planner_rows
        console.print(planner_table(planner_rows, cases.settings))
        logged = log_pairs(planner_rows)
        if logged:
            figures["log"] = logged
            console.print(log_table(logged))
    if not args.skip_live:
        live_rows = _live_rows(cases, args, progress)
        figures["live"] = {"speedup": args.live_speedup, "runs": live_rows}
        console.print(live_table(live_rows, args.live_speedup))
        pairs = web_pairs(live_rows)
        if pairs:
            figures["web"] = pairs
            console.print(web_table(pairs))
    found = goals(planner_rows, live_rows) + log_goals(logged, GOAL_SIDE)
    if found:
        figures["goals"] = [asdict(goal) for goal in found]
        console.print(goals_table(found))
    write_json(args.json, figures, console)
    ok = all(_complete(row) for row in planner_rows + live_rows)
    return EXIT_OK if ok else EXIT_FAILED


def _planner_rows(cases: _PerfCases, limit_s: float, progress: Console) -> list[dict[str, Any]]:
    """The planner's cases: every map kind, size and number of agents asked for."""
    progress.print("planner: compiling ...")
    compile_planner(cases.kinds, cases.settings)
    rows = []
    for kind in cases.kinds:
        for size in cases.sizes:
            for n in cases.agents:
                for log in cases.logs:  # side by side: the machine's drift shows on both
                    with_log = " with its log" if log else ""
                    progress.print(f"planner: {kind} {size}x{size}, {n} agents{with_log} ...")
                    case = PlannerCase(kind, size, n, tuple(cases.settings.items()), log)
                    rows.append(run_planner_case(case, limit_s))
    return rows


def _live_rows(
    cases: _PerfCases, args: argparse.Namespace, progress: Console
) -> list[dict[str, Any]]:
    """The live cases: each fleet size and link kind, with the web page and without,
    alternately (the machine's drift then shows on both), ``--repeat`` times."""
    links = PERF_LINKS if args.links == "both" else (args.links,)
    rows = []
    for n in cases.vehicles:
        for link in links:
            progress.print(f"live: {n} vehicles at speed-up {args.live_speedup:g}, {link} link ...")
            sides = [0, args.web_clients] if args.web_clients else [0]
            for clients in sides * args.repeat:
                if clients:
                    progress.print(f"live: the same, the web page read by {clients} ...")
                rows.append(
                    run_live_case(n, args.live_speedup, link, clients, args.live_time_limit)
                )
    return rows
