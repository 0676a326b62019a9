"""Resuming a mission from an earlier run's log (``gcs run --resume``).

The planner side (``Coordinator.restore``) is checked offline: a run stopped
halfway and restored into a fresh planner completes without covering any
restored cell again. The ground-station side runs the real CLI against the
mock fleet: an aborted run resumed, a bad resume refused.
"""

from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from core.cells import Cell
from gcs.bench.faults import log_loss_s
from gcs.live.resume import ResumeError, ResumePoint, load_resume_point, resumed_text
from gcs.log.reader import read_contents
from gcs.mission import load_mission
from planner.agent import ActionKind
from planner.coordinator import Coordinator
from planner.settings import AgentSpec, PlannerSettings
from sitl_mock.gridmap import GridMap
from sitl_mock.lockstep import Body, LockstepWorld
from sitl_mock.mapgen import caves, open_field, rooms
from tests.gcs.live.test_mission import write_mission
from tests.processes import gcs_run, stop

AGENTS = (1, 2, 3)
DEMO_MAP = Path("missions/maps/demo.txt")


def _run(coordinator: Coordinator, world: LockstepWorld, iterations: int) -> list[Cell]:
    """Lockstep iterations; returns every cell an agent covered for the first time."""
    newly: list[Cell] = []
    for _ in range(iterations):
        if coordinator.finished:
            break
        for i in AGENTS:
            action = coordinator.decide(i)
            if action.kind == ActionKind.MOVE:
                assert action.to is not None
                world.move(i, action.to)
                before = coordinator.belief.is_covered(action.to)
                coordinator.observe(i, action.to, world.sense(action.to), world.battery[i])
                if not before:
                    newly.append(action.to)
            elif action.kind == ActionKind.CHARGE:
                world.request_charge(i)
        world.end_iteration()
        for i in AGENTS:
            coordinator.update_battery(i, world.battery[i])
    return newly


def _fresh(grid_shape: tuple[int, int], charger: Cell) -> Coordinator:
    specs = [AgentSpec(i, 0.2) for i in AGENTS]
    return Coordinator(grid_shape, charger, specs, PlannerSettings(reserve_pct=20.0))


@pytest.mark.parametrize("grid", [rooms(24, 24, 1), caves(24, 24, 2), open_field(24, 24, 3)])
def test_a_restored_planner_finishes_without_covering_again(grid: GridMap) -> None:
    bodies = [Body(i, 0.2) for i in AGENTS]

    first = _fresh(grid.shape, grid.charger)
    world = LockstepWorld(grid, bodies)
    for i in AGENTS:
        first.observe(i, grid.charger, world.sense(grid.charger), 100.0)
    _run(first, world, 60)
    known = first.belief.state_grid()
    covered = first.belief.covered_grid()
    btps = first.btps()
    assert 0 < covered.sum() < grid.free_count

    # A new ground station: the vehicles were brought home (an aborted run).
    second = _fresh(grid.shape, grid.charger)
    second.restore(known, covered, btps)
    assert second.belief.covered_count == int(covered.sum())
    assert sorted(second.btps()) == sorted(c for c in btps if not covered[c])
    world = LockstepWorld(grid, bodies)
    for i in AGENTS:
        second.observe(i, grid.charger, world.sense(grid.charger), 100.0)
    newly = _run(second, world, 20_000)

    assert second.finished and second.coverage_complete
    assert second.belief.covered_count == grid.free_count
    assert not any(covered[c] for c in newly), "a restored covered cell was covered again"
    assert len(newly) == grid.free_count - int(covered.sum())


def test_restore_refuses_another_shape() -> None:
    coordinator = _fresh((5, 5), (4, 2))
    with pytest.raises(ValueError, match="shape"):
        coordinator.restore(np.zeros((4, 4), np.int8), np.zeros((4, 4), bool), [])


def _point(covered: int, last_t_s: float) -> ResumePoint:
    cells = np.zeros((20, 20), dtype=bool)
    cells.flat[:covered] = True
    return ResumePoint(
        source=Path("out/mission.mcap"),
        known=np.zeros((20, 20), dtype=np.int8),
        covered=cells,
        btps=(),
        vehicles={},
        last_t_s=last_t_s,
        crashed=False,
    )


def test_the_resume_message_says_plainly_what_is_kept() -> None:
    assert resumed_text(_point(320, 63.4), 320) == (
        "resumed from mission.mcap (its log ends at mission time 1:03): 320 covered cells "
        "are kept, none is covered again"
    )
    assert resumed_text(_point(320, 125.0), 300) == (
        "resumed from mission.mcap (its log ends at mission time 2:05): 300 covered cells "
        "are kept; 20 more it covered will be covered again, as what was sensed there did "
        "not reach the log"
    )


# -- the CLI ---------------------------------------------------------------------------


def test_resume_refuses_a_log_of_another_mission(tmp_path: Path, small_log: Path) -> None:
    other = load_mission(Path("missions/bob30.yaml"))
    with pytest.raises(ResumeError) as info:
        load_resume_point(small_log, other)
    assert str(info.value).startswith(f"--resume: {small_log} records mission 'demo'")
    done = gcs_run("run", "missions/bob30.yaml", "--sim", "--resume", str(small_log), "--quiet")
    assert done.returncode == 2
    assert done.stderr.count("\n") == 1 and "Traceback" not in done.stderr
    assert "records mission 'demo'" in done.stderr


def test_resume_refuses_to_overwrite_its_log(small_log: Path) -> None:
    done = gcs_run(
        "run", "missions/demo.yaml", "--sim", "--resume", str(small_log),
        "--out", str(small_log.parent), "--quiet",
    )  # fmt: skip
    assert done.returncode == 2
    assert "would overwrite the log being resumed" in done.stderr


def test_resume_refuses_a_missing_log(tmp_path: Path) -> None:
    done = gcs_run("run", "missions/demo.yaml", "--sim", "--resume", str(tmp_path / "x.mcap"))
    assert done.returncode == 2
    assert done.stderr.strip() == f"gcs run: --resume: {tmp_path / 'x.mcap'}: no such file"


@pytest.fixture(scope="module")
def small_log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The demo mission stopped by its time limit: everyone sent home, the log closed."""
    out = tmp_path_factory.mktemp("first")
    done = gcs_run(
        "run", "missions/demo.yaml", "--sim", "--agents", "3", "--speedup", "40",
        "--time-limit", "40", "--quiet", "--out", str(out),
    )  # fmt: skip
    assert done.returncode == 1, done.stderr
    return out / "mission.mcap"


def test_an_aborted_mission_resumed_completes(tmp_path: Path, small_log: Path) -> None:
    first = json.loads((small_log.parent / "report.json").read_text())
    assert not first["complete"] and first["covered_cells"] > 0
    done = gcs_run(
        "run", "missions/demo.yaml", "--sim", "--agents", "3", "--speedup", "40",
        "--resume", str(small_log), "--quiet", "--out", str(tmp_path),
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    second = json.loads((tmp_path / "report.json").read_text())
    assert second["complete"] and second["lost_agents"] == 0
    # An orderly stop logs everything: all of it is restored.
    assert second["resumed_logged_cells"] == second["resumed_covered_cells"]
    assert second["resumed_covered_cells"] == first["covered_cells"]
    assert second["resumed_swept_again_cells"] == 0


# -- killed with SIGKILL, resumed ------------------------------------------------------

#: The vehicles' clock in the kill test: fast enough to get far in a few seconds,
#: slow enough for two processes on a loaded 2-core machine.
KILL_SPEEDUP = 25.0
#: Real seconds the first ground station runs before it is killed.
KILL_AFTER_S = 5.0


def _spawn(*args: str) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [sys.executable, "-m", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def test_a_killed_ground_station_resumes_from_its_log(tmp_path: Path) -> None:
    """The mock fleet in its own process holds on GCS loss; the first ground station
    is killed mid-mission; the second one carries on from the first one's log."""
    vehicles: list[dict[str, Any]] = [
        {"type": "rover"},
        {"type": "copter", "speed_m_s": 3.0},
        {"type": "rover"},
    ]
    mission = write_mission(tmp_path, DEMO_MAP.read_text(), vehicles, energy=0.45)
    first_out, second_out = tmp_path / "first", tmp_path / "second"
    speed = ("--speedup", str(KILL_SPEEDUP))
    fleet = _spawn("gcs.sitl_cli", str(mission), *speed, "--gcs-failsafe", "hold")
    try:
        gcs = _spawn("gcs.cli", "run", str(mission), *speed, "--quiet", "--out", str(first_out))
        try:
            with pytest.raises(subprocess.TimeoutExpired):
                gcs.wait(timeout=KILL_AFTER_S)  # still flying when it is killed
        finally:
            killed_at = time.time()
            gcs.kill()
            gcs.wait(timeout=10)
        log = first_out / "mission.mcap"
        contents = read_contents(log)
        assert contents.truncated and contents.meta is not None and contents.result is None
        # Readable up to about a second before the kill (the writer flushes every second).
        lost_s = log_loss_s(log, killed_at, KILL_SPEEDUP)
        assert lost_s is not None and lost_s < 2.0, lost_s
        point = load_resume_point(log, load_mission(mission))
        assert 0 < point.covered_cells < load_mission(mission).map.free_count

        done = subprocess.run(
            [sys.executable, "-m", "gcs.cli", "run", str(mission), *speed, "--quiet",
             "--resume", str(log), "--out", str(second_out)],
            capture_output=True, text=True, timeout=240, check=False,
        )  # fmt: skip
        assert done.returncode == 0, done.stderr
    finally:
        stop(fleet)
    got = json.loads((second_out / "report.json").read_text())
    assert got["complete"] and got["lost_agents"] == 0
    assert got["resumed_logged_cells"] == point.covered_cells
    # Every arrival logs what was sensed there, so all that the log holds is restored,
    # but for cells whose sensing failed (swept again so that someone senses there).
    restored = got["resumed_covered_cells"]
    assert 0.95 * point.covered_cells <= restored <= point.covered_cells, (restored, point)
    # Covered again by a sweep: only those; going over covered cells to work is no sweep.
    assert got["resumed_swept_again_cells"] <= point.covered_cells - restored, got
