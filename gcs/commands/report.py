"""``gcs report LOG.mcap``: report.json, figures and the summary of a run, from its log alone."""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import sys
from pathlib import Path

from rich.console import Console

from gcs.commands.web_page import start_web, wants_web, web_view
from gcs.console import output_console
from gcs.errors import EXIT_FAILED, EXIT_OK, UsageError
from gcs.log.reader import LogError, read_contents, result_of
from gcs.outcome.figures import write_figures
from gcs.outcome.report import print_summary, write_report
from gcs.web.replay import load_replay
from gcs.web.server import WebView


def run(args: argparse.Namespace) -> int:
    try:
        contents = read_contents(args.log)  # read once: the report and the figures
        result = result_of(contents, args.log)
    except LogError as exc:
        raise UsageError(str(exc)) from exc
    out: Path = args.out if args.out is not None else args.log.parent
    try:
        write_report(result, out)
        write_figures(result, out, contents=contents)
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
    code = EXIT_OK if result.complete else EXIT_FAILED
    if wants_web(args):
        serve_replay(args, result.mission)
    return code


def serve_replay(args: argparse.Namespace, title: str) -> None:
    """The log replayed in the browser until Ctrl-C."""
    try:
        replay = load_replay(args.log)
    except LogError as exc:
        raise UsageError(str(exc)) from exc
    view = web_view(args, title, replay=replay.data)
    with contextlib.suppress(KeyboardInterrupt):
        asyncio.run(_serve(view))


async def _serve(view: WebView) -> None:
    await start_web(view, "report")
    print("gcs report: Ctrl-C stops", file=sys.stderr, flush=True)
    try:
        await asyncio.Event().wait()  # until Ctrl-C
    finally:
        await view.close()
