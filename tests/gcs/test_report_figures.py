"""Report and figures of a small hand-made run: values, and figures a reviewer can read."""

from __future__ import annotations

import io
import json
import os
import stat
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from mcap.reader import make_reader
from PIL import Image
from rich.console import Console

from core.cells import Cell, CellState
from gcs.log.reader import LogContents, VehicleState, read_contents, read_log
from gcs.offline.simulate import simulate
from gcs.outcome.figures import (
    MISSION_LOG,
    PREDICTED_TIME_LABEL,
    STEP_LABEL,
    TIME_LABEL,
    battery_plot,
    coverage_plot,
    explored_plot,
    path_length_plot,
    timeline,
    write_figures,
)
from gcs.outcome.report import print_summary, report_dict, summary_rows, write_report
from gcs.outcome.result import AgentTrace, BtpRecord, RunResult
from sitl_mock import mapgen
from tests.checks import make_mission, open_mission_log

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
    assert labels["Vehicles"] == "2 (0 lost)"
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


# --------------------------------------------------------------------------- readability


def _drawn(fig: Figure) -> Figure:
    """The figure laid out as it is saved (constrained layout runs at draw time)."""
    fig.canvas.draw()
    return fig


def _main_axes(fig: Figure) -> Axes:
    return fig.axes[0]


def _legend_texts(fig: Figure) -> list[str]:
    return [t.get_text() for legend in fig.legends for t in legend.get_texts()]


def _all_plots(result: RunResult) -> list[Figure]:
    clock = timeline(result)
    return [
        coverage_plot(result),
        path_length_plot(result),
        battery_plot(result, clock),
        explored_plot(result, clock),
    ]


def test_coverage_axes_are_east_and_north_in_metres() -> None:
    result = make_result()  # 6 x 8 cells of 1.5 m
    ax = _main_axes(_drawn(coverage_plot(result)))
    assert "east" in ax.get_xlabel() and "[m]" in ax.get_xlabel()
    assert "north" in ax.get_ylabel() and "[m]" in ax.get_ylabel()
    assert ax.get_xlim() == pytest.approx((0.0, 8 * 1.5))
    assert ax.get_ylim() == pytest.approx((-6 * 1.5, 0.0))  # row 0 is the northern edge
    # Vehicle 1 starts on the charger, cell (5, 3): 3.5 cells east, 5.5 cells south.
    east, north = np.asarray(ax.lines[1].get_xydata())[0]
    assert (east, north) == pytest.approx((3.5 * 1.5, -5.5 * 1.5))


def test_coverage_ticks_are_whole_metres() -> None:
    ax = _main_axes(_drawn(coverage_plot(make_result())))
    for ticks, (low, high) in ((ax.get_xticks(), ax.get_xlim()), (ax.get_yticks(), ax.get_ylim())):
        shown = [t for t in ticks if low - 1e-9 <= t <= high + 1e-9]
        assert len(shown) >= 3
        assert all(float(t).is_integer() for t in shown), shown


def test_backtracking_points_are_hollow_and_named_in_plain_words() -> None:
    result = make_result()  # two BTPs covered, one not
    fig = coverage_plot(result)
    rings = [c for c in _main_axes(fig).collections if len(np.asarray(c.get_offsets()))]
    hollow, filled = rings
    assert len(np.asarray(hollow.get_offsets())) == 2 and len(hollow.get_facecolor()) == 0
    assert len(np.asarray(filled.get_offsets())) == 1
    texts = _legend_texts(fig)
    assert any(t.startswith("backtracking point") for t in texts)
    assert not any("BTP" in t for t in texts)


def test_legends_stay_off_the_axes() -> None:
    for fig in _all_plots(make_result()):
        _drawn(fig)
        renderer = fig.canvas.get_renderer()  # type: ignore[attr-defined]
        (legend,) = fig.legends
        box = legend.get_window_extent(renderer)
        for ax in fig.axes:
            assert not box.overlaps(ax.get_window_extent(renderer)), ax.get_title()
            tight = ax.get_tightbbox(renderer)
            assert tight is not None
            assert not box.overlaps(tight), ax.get_title()


def test_plots_over_time_share_one_clock() -> None:
    result = make_result()
    _, _, battery, explored = (_drawn(f) for f in _all_plots(result))
    labels = {_main_axes(f).get_xlabel() for f in (battery, explored)}
    assert labels == {STEP_LABEL}
    assert _main_axes(battery).get_xlim() == _main_axes(explored).get_xlim() == (0, 8)


def test_a_timed_plan_is_drawn_in_predicted_seconds() -> None:
    result = make_result()
    result = replace(result, extra={"total_iterations": 8, "mission_s": 2.0, "coverage_s": 1.5})
    clock = timeline(result)
    assert clock is not None and clock.label == PREDICTED_TIME_LABEL
    assert clock.battery[1].x[-1] == pytest.approx(2.0)
    assert clock.covered.x[-1] == pytest.approx(2.0)


def _live_result() -> RunResult:
    """A live run of one vehicle: start, two arrivals, two samples on the charger."""
    base = make_result()
    agent = AgentTrace(
        id=1,
        track=((5, 3), (4, 3), (5, 3), (5, 3), (5, 3)),
        battery_pct=(100.0, 96.0, 92.0, 92.0, 100.0),
        path_m=3.0,
        homing_m=0.0,
        charges=1,
        min_battery_pct=92.0,
    )
    return replace(
        base,
        agents=(agent,),
        covered_per_iteration=(2, 2),
        extra={"live": 1, "mission_s": 11.0, "coverage_s": 5.0},
    )


def _live_log(result: RunResult) -> LogContents:
    states = [VehicleState(2.0, (4, 3), 96.0, "exploring"), VehicleState(5.0, (5, 3), 92.0, "x")]
    return LogContents(
        meta={"mission": result.mission, "shape": list(result.shape)},
        states={1: states},
        topics={"/mavlink/1/in": ""},
    )


def test_a_live_run_is_drawn_in_mission_seconds_from_its_log() -> None:
    result = _live_result()
    clock = timeline(result, _live_log(result))
    assert clock is not None and clock.label == TIME_LABEL
    # Arrivals at their logged times; the charger's samples spread up to the mission's end.
    assert clock.battery[1].x.tolist() == pytest.approx([0.0, 2.0, 5.0, 8.0, 11.0])
    assert clock.covered.x.tolist() == [2.0, 5.0]
    assert clock.covered_at == 5.0 and clock.end == 11.0
    fig = _drawn(explored_plot(result, clock))
    assert _main_axes(fig).get_xlabel() == TIME_LABEL


def test_a_live_run_without_its_log_says_so_instead_of_guessing() -> None:
    result = _live_result()
    assert timeline(result) is None
    other = _live_log(result)
    other.states[1] = other.states[1][:1]  # not this run's arrivals
    assert timeline(result, other) is None
    fig = battery_plot(result, None)
    assert not _main_axes(fig).axison
    assert "mission log" in _main_axes(fig).texts[0].get_text()


def test_figures_of_a_cut_log_find_the_log_beside_them(tmp_path: Path) -> None:
    """A result rebuilt from a cut log has no clock of its own: its log gives one."""
    mission = make_mission(mapgen.open_field(10, 10, 1), 2, name="cut")
    beside = tmp_path / "beside"
    beside.mkdir()
    path = beside / MISSION_LOG
    log = open_mission_log(path, mission, chunk_size=2048)
    simulate(mission, log=log)
    with path.open("rb") as stream:
        summary = make_reader(stream).get_summary()
    assert summary is not None
    chunks = sorted(c.chunk_start_offset for c in summary.chunk_indexes)
    path.write_bytes(path.read_bytes()[: chunks[len(chunks) // 2]])  # cut mid-way
    result = read_log(path)
    assert result.interrupted and timeline(result) is None
    clock = timeline(result, read_contents(path))
    assert clock is not None and clock.label == STEP_LABEL  # a plan's log
    with_log = write_figures(result, beside)[3].read_bytes()
    elsewhere = write_figures(result, tmp_path / "elsewhere")[3].read_bytes()
    assert with_log != elsewhere  # drawn over steps vs. the "no times" note
    assert write_figures(result, tmp_path / "given", log=path)[3].read_bytes() == with_log
    read = write_figures(result, tmp_path / "read", contents=read_contents(path))
    assert read[3].read_bytes() == with_log  # the log as ``gcs report`` already read it


def test_summary_never_says_iterations() -> None:
    labels = [label for label, _ in summary_rows(make_result())]
    assert not any("Iteration" in label for label in labels)
    assert "Plan steps" in labels  # one free cell is left: not "to full coverage"


def test_report_json_is_as_readable_as_any_file_written_there(tmp_path: Path) -> None:
    """Written atomically through a temporary file (mode 0600), then given the mode the
    umask gives any new file, as the figures and the log have."""
    path = write_report(make_result(), tmp_path)
    mask = os.umask(0)
    os.umask(mask)
    assert stat.S_IMODE(path.stat().st_mode) == 0o666 & ~mask
