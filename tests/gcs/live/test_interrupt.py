"""Ctrl-C on a live mission: exit 130, everyone home, nobody lost, a readable log
and a report."""

from __future__ import annotations

import time
from pathlib import Path

import pytest

from gcs.live.resume import load_resume_point
from gcs.log.reader import read_log
from gcs.mission import load_mission
from planner.belief import with_unknown_side
from tests.processes import ctrl_c, gcs_process

DEMO = Path(__file__).resolve().parents[3] / "missions" / "demo.yaml"


@pytest.mark.timeout(120)
def test_ctrl_c_sends_everyone_home_and_closes_the_log(tmp_path: Path) -> None:
    out = tmp_path / "live"
    args = ["run", str(DEMO), "--sim", "--speedup", "10", "--quiet", "--out", str(out)]
    with gcs_process(*args) as process:
        log = out / "mission.mcap"
        # The mission is under way once its log has grown past the first chunks;
        # the other process gives no other sign (--quiet), so look at the file.
        deadline = time.monotonic() + 60
        while not (log.exists() and log.stat().st_size > 200_000):
            assert process.poll() is None, process.communicate()
            assert time.monotonic() < deadline, "the mission did not get under way"
            time.sleep(0.2)
        stdout, stderr = ctrl_c(process)
    assert process.returncode == 130, (stdout, stderr)
    result = read_log(out / "mission.mcap")
    assert not result.complete
    assert result.lost_agents == 0
    # Brought home by the planner (not each sent on its own): every vehicle's last
    # arrival is on the charger.
    charger = load_mission(DEMO).charger
    assert [a.track[-1] for a in result.agents] == [charger] * len(result.agents)
    assert "not home" not in stdout + stderr
    # The way home, flown in AUTO without sensing, crossed only cells already
    # covered: every covered cell was sensed from (a resumed mission relies on it).
    logged = load_resume_point(out / "mission.mcap", load_mission(DEMO))
    assert not (logged.covered & with_unknown_side(logged.known)).any()
    assert (out / "report.json").exists()
