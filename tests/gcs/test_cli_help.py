"""Every ``--help`` answers without loading the planner, matplotlib or MAVLink, and the
options' defaults and choices agree with the code that uses them."""

from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys

import pytest

from gcs import cli
from gcs.bench.mavlink import TIMERS
from gcs.bench.paper import PAPER_TABLE1
from gcs.generated_missions import GENERATORS
from gcs.live.agent import AgentSettings
from gcs.mission import MAX_SYSID
from gcs.options import bench as bench_options
from gcs.options import run as run_options

HEAVY = (
    "matplotlib",
    "numba",
    "scipy",
    "planner.coordinator",
    "pymavlink.mavutil",
    "gcs.live",
    "dask",
    "distributed",
)


def _parsers(
    parser: argparse.ArgumentParser, argv: tuple[str, ...] = ()
) -> dict[tuple[str, ...], argparse.ArgumentParser]:
    """Every command line that can end in ``--help``, subcommands included, and its parser."""
    found = {argv: parser}
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                found |= _parsers(sub, (*argv, name))
    return found


PARSERS = _parsers(cli.build_parser())
COMMAND_LINES = list(PARSERS)


def test_every_command_is_found() -> None:
    assert ("run",) in COMMAND_LINES and ("bench", "perf") in COMMAND_LINES
    assert ("mission", "upload") in COMMAND_LINES and ("map", "building") in COMMAND_LINES


def test_help_loads_nothing_heavy() -> None:
    """One child process prints every help (``sitl-mock``'s too) and reports the modules
    it had to load."""
    script = (
        "import contextlib, io, json, sys\n"
        "from gcs import cli\n"
        f"for argv in {[list(a) for a in COMMAND_LINES]!r}:\n"
        "    with contextlib.redirect_stdout(io.StringIO()), contextlib.suppress(SystemExit):\n"
        "        cli.main([*argv, '--help'])\n"
        "from gcs import sitl_cli\n"
        "with contextlib.redirect_stdout(io.StringIO()), contextlib.suppress(SystemExit):\n"
        "    sitl_cli.main(['--help'])\n"
        "print(json.dumps(sorted(sys.modules)))\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, timeout=60, check=True
    )
    loaded = json.loads(out.stdout)
    heavy = [m for m in loaded if any(m == h or m.startswith(h + ".") for h in HEAVY)]
    assert heavy == []


@pytest.mark.parametrize("argv", COMMAND_LINES, ids=lambda a: " ".join(a) or "gcs")
def test_help_is_plain_text(argv: tuple[str, ...], capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as stop:
        cli.main([*argv, "--help"])
    assert stop.value.code == 0
    text = capsys.readouterr().out
    assert "``" not in text
    # No internal constant names (an option's own metavar, e.g. ROOM_MIN, is fine).
    metavars = {str(a.metavar or a.dest.upper()) for a in PARSERS[argv]._actions}
    assert set(re.findall(r"\b[A-Z]{2,}_[A-Z_]{2,}\b", text)) <= metavars


def test_defaults_agree_with_the_code() -> None:
    assert AgentSettings().lost_after_s == run_options.LOST_AFTER_S
    assert tuple(GENERATORS) == bench_options.PERF_KINDS
    assert tuple(TIMERS) == bench_options.MAVLINK_TIMERS
    assert tuple(sorted(PAPER_TABLE1)) == bench_options.PAPER_AGENTS
    assert bench_options.MAX_SYSID == MAX_SYSID
