"""``gcs bench perf``: the planner part end to end on tiny maps, and its inputs."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from gcs.bench_perf import live_map, write_live_mission
from gcs.cli import main
from gcs.mission import load_mission

pytestmark = pytest.mark.timeout(120)


def test_planner_cases_print_and_write_their_figures(tmp_path: Path, capsys) -> None:
    out = tmp_path / "perf.json"
    code = main(
        ["bench", "perf", "--sizes", "24", "--agents", "1,3", "--skip-live", "--json", str(out)]
    )
    assert code == 0
    rows = json.loads(out.read_text())["planner"]
    assert [(r["kind"], r["size"], r["agents"]) for r in rows] == [
        ("rooms", 24, 1),
        ("rooms", 24, 3),
        ("open", 24, 1),
        ("open", 24, 3),
    ]
    for r in rows:
        assert r["coverage_pct"] == 100.0 and r["lost"] == 0
        assert r["charges"] >= 1  # the battery keeps the staying alive policy at work
        assert r["peak_mb"] > 0 and r["us_per_agent_step"] > 0
    assert "offline planner" in capsys.readouterr().out


def test_the_planner_option_reaches_the_cases(tmp_path: Path, capsys) -> None:
    out = tmp_path / "perf.json"
    args = ["bench", "perf", "--sizes", "24", "--agents", "3", "--kinds", "open", "--skip-live"]
    assert main([*args, "--far-transit-recheck", "4", "--json", str(out)]) == 0
    (row,) = json.loads(out.read_text())["planner"]
    assert row["far_transit_recheck"] == 4 and row["coverage_pct"] == 100.0
    assert "far_transit_recheck 4" in capsys.readouterr().out


def test_a_case_over_its_limit_is_reported_not_waited_for(tmp_path: Path, capsys) -> None:
    """Stopped at its limit, with how far it got (its coverage reported meanwhile)."""
    out = tmp_path / "perf.json"
    args = ["bench", "perf", "--sizes", "300", "--agents", "50", "--kinds", "rooms"]
    code = main([*args, "--skip-live", "--case-limit", "4", "--json", str(out)])
    assert code == 1
    (row,) = json.loads(out.read_text())["planner"]
    assert row["error"] == "over 4 s"
    assert 0 <= row["coverage_pct"] < 100 and row["iterations"] > 0
    assert f"{row['coverage_pct']:.1f}" in capsys.readouterr().out


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--sizes", "ten"], "--sizes: expected comma-separated numbers, got 'ten'"),
        (["--agents", "0"], "--agents: expected positive numbers, got '0'"),
        (["--kinds", "caves"], "--kinds: choose from rooms, open, got 'caves'"),
        (["--far-transit-recheck", "0"], "--far-transit-recheck must be a positive number"),
    ],
)
def test_bad_options_are_refused(args: list[str], message: str, capsys) -> None:
    assert main(["bench", "perf", *args]) == 2
    assert message in capsys.readouterr().err


def test_the_live_mission_gives_every_vehicle_work_on_loopback(tmp_path: Path) -> None:
    mission = load_mission(write_live_mission(tmp_path, 16))
    assert len(mission.fleet) == 16
    assert all(v.connection.startswith("udpin:127.0.0.1:") for v in mission.fleet)
    assert len({v.connection for v in mission.fleet}) == 16
    assert live_map(16).free_count >= 25 * 16
