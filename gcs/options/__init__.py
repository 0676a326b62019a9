"""The command line's options: one module per ``gcs`` subcommand, argparse only.

These modules import nothing heavy (no planner, no matplotlib, no MAVLink), so
``gcs ... --help`` answers at once. Each parser names the function that does
the work as ``"module:function"`` (see :func:`runs`); ``gcs.cli`` imports that
module only when the command runs. The work itself lives in ``gcs.commands``.
"""

from __future__ import annotations

import argparse

#: The ``func`` default of a parser: ``"gcs.commands.plan:run"``.
Target = str


def runs(parser: argparse.ArgumentParser, target: Target) -> None:
    """Make ``parser`` run ``target`` (``"package.module:function"``), imported when used."""
    parser.set_defaults(func=target)
