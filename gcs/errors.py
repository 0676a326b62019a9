"""Exit statuses and the errors the CLI reports as one line without a traceback."""

from __future__ import annotations

EXIT_OK = 0
EXIT_FAILED = 1
EXIT_BAD_INPUT = 2
#: Stopped by Ctrl-C (128 + SIGINT, as shells report it).
EXIT_INTERRUPTED = 130


class UsageError(ValueError):
    """Bad input from the operator: the message is shown as is, exit status 2."""
