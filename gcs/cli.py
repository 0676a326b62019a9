"""The operator's command line: ``gcs plan|run|report|bench|status|map|mission``.

Each subcommand's options live in ``gcs.options`` (argparse only, so ``--help``
is instant) and name the function in ``gcs.commands`` that does the work; this
module imports that function only when the command runs, and turns expected
errors into one-line messages with the documented exit status (0 success, 1 the
mission failed, 2 bad input, 130 interrupted).
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Callable, Sequence

from gcs.errors import EXIT_BAD_INPUT, EXIT_INTERRUPTED, UsageError
from planner.native import use_sources_if_stale

#: Subcommands, in the order ``--help`` lists them.
COMMANDS = ("plan", "bench", "map", "run", "report", "status", "mission")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="gcs",
        description=(
            "Ground station for multi-agent exploration and complete coverage with the "
            "staying alive battery policy, over MAVLink. 'gcs COMMAND --help' explains each "
            "command."
        ),
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name in COMMANDS:
        importlib.import_module(f"gcs.options.{name}").register(sub)
    return parser


def command_function(target: str | Callable[[argparse.Namespace], int]) -> Callable[..., int]:
    """The function a parser named (``"module:function"``), imported now."""
    if callable(target):
        return target
    module, _, name = target.partition(":")
    function: Callable[..., int] = getattr(importlib.import_module(module), name)
    return function


def main(argv: Sequence[str] | None = None) -> int:
    use_sources_if_stale()  # before a command imports the compiled planner
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(command_function(args.func)(args))
    except UsageError as exc:
        print(f"gcs {args.command}: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print(f"gcs {args.command}: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED


if __name__ == "__main__":
    sys.exit(main())
