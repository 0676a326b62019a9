"""``gcs bench plans``: strategies compared on generated maps, end to end on tiny ones."""

from __future__ import annotations

import json
import math
import time
from pathlib import Path

import pytest

from gcs.bench.plans import paper_bars, summarise
from gcs.cli import main
from sitl_mock.maps import load_map
from tests.processes import ctrl_c, gcs_process

pytestmark = pytest.mark.timeout(120)

TINY = ["--sizes", "24", "--agents", "3", "--seeds", "1,2", "--jobs", "2"]


def test_a_variant_is_compared_run_by_run_and_in_the_mean(tmp_path: Path, capsys) -> None:
    out = tmp_path / "plans.json"
    args = ["bench", "plans", *TINY, "--kinds", "rooms,open", "--set", "hold_radius=0"]
    assert main([*args, "--json", str(out)]) == 0
    figures = json.loads(out.read_text())
    base, variant = figures["runs"]["base"], figures["runs"]["variant"]
    assert len(base) == len(variant) == 4
    for row in base + variant:
        assert row["complete"] and row["lost"] == 0
    assert figures["strategies"]["variant"] == {"hold_radius": "0"}
    key = lambda r: (r["kind"], r["seed"])  # noqa: E731
    by_case = {key(r): r for r in base}
    for pair in figures["pairs"]:
        was = by_case[key(pair)]
        now = next(r for r in variant if key(r) == key(pair))
        assert pair["path_ratio"] == pytest.approx(
            now["path_per_free_cell"] / was["path_per_free_cell"]
        )
        assert pair["same_plan"] == (now["tracks"] == was["tracks"])
    (everything,) = (s for s in figures["summary"] if s["group"] == "all")
    ratios = [p["path_ratio"] for p in figures["pairs"]]
    assert everything["path_ratio"] == pytest.approx(math.prod(ratios) ** (1 / len(ratios)))
    printed = capsys.readouterr().out
    assert "geometric means" in printed and "rooms 24x24" in printed


def test_the_same_settings_give_the_same_plans(tmp_path: Path) -> None:
    """The base run again as the variant (a setting at its default): cell for cell the
    same plan, and ratios of 1; a speed-only change is checked this way."""
    out = tmp_path / "plans.json"
    args = ["bench", "plans", *TINY, "--kinds", "caves", "--set", "patience=2"]
    assert main([*args, "--json", str(out)]) == 0
    (everything,) = (s for s in json.loads(out.read_text())["summary"] if s["group"] == "all")
    assert everything["same_plans"] == everything["runs"] == 2
    assert everything["path_ratio"] == everything["iterations_ratio"] == 1.0


def test_the_base_alone_prints_its_runs(tmp_path: Path, capsys) -> None:
    out = tmp_path / "plans.json"
    assert main(["bench", "plans", *TINY, "--kinds", "open", "--json", str(out)]) == 0
    figures = json.loads(out.read_text())
    assert list(figures["runs"]) == ["base"] and "pairs" not in figures
    assert "geometric means" not in capsys.readouterr().out


def test_ctrl_c_keeps_the_runs_finished(tmp_path: Path) -> None:
    """Interrupted with a long run still going: the runs finished so far are printed
    and written, the exit status is 130, and no worker is left behind."""
    out = tmp_path / "plans.json"
    args = ["bench", "plans", "--kinds", "rooms", "--sizes", "24,600", "--agents", "3"]
    args += ["--seeds", "1", "--jobs", "2", "--set", "hold_radius=0", "--json", str(out)]
    with gcs_process(*args) as process:
        assert process.stderr is not None
        deadline = time.monotonic() + 60
        seen = ""
        while "[2/4]" not in seen:  # the small map, under both settings
            assert time.monotonic() < deadline and process.poll() is None, seen
            seen += process.stderr.readline()
        workers = _descendants(process.pid)  # the local Dask cluster's processes
        assert workers
        stdout, stderr = ctrl_c(process)
    assert process.returncode == 130, stderr
    assert "interrupted: 2 runs finished are kept" in stderr
    assert "Traceback" not in stderr
    figures = json.loads(out.read_text())
    assert figures["interrupted"] is True
    assert [(r["size"], r["complete"]) for r in figures["runs"]["base"]] == [(24, True)]
    assert [p["size"] for p in figures["pairs"]] == [24]
    assert "rooms 24x24" in stdout and "rooms 600x600" not in stdout
    deadline = time.monotonic() + 10
    while any(Path(f"/proc/{pid}").exists() for pid in workers):
        assert time.monotonic() < deadline, "workers left running"
        time.sleep(0.1)


def _descendants(pid: int) -> list[int]:
    """The processes started by ``pid``, and theirs (Linux's /proc)."""
    children: dict[int, list[int]] = {}
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue  # ended meanwhile
        children.setdefault(int(fields[1]), []).append(int(stat.parent.name))
    found: list[int] = []
    todo = [pid]
    while todo:
        kids = children.get(todo.pop(), [])
        found += kids
        todo += kids
    return found


@pytest.mark.usefixtures("planner_failing_on_seed_2")
def test_a_failed_run_is_reported_and_the_others_kept(tmp_path: Path, capsys) -> None:
    out = tmp_path / "plans.json"
    args = ["bench", "plans", "--kinds", "open", *TINY, "--jobs", "1", "--set", "hold_radius=0"]
    assert main([*args, "--json", str(out)]) == 1
    figures = json.loads(out.read_text())
    for label in ("base", "variant"):
        rows = {r["seed"]: r for r in figures["runs"][label]}
        assert rows[2]["error"] == "RuntimeError: planner bug"
        assert rows[1]["complete"] and "error" not in rows[1]
    assert [p["seed"] for p in figures["pairs"]] == [1]
    captured = capsys.readouterr()
    assert "failed: RuntimeError: planner bug" in captured.err
    assert "failed" in captured.out  # in the runs table


def test_bad_options_exit_2_before_any_run(capsys) -> None:
    assert main(["bench", "plans", "--kinds", "mazes"]) == 2
    assert main(["bench", "plans", "--sizes", "3"]) == 2
    assert main(["bench", "plans", "--jobs", "0"]) == 2
    err = capsys.readouterr().err
    assert "--kinds: choose from rooms, caves, open" in err
    assert "at least 5 cells a side" in err
    assert "[1/" not in err  # nothing ran


def test_means_are_taken_per_group_and_over_all() -> None:
    pairs = [
        {"kind": "rooms", "size": 9, "agents": 2, "path_ratio": r, "iterations_ratio": 1.0}
        | {"planner_s_ratio": 1.0, "same_plan": False}
        for r in (0.5, 2.0)
    ] + [
        {"kind": "open", "size": 9, "agents": 2, "path_ratio": 4.0, "iterations_ratio": 2.0}
        | {"planner_s_ratio": 1.0, "same_plan": True}
    ]
    summary = {s["group"]: s for s in summarise(pairs)}
    assert summary["rooms 9x9, 2 agents"]["path_ratio"] == pytest.approx(1.0)
    assert summary["open 9x9, 2 agents"]["same_plans"] == 1
    assert summary["all"]["path_ratio"] == pytest.approx(4.0 ** (1 / 3))
    assert summary["all"]["runs"] == 3


def test_the_papers_bar_maps_run_without_a_battery_limit(tmp_path: Path) -> None:
    """``--kinds bars --battery none`` is the paper's Table 2: seed 9 at 30x30 is bob30's
    map, and with no battery limit nobody charges; ``--seeds`` takes a range."""
    bob30 = load_map(Path(__file__).parents[3] / "missions" / "maps" / "bob30.txt")
    bars = paper_bars(30, 30, 9)
    assert (bars.obstacle == bob30.obstacle).all() and bars.charger == bob30.charger
    out = tmp_path / "plans.json"
    args = ["bench", "plans", "--kinds", "bars,branching", "--sizes", "30", "--agents", "4"]
    args += ["--seeds", "8-9", "--battery", "none", "--jobs", "1", "--json", str(out)]
    assert main(args) == 0
    figures = json.loads(out.read_text())
    rows = figures["runs"]["base"]
    assert figures["battery"] == "none"
    assert [(r["kind"], r["seed"]) for r in rows] == [
        ("bars", 8),
        ("bars", 9),
        ("branching", 8),
        ("branching", 9),
    ]
    assert all(r["complete"] and r["lost"] == 0 and r["charges"] == 0 for r in rows)
    assert main([*args[:-2], "--seeds", "9-x"]) != 0
