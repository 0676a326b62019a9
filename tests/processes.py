"""The ``gcs`` command line in a process of its own, for the tests of Ctrl-C."""

from __future__ import annotations

import signal
import subprocess
import sys
from collections.abc import Iterator
from contextlib import contextmanager


@contextmanager
def gcs_process(*args: str) -> Iterator[subprocess.Popen[str]]:
    """``gcs ARGS`` with text pipes, killed at the end if it is still running."""
    process = subprocess.Popen(
        [sys.executable, "-m", "gcs.cli", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        yield process
    finally:
        if process.poll() is None:
            process.kill()
            process.communicate()


def ctrl_c(process: subprocess.Popen[str], timeout_s: float = 60) -> tuple[str, str]:
    """Interrupt as a terminal's Ctrl-C does; what it printed (stdout, stderr) once it ended."""
    process.send_signal(signal.SIGINT)
    return process.communicate(timeout=timeout_s)
