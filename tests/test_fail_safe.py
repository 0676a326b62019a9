"""Fail safe (issue: whatever breaks, every vehicle ends under control or safely stopped,
and the record tells the truth): each test is an attack as a hostile peer or a careless
operator would make it, and asserts the safe outcome."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from tests.test_live_mission import SMALL, write_mission

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
