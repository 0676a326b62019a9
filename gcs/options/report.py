"""``gcs report`` options."""

from __future__ import annotations

import argparse
from pathlib import Path

from gcs.options import runs
from gcs.options.web import add_web_options


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    p = sub.add_parser(
        "report",
        help="rebuild report.json, figures and the summary from a mission log (MCAP)",
        description=(
            "Read a mission log written by 'gcs plan --out' or 'gcs run --out' and rebuild "
            "report.json and the PNG figures from it alone. A log cut short (the ground "
            "station died) is read up to its last complete chunk and reported as such. "
            "With --web, the mission is then replayed in the browser. Exit status 1 when the "
            "logged mission failed."
        ),
    )
    p.add_argument("log", type=Path, help="the mission log (.mcap)")
    p.add_argument(
        "--out", type=Path, help="folder for report.json and figures (default: the log's folder)"
    )
    p.add_argument("--quiet", action="store_true", help="print nothing but errors")
    add_web_options(p, "a replay of the log, with a time slider, until Ctrl-C,")
    runs(p, "gcs.commands.report:run")
