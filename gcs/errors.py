"""Exit statuses and the errors the CLI reports as one line without a traceback."""

from __future__ import annotations

EXIT_OK = 0
EXIT_FAILED = 1
EXIT_BAD_INPUT = 2


class UsageError(ValueError):
    """Bad input from the operator: the message is shown as is, exit status 2."""
