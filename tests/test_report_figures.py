"""Report and figures of a small hand-made run."""

from __future__ import annotations

import io
import json
import warnings
from pathlib import Path

import numpy as np
import pytest
from PIL import Image
from rich.console import Console

from gcs.figures import write_figures
from gcs.report import print_summary, report_dict, summary_rows, write_report
from gcs.result import AgentTrace, BtpRecord, RunResult
from gcs.simulate import simulate
from planner.grid import Cell, CellState
from sitl_mock import mapgen
from tests.checks import make_mission

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
MAP = (
    "........",
    ".##.....",
    ".##..#..",
    ".....#..",
    "........",
    "...C....",
)


def _belief() -> np.ndarray:
    codes = {"#": CellState.OBSTACLE, ".": CellState.FREE, "C": CellState.FREE}
    return np.array([[codes[ch] for ch in line] for line in MAP], dtype=np.int8)


def _track(cells: list[Cell]) -> tuple[Cell, ...]:
    return tuple(cells)


def make_result(lost_second: bool = True) -> RunResult:
    """A 6x8 run with two agents: one complete, one lost, one uncovered cell."""
    belief = _belief()
    belief[0, 7] = CellState.UNKNOWN
    covered = belief == CellState.FREE
    covered[0, 6] = False  # free but nobody covered it
    a1 = AgentTrace(
        id=1,
        track=_track([(5, 3), (4, 3), (3, 3), (2, 3), (1, 3), (0, 3), (0, 2), (0, 1), (0, 0)]),
        battery_pct=(100.0, 96.0, 92.0, 88.0, 84.0, 80.0, 76.0, 72.0, 68.0),
        path_m=12.5,
        homing_m=4.0,
        charges=1,
        min_battery_pct=68.0,
    )
    a2 = AgentTrace(
        id=2,
        track=_track([(5, 3), (5, 4), (4, 4), (3, 4), (2, 4), (1, 4), (0, 4)]),
        battery_pct=(100.0, 90.0, 80.0, 70.0, 60.0, 50.0, 40.0),
        path_m=20.25,
        homing_m=0.0,
        charges=0,
        min_battery_pct=40.0,
        lost=lost_second,
    )
    btps = (
        BtpRecord(cell=(3, 0), detected_by=1, detected_at=2, covered_by=2, covered_at=5),
        BtpRecord(cell=(3, 6), detected_by=2, detected_at=3, covered_by=1, covered_at=6),
        BtpRecord(cell=(0, 6), detected_by=2, detected_at=6),
    )
    return RunResult(
        mission="synthetic",
        shape=(6, 8),
        cell_size_m=1.5,
        charger=(5, 3),
        reserve_pct=25.0,
        belief=belief,
        covered=covered,
        agents=(a1, a2),
        btps=btps,
        covered_per_iteration=(1, 4, 9, 14, 20, 26, 31, 35, 38),
        iterations=8,
        free_cells=int((belief == CellState.FREE).sum()),
        covered_cells=int(covered.sum()),
        out_of_range_cells=1,
        safety_net_fires=2,
        wall_s=1.23456,
        planner_s=0.0123456,
        extra={"seed": 7, "note": "hand made"},
    )


def test_report_dict_values() -> None:
    result = make_result()
    report = report_dict(result)
    for key in (
        "mission", "complete", "coverage_pct", "free_cells", "covered_cells",
        "out_of_range_cells", "total_path_m", "homing_m", "makespan_m", "iterations",
        "lost_agents", "wall_s", "planner_s", "us_per_agent_step", "btps_detected",
        "safety_net_fires", "charges_total", "agents",
    ):  # fmt: skip
        assert key in report, key
    assert report["mission"] == "synthetic"
    assert report["total_path_m"] == pytest.approx(32.75)
    assert report["homing_m"] == pytest.approx(4.0)
    assert report["makespan_m"] == pytest.approx(20.25)
    assert report["free_cells"] == 41
    assert report["covered_cells"] == 40
    assert report["coverage_pct"] == pytest.approx(round(100 * 40 / 41, 3))
    assert report["lost_agents"] == 1
    assert report["complete"] is False
    assert report["btps_detected"] == 3
    assert report["charges_total"] == 1
    assert report["wall_s"] == 1.235
    assert report["us_per_agent_step"] == pytest.approx(round(0.0123456e6 / 16, 3))
    assert report["seed"] == 7 and report["note"] == "hand made"
    assert [a["id"] for a in report["agents"]] == [1, 2]
    assert report["agents"][1] == {
        "id": 2, "path_m": 20.25, "homing_m": 0.0, "charges": 0,
        "min_battery_pct": 40.0, "lost": True,
    }  # fmt: skip


def test_extra_never_overrides_standard_keys() -> None:
    result = make_result()
    result.extra["mission"] = "spoofed"
    assert report_dict(result)["mission"] == "synthetic"


def test_write_report_round_trips(tmp_path: Path) -> None:
    result = make_result()
    path = write_report(result, tmp_path / "out")
    assert path.name == "report.json"
    assert json.loads(path.read_text(encoding="utf-8")) == report_dict(result)
    assert [p.name for p in path.parent.iterdir()] == ["report.json"]  # no temp left over


def test_write_figures(tmp_path: Path) -> None:
    paths = write_figures(make_result(), tmp_path)
    assert [p.name for p in paths] == [
        "coverage.png", "path_length.png", "battery.png", "explored.png",
    ]  # fmt: skip
    for path in paths:
        data = path.read_bytes()
        assert data.startswith(PNG_SIGNATURE), path.name
        with Image.open(path) as image:
            image.verify()
        with Image.open(path) as image:
            width, height = image.size
        assert 300 <= width <= 4000 and 300 <= height <= 4000, (path.name, image.size)


def test_print_summary_has_agent_rows() -> None:
    result = make_result(lost_second=False)
    buffer = io.StringIO()
    print_summary(result, Console(file=buffer, width=120))
    text = buffer.getvalue()
    assert "synthetic" in text
    assert "20.2" in text  # agent 2's path, to one decimal
    rows = [line for line in text.splitlines() if "12.5" in line or "20.2" in line]
    assert len(rows) >= 2
    labels = dict(summary_rows(result))
    assert labels["Agents"] == "2 (0 lost)"
    assert labels["Result"] == "INCOMPLETE"  # one free cell is uncovered


def test_empty_run_still_reports_and_draws(tmp_path: Path) -> None:
    belief = np.zeros((3, 4), dtype=np.int8)
    result = RunResult(
        mission="empty",
        shape=(3, 4),
        cell_size_m=1.0,
        charger=(2, 0),
        reserve_pct=20.0,
        belief=belief,
        covered=np.zeros((3, 4), dtype=bool),
        agents=(),
        btps=(),
        covered_per_iteration=(),
        iterations=0,
        free_cells=0,
        covered_cells=0,
        out_of_range_cells=0,
        safety_net_fires=0,
        wall_s=0.0,
        planner_s=0.0,
    )
    report = report_dict(result)
    assert report["us_per_agent_step"] == 0.0 and report["makespan_m"] == 0.0
    assert all(p.stat().st_size > 0 for p in write_figures(result, tmp_path))


def test_figures_of_a_large_fleet_keep_their_axes(tmp_path: Path) -> None:
    """64 agents' legend entries wrap into columns instead of crowding out the plot."""
    grid = mapgen.open_field(14, 14, 1)
    result = simulate(make_mission(grid, 64))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # "constrained_layout not applied" and the like
        paths = write_figures(result, tmp_path)
    assert len(paths) == 4
