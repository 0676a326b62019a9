"""``gcs report LOG.mcap``: report.json, figures and the summary of a run, from its log alone."""

from __future__ import annotations

import argparse
from pathlib import Path

from rich.console import Console

from gcs.console import output_console
from gcs.errors import EXIT_FAILED, EXIT_OK, UsageError
from gcs.figures import write_figures
from gcs.log_reader import LogError, read_log
from gcs.report import print_summary, write_report


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    p = sub.add_parser(
        "report",
        help="rebuild report.json, figures and the summary from a mission log (MCAP)",
        description=(
            "Read a mission log written by 'gcs plan --out' or 'gcs run --out' and rebuild "
            "report.json and the PNG figures from it alone. A log cut short (the ground "
            "station died) is read up to its last complete chunk and reported as such. "
            "Exit status 1 when the logged mission failed."
        ),
    )
    p.add_argument("log", type=Path, help="the mission log (.mcap)")
    p.add_argument(
        "--out", type=Path, help="folder for report.json and figures (default: the log's folder)"
    )
    p.add_argument("--quiet", action="store_true", help="print nothing but errors")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    try:
        result = read_log(args.log)
    except LogError as exc:
        raise UsageError(str(exc)) from exc
    out: Path = args.out if args.out is not None else args.log.parent
    try:
        write_report(result, out)
        write_figures(result, out)
    except OSError as exc:
        raise UsageError(f"--out: cannot write to {out}: {exc.strerror}") from exc
    console = output_console(quiet=args.quiet)
    if result.extra.get("log_truncated"):
        Console(stderr=True, quiet=args.quiet).print(
            "[yellow]warning:[/] the log ends before the run's result (the ground station "
            "stopped): this report is rebuilt from what it holds"
        )
    print_summary(result, console)
    console.print(f"wrote {out}/report.json and figures")
    return EXIT_OK if result.complete else EXIT_FAILED
