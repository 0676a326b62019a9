"""The ``gcs`` command line in a process of its own, for the tests of Ctrl-C, and the
processes left running."""

from __future__ import annotations

import signal
import subprocess
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any


def _as_in_a_terminal() -> None:
    """Ctrl-C as a terminal's foreground command receives it. A shell starts its
    background jobs with SIGINT ignored and children inherit that, so the tests
    run that way (``.ci/run &``) would find every command deaf to Ctrl-C."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def gcs_run(*args: str, timeout_s: float = 240.0) -> subprocess.CompletedProcess[str]:
    """``gcs ARGS`` run to its end: exit status and text output."""
    return subprocess.run(
        [sys.executable, "-m", "gcs.cli", *args],
        capture_output=True,
        text=True,
        timeout=timeout_s,
        check=False,
    )


@contextmanager
def gcs_process(*args: str) -> Iterator[subprocess.Popen[str]]:
    """``gcs ARGS`` with text pipes, killed at the end if it is still running."""
    process = subprocess.Popen(
        [sys.executable, "-m", "gcs.cli", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=_as_in_a_terminal,
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


def processes_naming(text: str) -> list[int]:
    """The processes whose command line holds ``text`` (Linux's /proc)."""
    found = []
    for cmdline in Path("/proc").glob("[0-9]*/cmdline"):
        try:
            if text.encode() in cmdline.read_bytes():
                found.append(int(cmdline.parent.name))
        except OSError:
            continue  # ended meanwhile
    return found


def stop(process: subprocess.Popen[Any]) -> None:
    """Terminate a child process, killing it if it does not end within 10 s."""
    if process.poll() is None:
        process.terminate()
        try:
            process.wait(timeout=10)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait(timeout=10)
