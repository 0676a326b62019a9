"""Consoles for the CLI's tables: as wide as a terminal, and wide enough in a pipe or a file."""

from __future__ import annotations

from rich.console import Console

#: Width of tables written to a file or a pipe, where there is no terminal to fit.
PIPE_WIDTH = 160


def output_console(*, quiet: bool = False, stderr: bool = False) -> Console:
    console = Console(quiet=quiet, stderr=stderr)
    if console.is_terminal:
        return console
    return Console(quiet=quiet, stderr=stderr, width=PIPE_WIDTH)
