"""The operator's command line: ``gcs plan|run|report|bench|status|map|mission``.

Each subcommand lives in its own module under ``gcs.commands`` and registers
itself on the parser; this module only dispatches and turns expected errors
into one-line messages with the documented exit status (0 success, 1 the
mission failed, 2 bad input).
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence

from gcs.errors import EXIT_BAD_INPUT, EXIT_INTERRUPTED, UsageError

#: Subcommand modules, in the order ``--help`` lists them.
COMMANDS = ("plan", "bench", "map", "run", "report", "status", "mission")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="gcs",
        description=(
            "Ground station for multi-agent exploration and complete coverage with the "
            "staying alive battery policy, over MAVLink."
        ),
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name in COMMANDS:
        try:
            module = importlib.import_module(f"gcs.commands.{name}")
        except ModuleNotFoundError as exc:
            if exc.name != f"gcs.commands.{name}":
                raise
            continue  # not built yet
        module.register(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args))
    except UsageError as exc:
        print(f"gcs {args.command}: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print(f"gcs {args.command}: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED


if __name__ == "__main__":
    sys.exit(main())
