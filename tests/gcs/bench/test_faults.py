"""``gcs bench faults``: two real rows on a small mission, the verdicts, bad options."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from gcs.bench.faults import fault_cases, on_free_ports, verdict
from gcs.cli import main
from gcs.mission import load_mission
from tests.gcs.live.test_mission import write_mission

pytestmark = pytest.mark.timeout(300)


#: An open room: a vehicle dying anywhere in it cuts nothing off.
ROOM = "\n".join(["############", *["#..........#"] * 5, "#....C.....#", "############"]) + "\n"


def test_a_dying_vehicle_is_lost_and_the_others_finish(tmp_path: Path, capsys) -> None:
    mission = write_mission(tmp_path, ROOM, [{"type": "rover"}] * 3, energy=0.5)
    out = tmp_path / "faults.json"
    names = [c.name for c in fault_cases(3)]
    rows = [names.index("no fault") + 1, names.index("vehicle dies") + 1]
    code = main(
        ["bench", "faults", "--mission", str(mission), "--speedup", "20", "--strike", "15",
         "--only", ",".join(map(str, rows)), "--case-limit", "120", "--json", str(out)]
    )  # fmt: skip
    got = json.loads(out.read_text())["rows"]
    assert code == 0, got
    assert [r["fault"] for r in got] == ["no fault", "vehicle dies"]
    for r in got:
        assert r["coverage_pct"] == 100.0 and not r["below_reserve"]
        assert r["log"] == "complete"  # the log rebuilds the run's own report
    assert [r["lost"] for r in got] == [0, 1]
    assert "ok, 1 lost as it must be" in capsys.readouterr().out


def test_the_campaign_copies_the_mission_onto_free_ports(tmp_path: Path) -> None:
    copy = load_mission(on_free_ports(Path("missions/demo.yaml"), tmp_path))
    demo = load_mission(Path("missions/demo.yaml"))
    assert [v.connection for v in copy.fleet] != [v.connection for v in demo.fleet]
    assert [(v.sysid, v.type, v.speed_m_s) for v in copy.fleet] == [
        (v.sysid, v.type, v.speed_m_s) for v in demo.fleet
    ]
    assert (copy.map.obstacle == demo.map.obstacle).all() and copy.name == demo.name


def _row(**changes: Any) -> dict[str, Any]:
    row = {"coverage_pct": 100.0, "lost": 0, "expect_lost": 0, "below_reserve": False}
    return {"reserve_eaten_pct": 0.0, "sag_pct": 0.0, **row, **changes}


@pytest.mark.parametrize(
    ("row", "expected"),
    [
        (_row(), "ok"),
        (_row(lost=1, expect_lost=1), "ok, 1 lost as it must be"),
        (_row(lost=1), "FAILED: 1 lost"),
        (_row(lost=0, expect_lost=1), "FAILED: 0 lost"),
        (_row(coverage_pct=99.5), "FAILED: incomplete"),
        (_row(below_reserve=True, reserve_eaten_pct=2.0), "FAILED: below the reserve"),
        (
            _row(below_reserve=True, reserve_eaten_pct=3.0, sag_pct=15.0),
            "ok, a sag ate 3 % of the reserve",
        ),
        (
            _row(below_reserve=True, reserve_eaten_pct=16.0, sag_pct=15.0),
            "FAILED: below the reserve",
        ),
        (_row(error="over 5 s"), "FAILED: over 5 s"),
    ],
)
def test_verdicts(row: dict[str, Any], expected: str) -> None:
    assert verdict(row) == expected


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--only", "0"], "--only: rows are 1..10, got '0'"),
        (["--only", "x"], "--only: expected row numbers like 1,3, got 'x'"),
        (["--speedup", "0"], "--speedup, --case-limit and --strike must be positive"),
        (["--mission", "missions/nope.yaml"], "missions/nope.yaml: cannot read file"),
    ],
)
def test_bad_options_are_refused(args: list[str], message: str, capsys) -> None:
    assert main(["bench", "faults", *args]) == 2
    assert message in capsys.readouterr().err
