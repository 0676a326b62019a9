"""Fail safe (issue: whatever breaks, every vehicle ends under control or safely stopped,
and the record tells the truth): each test is an attack as a hostile peer or a careless
operator would make it, and asserts the safe outcome."""

from __future__ import annotations

import io
import json
import os
import subprocess
import sys
import unicodedata
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st
from pymavlink.dialects.v20 import ardupilotmega as mavlink
from rich.console import Console

from gcs.live.display import LiveDisplay
from gcs.live.shared import Level
from tests.test_live_mission import SMALL, write_mission
from vehicles.printable import printable
from vehicles.telemetry import StatusText, TelemetryCache

pytestmark = pytest.mark.timeout(120)


def gcs(*argv: str, timeout_s: float = 100.0) -> subprocess.CompletedProcess[str]:
    """The real CLI in a process of its own."""
    return subprocess.run(
        [sys.executable, "-c", "import sys; from gcs.cli import main; sys.exit(main())", *argv],
        capture_output=True,
        text=True,
        timeout=timeout_s,
        check=False,
    )


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="needs /dev/full (Linux)")
def test_a_full_log_disk_is_a_warning_and_the_mission_flies_on(tmp_path: Path) -> None:
    """The log file's every write fails with ENOSPC (it is /dev/full): the operator is told
    once, the vehicles fly the mission to the end and are parked, nobody is lost, no
    traceback; report.json (on a disk with room) says the mission was complete."""
    mission = write_mission(tmp_path, SMALL, [{"type": "rover"}, {"type": "copter"}])
    out = tmp_path / "out"
    out.mkdir()
    (out / "mission.mcap").symlink_to("/dev/full")
    done = gcs("run", str(mission), "--sim", "--speedup", "30", "--quiet", "--out", str(out))
    assert "Traceback" not in done.stderr, done.stderr
    assert done.returncode == 0, done.stderr
    assert "the log stopped at mission time" in done.stderr
    assert "No space left on device" in done.stderr
    report = json.loads((out / "report.json").read_text())
    assert report["complete"] and report["lost_agents"] == 0


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="needs /dev/full (Linux)")
def test_a_plan_whose_log_cannot_be_written_is_still_a_plan(tmp_path: Path) -> None:
    mission = write_mission(tmp_path, SMALL, [{"type": "rover"}])
    out = tmp_path / "out"
    out.mkdir()
    (out / "mission.mcap").symlink_to("/dev/full")
    done = gcs("plan", str(mission), "--quiet", "--out", str(out))
    assert "Traceback" not in done.stderr, done.stderr
    assert done.returncode == 0, done.stderr
    assert "warning: the log stopped at" in done.stderr
    assert json.loads((out / "report.json").read_text())["complete"]


# -- text from a vehicle -----------------------------------------------------------------

HOSTILE_TEXTS = (
    "\x1b[2J\x1b[Hcleared",  # clears the operator's terminal
    "[link=http://evil.example]click[/link]",  # Rich markup: a link
    "[/bogus] and what follows",  # Rich markup that does not close
    "ok\u202eenil a nrut",  # a right-to-left override
    "two\nlines\rforged",
)


def _statustext_on_the_wire(text: str) -> StatusText:
    codec = mavlink.MAVLink(None, 1, 1)
    frame = codec.statustext_encode(mavlink.MAV_SEVERITY_WARNING, text.encode()[:50]).pack(codec)
    message = mavlink.MAVLink(None).parse_buffer(bytes(frame))[0]
    cache = TelemetryCache()
    update = cache.update(message)
    assert update is not None
    return update[1]


@pytest.mark.parametrize("text", HOSTILE_TEXTS)
def test_a_vehicles_text_reaches_the_operator_printable(text: str) -> None:
    """No control, format or line-breaking character survives the decoding of a
    STATUSTEXT, and the display prints markup as the characters it is."""
    got = _statustext_on_the_wire(text).text
    assert all(not unicodedata.category(c).startswith("C") for c in got), repr(got)
    assert "\n" not in got and "\r" not in got
    display = LiveDisplay(quiet=True)
    display.errors = Console(file=io.StringIO(), force_terminal=True, width=200)
    for _ in range(2):  # the second one is still shown: nothing was swallowed
        display.notify(got, Level.ERROR, 1)
    shown = display.errors.file.getvalue()  # type: ignore[attr-defined]
    assert shown.count(f"error: {got}") == 2, repr(shown)
    assert "\x1b]8;" not in shown  # no terminal hyperlink was made


@given(st.text(max_size=300))
def test_printable_leaves_nothing_a_terminal_acts_on(text: str) -> None:
    got = printable(text)
    assert len(got) <= 200
    assert all(
        c == " " or not (c.isspace() or unicodedata.category(c).startswith("C")) for c in got
    )
