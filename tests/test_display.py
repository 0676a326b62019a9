"""The live display's title line says what the fleet is doing."""

from __future__ import annotations

from types import SimpleNamespace

from gcs.live.display import LiveDisplay


def test_title_tells_covering_from_going_home_and_from_an_abort() -> None:
    coordinator = SimpleNamespace(belief=SimpleNamespace(covered_count=10), coverage_complete=False)
    planner = SimpleNamespace(record=SimpleNamespace(free_cells=40), coordinator=coordinator)
    run = SimpleNamespace(
        mission=SimpleNamespace(name="demo"), planner=planner, elapsed_s=20.0, aborted=False
    )
    title = LiveDisplay(quiet=True)._title
    assert title(run).plain == "demo: 10/40 cells (25%), mission time 0:20, ~1:00 to cover the rest"
    run.aborted = True
    assert title(run).plain.endswith(", aborted, going home")
    run.aborted, coordinator.coverage_complete = False, True
    assert title(run).plain.endswith(", coverage complete, going home")
