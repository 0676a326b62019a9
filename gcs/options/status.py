"""``gcs status`` options."""

from __future__ import annotations

import argparse

from gcs.options import runs
from gcs.options.mission import add_link_arguments, positive_float

DEFAULT_TIMEOUT_S = 5.0


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    p = sub.add_parser(
        "status",
        help="list the vehicles on one or more endpoints with mode, battery and position",
        description=(
            "Listen on each ENDPOINT (UDP, TCP or a serial radio) for vehicle heartbeats and "
            "print one row per vehicle heard, however many share an endpoint: "
            "system id, type, autopilot, mode, armed, battery and position. Waits until every "
            "vehicle heard has reported position and battery, or until --timeout. Exit status "
            "1 if some endpoint had no vehicle."
        ),
    )
    p.add_argument(
        "endpoints",
        nargs="+",
        metavar="ENDPOINT",
        help="connection string, e.g. tcp:127.0.0.1:5760 or udpin:127.0.0.1:14550",
    )
    p.add_argument(
        "--timeout",
        type=positive_float,
        default=DEFAULT_TIMEOUT_S,
        metavar="S",
        help=f"seconds to wait for heartbeats and telemetry (default {DEFAULT_TIMEOUT_S:g})",
    )
    add_link_arguments(p, sysid=False)
    runs(p, "gcs.commands.status:run")
