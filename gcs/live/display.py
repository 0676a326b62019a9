"""The operator's live view: one row per vehicle, coverage, time, and warnings as they come.

Display only: it reads the ``LiveRun`` the mission keeps up to date and
never talks to a vehicle or the planner. ``quiet`` shows nothing (tests,
scripts); errors still go to stderr.

Times are mission time, as in the mission log (seconds since the ground station
connected, on the vehicles' clock: faster than real time under a speed-up, which
the title says), so that a message seen here is found at the same mission time
in the log (``t_s`` of its event in Foxglove's Log panel, stamped the wall clock
at the start plus that time).
"""

from __future__ import annotations

from types import TracebackType

from rich import box
from rich.console import Console, Group
from rich.live import Live
from rich.table import Table
from rich.text import Text

from gcs.live.run import LiveRun
from gcs.live.shared import Level, Phase, VehicleView
from gcs.live.status import activity, mission_progress
from vehicles.link import RejectedFrames

REFRESH_HZ = 4
_PHASE_STYLE = {
    Phase.LOST: "bold red",
    Phase.LINK_LOST: "yellow",
    Phase.CHARGING: "cyan",
    Phase.DONE: "green",
    Phase.FLYING_HOME: "magenta",
    Phase.ABORTED: "red",
}
_LEVEL_STYLE = {Level.INFO: "dim", Level.WARNING: "yellow", Level.ERROR: "bold red"}

#: The planner's modes (``AgentMode`` values) in a few words: why the vehicle does what
#: it does (transit: to a backtracking point, where uncovered cells start; homing: the
#: coverage is complete).
_TASK = {
    "exploring": "exploring",
    "transit": "to a new area",
    "returning": "to charge",
    "charging": "charging",
    "idle": "idle",
    "homing": "going home",
    "done": "done",
    "lost": "lost",
}
#: Header and justification of each column: short, and the table drawn without borders,
#: so that it fits 80 columns (a terminal's, a pipe's) but for long details (those wrap).
COLUMNS = (
    ("vehicle", "left"),
    ("activity", "left"),
    ("planner task", "left"),
    ("cell\n(row, col)", "left"),
    ("battery", "right"),
    ("%/m est.", "right"),
    ("charges", "right"),
)
#: The line under the table that says what its two state columns mean.
LEGEND = "activity: what the vehicle is doing; planner task: what the planner has it do"


#: How the display names each reason a frame was thrown away.
_REJECTED_LABELS = (
    ("bad_frames", "bad"),
    ("bad_signatures", "bad signature"),
    ("unknown_messages", "unknown id"),
    ("foreign_frames", "foreign"),
    ("implausible", "implausible values"),
    ("other_address", "from a second address"),
)


def _rejected_caption(run: LiveRun) -> str | None:
    """Frames each link and connection threw away (garbage, strangers), or None while
    there are none."""
    counted: list[tuple[str, RejectedFrames]] = [
        (f"vehicle {sysid}", link.rejected)
        for sysid, link in sorted(list(run.links.items()))  # list(): the loop may add links
    ]
    if run.network is not None:
        counted += [(name, c.rejected) for name, c in list(run.network.connections.items())]
    parts = []
    for name, counts in counted:
        if counts.total:
            text = ", ".join(
                f"{getattr(counts, field)} {label}"
                for field, label in _REJECTED_LABELS
                if getattr(counts, field)
            )
            parts.append(f"{name}: {text}")
    return "rejected frames: " + "; ".join(parts) if parts else None


def _task(view: VehicleView) -> str:
    return _TASK.get(view.mode, view.mode) or "-"


def _clock(seconds: float) -> str:
    m, s = divmod(int(max(0.0, seconds)), 60)
    h, m = divmod(m, 60)
    return f"{h}:{m:02d}:{s:02d}" if h else f"{m}:{s:02d}"


def _speed(run: LiveRun) -> str:
    """`` (10x real time)``: how the mission clock runs, if it is known."""
    speedup = getattr(run.clock, "speedup", None)
    if speedup is None:
        return ""
    return " (real time)" if speedup == 1 else f" ({speedup:g}x real time)"


def mission_time(run: LiveRun) -> float | None:
    """Mission seconds as the log counts them (None before the planner starts)."""
    planner = run.planner
    return None if planner is None else planner.t_s


class LiveDisplay:
    def __init__(self, quiet: bool = False, console: Console | None = None) -> None:
        self.quiet = quiet
        self.console = console or Console(stderr=False)
        self.errors = Console(stderr=True)
        self.run: LiveRun | None = None
        self._live: Live | None = None
        self.messages: list[tuple[Level, str]] = []

    # -- wiring -----------------------------------------------------------------------

    def attach(self, run: LiveRun) -> None:
        self.run = run

    def notify(self, text: str, level: Level, sysid: int | None) -> None:
        """A message for the operator: printed above the live table as it happens."""
        self.messages.append((level, text))
        if self.quiet:
            if level == Level.ERROR:
                self.errors.print(Text(f"error: {text}"), highlight=False)
            return
        t_s = None if self.run is None else mission_time(self.run)
        stamp = "-:--" if t_s is None else _clock(t_s)
        line = Text(f"[{stamp}] {text}", style=_LEVEL_STYLE[level])
        if self._live is not None:
            self._live.console.print(line)
        else:
            self.console.print(line)

    def __enter__(self) -> LiveDisplay:
        if not self.quiet:
            # Rich redraws from its own thread, calling ``render`` (which only reads).
            self._live = Live(
                console=self.console,
                get_renderable=self.render,
                refresh_per_second=REFRESH_HZ,
                transient=False,
            )
            self._live.__enter__()
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        if self._live is not None:
            self._live.refresh()
            self._live.__exit__(exc_type, exc, tb)
            self._live = None
            if not self.console.is_terminal:
                # Rich ends its last table without a newline in a pipe or a file: the
                # next line written (an error on stderr) would be glued to its border.
                self.console.line()

    # -- drawing ----------------------------------------------------------------------

    def render(self) -> Group | Text:
        run = self.run
        if run is None:
            return Text("connecting...")
        table = Table(
            expand=False,
            box=box.SIMPLE_HEAD,
            show_edge=False,
            pad_edge=False,
            collapse_padding=True,
        )
        for name, justify in COLUMNS:
            wraps = name in ("activity", "planner task")
            table.add_column(name, justify=justify, no_wrap=not wraps)  # type: ignore[arg-type]
        for view in run.views.values():
            battery = "-" if view.battery_pct is None else f"{view.battery_pct:.0f}%"
            energy = "-" if view.energy_pct_per_m is None else f"{view.energy_pct_per_m:.3f}"
            table.add_row(
                f"{view.sysid} {view.kind}",
                Text(activity(view), style=_PHASE_STYLE.get(view.phase, "")),
                _task(view),
                "-" if view.cell is None else f"{view.cell[0]}, {view.cell[1]}",
                battery,
                energy,
                str(view.charges),
            )
        # Above and below the table, not its title and caption: those wrap at its width.
        below = [Text(LEGEND, style="dim")]
        rejected = _rejected_caption(run)
        if rejected is not None:
            below.append(Text(rejected, style="yellow"))
        return Group(self._title(run), table, *below)

    def _title(self, run: LiveRun) -> Text:
        progress = mission_progress(run)
        planner = run.planner
        if progress is None or planner is None:
            return Text(f"{run.mission.name}: getting ready")
        parts = [
            f"{progress.covered}/{progress.free} cells ({progress.pct:.0f}%)",
            f"mission time {_clock(planner.t_s)}{_speed(run)}",
        ]
        if progress.time_left_s is not None:
            parts.append(f"~{_clock(progress.time_left_s)} to cover the rest")
        elif progress.state != "covering":
            parts.append(progress.state)
        return Text(f"{run.mission.name}: " + ", ".join(parts))
