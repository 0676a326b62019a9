"""The live display: its title says what the fleet is doing and how its clock runs, its
table names its columns, a rover drives, and it ends its last line in a pipe."""

from __future__ import annotations

import io
from types import SimpleNamespace
from typing import Any

from rich.console import Console

from gcs.live.display import LiveDisplay
from gcs.live.shared import Level, Phase, VehicleView


def _run(**changes: Any) -> SimpleNamespace:
    """What the display reads of a ``LiveRun``: 10 of 40 cells covered in 20 s of flight,
    28 s of mission time (the 8 s before it getting ready), at 10x."""
    coordinator = SimpleNamespace(belief=SimpleNamespace(covered_count=10), coverage_complete=False)
    planner = SimpleNamespace(
        record=SimpleNamespace(free_cells=40, covered_at_start=0),
        coordinator=coordinator,
        t_s=28.0,
    )
    run = SimpleNamespace(
        mission=SimpleNamespace(name="demo"),
        planner=planner,
        clock=SimpleNamespace(speedup=10.0),
        elapsed_s=20.0,
        aborted=False,
        views={},
        links={},
        network=None,
    )
    for key, value in changes.items():
        setattr(run, key, value)
    return run


def test_title_tells_covering_from_going_home_and_from_an_abort() -> None:
    run = _run()
    title = LiveDisplay(quiet=True)._title
    assert title(run).plain == (  # type: ignore[arg-type]
        "demo: 10/40 cells (25%), mission time 0:28 (10x real time), ~1:00 to cover the rest"
    )
    run.aborted = True
    assert title(run).plain.endswith(", aborted, going home")  # type: ignore[arg-type]
    run.aborted, run.planner.coordinator.coverage_complete = False, True
    assert title(run).plain.endswith(", coverage complete, going home")  # type: ignore[arg-type]
    run.views = {1: VehicleView(1, "rover", phase=Phase.DONE)}
    assert title(run).plain.endswith(", coverage complete, every vehicle parked")  # type: ignore[arg-type]


def test_title_at_real_time_and_for_a_resumed_mission() -> None:
    """At speed-up 1 the clock is said to be real time; a resumed mission's pace counts
    only the cells this run covered."""
    run = _run(clock=SimpleNamespace(speedup=1.0))
    run.planner.record.covered_at_start = 6  # 4 covered in 20 s: 30 to go take 2:30
    title = LiveDisplay(quiet=True)._title(run)  # type: ignore[arg-type]
    assert title.plain == (
        "demo: 10/40 cells (25%), mission time 0:28 (real time), ~2:30 to cover the rest"
    )


def _rendered(display: LiveDisplay, run: Any) -> str:
    console = Console(file=io.StringIO(), width=120, color_system=None)
    console.print(display.render())
    out = console.file.getvalue()  # type: ignore[attr-defined]
    assert isinstance(out, str)
    return out


def test_table_names_its_columns_and_says_how_each_vehicle_goes() -> None:
    rover = VehicleView(1, "rover", Phase.FLYING_HOME, "returning", cell=(12, 20))
    copter = VehicleView(2, "copter", Phase.FLYING_HOME, "homing", cell=(3, 4))
    charging = VehicleView(3, "rover", Phase.CHARGING, "charging", detail="45 % by the pad's rate")
    run = _run(views={1: rover, 2: copter, 3: charging})
    display = LiveDisplay(quiet=True)
    display.attach(run)  # type: ignore[arg-type]
    out = _rendered(display, run)
    lines = out.splitlines()
    row = {" ".join(line.split()[:2]): line for line in lines if line[:1].isdigit()}
    assert "driving home (AUTO)" in row["1 rover"] and "to charge" in row["1 rover"]
    assert "12, 20" in row["1 rover"]
    assert "flying home (AUTO)" in row["2 copter"] and "going home" in row["2 copter"]
    assert "charging: 45 % by the pad's rate" in row["3 rover"]
    header = "\n".join(lines[:6])
    for name in ("vehicle", "activity", "planner task", "cell", "(row, col)", "battery"):
        assert name in header
    assert "state" not in header
    legend = [line.rstrip() for line in lines if line.startswith("activity:")]
    assert legend == [
        "activity: what the vehicle is doing; planner task: what the planner has it do"
    ]


def test_messages_are_stamped_with_mission_time() -> None:
    console = Console(file=io.StringIO(), width=120, color_system=None)
    display = LiveDisplay(console=console)
    display.notify("before the start", Level.WARNING, None)
    display.attach(_run())  # type: ignore[arg-type]
    display.notify("vehicle 2 says: Battery 1 is low", Level.WARNING, 2)
    out = console.file.getvalue()  # type: ignore[attr-defined]
    assert out.splitlines() == [
        "[-:--] before the start",
        "[0:28] vehicle 2 says: Battery 1 is low",
    ]


def test_in_a_pipe_the_last_table_ends_its_line() -> None:
    """Rich leaves its last render without a newline when it writes to a file: the error
    line printed next (``gcs run: ...``) was glued to the table's border."""
    out = io.StringIO()
    console = Console(file=out, width=120, color_system=None)
    assert not console.is_terminal
    run = _run(views={1: VehicleView(1, "rover", Phase.DONE, "done")})
    with LiveDisplay(console=console) as display:
        display.attach(run)  # type: ignore[arg-type]
    text = out.getvalue()
    assert "1 rover" in text
    assert text.endswith("\n")
    assert text.rstrip("\n").splitlines()[-1].startswith("activity:")
