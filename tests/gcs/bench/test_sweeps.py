"""``gcs bench plans`` on Dask: through a cluster the test starts on loopback, the same
table and JSON as a run in this process, and a run that fails in a worker reported."""

from __future__ import annotations

import contextlib
import json
import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from distributed import LocalCluster

from gcs.bench import paper as bench_paper
from gcs.bench.sweeps import Failed, Where, run_sweep
from gcs.cli import main

pytestmark = pytest.mark.timeout(120)

TINY = ["--kinds", "open", "--sizes", "20", "--agents", "2,3", "--seeds", "1,2"]


@pytest.fixture
def scheduler() -> Iterator[str]:
    """A scheduler and two workers in this process (threads), on loopback, no dashboard:
    the address of an existing cluster, as ``--scheduler`` takes it."""
    with LocalCluster(
        n_workers=2,
        threads_per_worker=1,
        processes=False,
        protocol="tcp",
        host="127.0.0.1",
        dashboard_address=None,
        scheduler_kwargs={"dashboard_address": "127.0.0.1:0"},
    ) as cluster:
        yield cluster.scheduler_address


def _figures(path: Path) -> dict[str, Any]:
    """The JSON's runs without their timings (the only figures that may differ)."""
    runs = json.loads(path.read_text())["runs"]
    return {
        label: [{k: v for k, v in r.items() if k != "planner_s"} for r in found]
        for label, found in runs.items()
    }


def _runs_table(printed: str) -> str:
    """The runs table as printed (the summary after it holds timings)."""
    return printed[: printed.index("variant / base")]


def test_a_cluster_gives_the_same_runs_as_this_process(
    tmp_path: Path, scheduler: str, capsys
) -> None:
    args = ["bench", "plans", *TINY, "--set", "hold_radius=0"]
    here, there = tmp_path / "here.json", tmp_path / "there.json"
    assert main([*args, "--jobs", "1", "--json", str(here)]) == 0
    printed_here = capsys.readouterr().out
    assert main([*args, "--scheduler", scheduler, "--json", str(there)]) == 0
    printed_there = capsys.readouterr()
    assert _figures(there) == _figures(here)
    assert [r["seed"] for r in _figures(there)["base"]] == [1, 2, 1, 2]  # the cases' order
    assert _runs_table(printed_there.out) == _runs_table(printed_here)
    assert "[8/8] " in printed_there.err


def test_a_local_cluster_gives_the_same_runs(tmp_path: Path) -> None:
    here, there = tmp_path / "here.json", tmp_path / "there.json"
    assert main(["bench", "plans", *TINY, "--jobs", "1", "--json", str(here)]) == 0
    assert main(["bench", "plans", *TINY, "--jobs", "2", "--json", str(there)]) == 0
    assert _figures(there) == _figures(here)


@pytest.mark.usefixtures("planner_failing_on_seed_2")
def test_a_run_failing_in_a_worker_is_reported_and_the_others_kept(
    tmp_path: Path, scheduler: str, capsys
) -> None:
    """The workers are threads of this process, so the patched planner run is theirs."""
    out = tmp_path / "plans.json"
    assert main(["bench", "plans", *TINY, "--scheduler", scheduler, "--json", str(out)]) == 1
    rows = _figures(out)["base"]
    assert [(r["seed"], r.get("error")) for r in rows] == [
        (1, None),
        (2, "RuntimeError: planner bug"),
        (1, None),
        (2, "RuntimeError: planner bug"),
    ]
    assert all(r["complete"] for r in rows if "error" not in r)
    captured = capsys.readouterr()
    assert captured.err.count("failed: RuntimeError: planner bug") == 2
    assert "failed" in captured.out  # in the runs table


def test_a_worker_that_dies_fails_its_run_alone() -> None:
    """A run that ends its worker's process (here ``os._exit``) is a failure in its
    place; the other runs still answer."""
    jobs = [7, 0, 8, 9]
    with contextlib.closing(run_sweep(_exit_on_zero_else_echo, jobs, Where(2))) as sweep:
        answers = dict(sweep)
    assert answers == {
        0: 7,
        1: Failed("KilledWorker: the worker running it died"),
        2: 8,
        3: 9,
    }


def _exit_on_zero_else_echo(job: int) -> int:
    if job == 0:
        os._exit(3)
    return job


PAPER = ["bench", "paper", "--agents", "1", "3"]


def _paper_figures(path: Path) -> dict[str, Any]:
    """The tables' rows without their timings."""
    figures = json.loads(path.read_text())
    timings = ("planner_s", "us_per_agent_step")
    return {
        "table1": [{k: v for k, v in r.items() if k not in timings} for r in figures["table1"]],
        "table2": figures["table2"],
    }


def test_the_paper_tables_on_a_cluster_are_the_same(tmp_path: Path, scheduler: str) -> None:
    here, there = tmp_path / "here.json", tmp_path / "there.json"
    assert main([*PAPER, "--jobs", "1", "--json", str(here)]) == 0
    assert main([*PAPER, "--scheduler", scheduler, "--json", str(there)]) == 0
    assert _paper_figures(there) == _paper_figures(here)
    each = len(bench_paper.STRATEGIES)
    assert [r["agents"] for r in _paper_figures(there)["table1"]] == [1] * each + [3] * each


def test_a_paper_run_that_fails_is_a_failed_row(
    tmp_path: Path, scheduler: str, monkeypatch, capsys
) -> None:
    real = bench_paper.simulate

    def failing_alone(mission, options):
        if len(mission.fleet) == 1:
            raise RuntimeError("planner bug")
        return real(mission, options)

    monkeypatch.setattr(bench_paper, "simulate", failing_alone)
    out = tmp_path / "paper.json"
    assert main([*PAPER, "--scheduler", scheduler, "--json", str(out)]) == 1
    figures = json.loads(out.read_text())
    each = len(bench_paper.STRATEGIES)
    errors = [r.get("error") for r in figures["table1"]]
    assert errors == ["RuntimeError: planner bug"] * each + [None] * each
    assert all(r["complete"] for r in figures["table2"])
    captured = capsys.readouterr()
    assert captured.err.count("failed: RuntimeError: planner bug") == each
    assert "failed" in captured.out  # in Table 1
