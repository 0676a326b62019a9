"""What the benches share: planner settings as KEY=VALUE, and the --json option."""

from __future__ import annotations

from pathlib import Path

import pytest

from gcs.bench.common import parse_settings
from gcs.cli import main
from gcs.errors import UsageError
from planner.settings import BmRule


def test_settings_are_read_as_their_types() -> None:
    parsed = parse_settings(
        ["bm_rule=paper", "hold_radius=8", "resume_pct=90", "charging_slots=null", "spread=false"],
        "set",
    )
    assert parsed == {
        "bm_rule": BmRule.PAPER,
        "hold_radius": 8,
        "resume_pct": 90.0,
        "charging_slots": None,
        "spread": False,
    }


@pytest.mark.parametrize(
    ("pair", "says"),
    [
        ("hold_radius", "expected KEY=VALUE"),
        ("speed=3", "unknown setting 'speed'"),
        ("reserve_pct=10", "unknown setting 'reserve_pct'"),  # the mission's, not a strategy's
        ("bm_rule=zigzag", "choose from paper, tight"),
        ("hold_radius=1.5", "expected int"),
        ("spread=3", "expected bool"),
        ("far_transit_recheck=-1", "must not be negative"),
        ("hold_radius=[1", "cannot read the value"),
    ],
)
def test_a_bad_setting_is_a_usage_error_that_names_it(pair: str, says: str) -> None:
    with pytest.raises(UsageError, match="--set: .*" + says.replace("[", r"\[")):
        parse_settings([pair], "set")


@pytest.mark.parametrize("bench", ["paper", "perf", "plans", "faults", "mavlink"])
def test_every_bench_refuses_a_json_path_it_cannot_write_before_it_runs(
    bench: str, tmp_path: Path, capsys
) -> None:
    for where, says in [
        (tmp_path / "none" / "figures.json", "no folder"),
        (tmp_path, "is a folder, not a file"),
    ]:
        with pytest.raises(SystemExit) as exit_:
            main(["bench", bench, "--json", str(where)])
        assert exit_.value.code == 2
        err = capsys.readouterr().err
        assert "argument --json:" in err and says in err
