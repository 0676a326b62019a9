"""The operator's live view: one row per vehicle, coverage, time, and warnings as they come.

Display only: it reads the ``LiveRun`` the mission keeps up to date and
never talks to a vehicle or the planner. ``quiet`` shows nothing (tests,
scripts); errors still go to stderr.
"""

from __future__ import annotations

from types import TracebackType

from rich.console import Console, Group
from rich.live import Live
from rich.table import Table
from rich.text import Text

from gcs.live.mission import LiveRun
from gcs.live.shared import Level, Phase, VehicleView
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


def _state(view: VehicleView) -> str:
    """The phase, and what the vehicle waits for in it (``waiting: GPS fix``)."""
    if not view.detail:
        return view.phase.value
    return f"{view.phase.value}: {view.detail}"


def _clock(seconds: float) -> str:
    m, s = divmod(int(seconds), 60)
    h, m = divmod(m, 60)
    return f"{h}:{m:02d}:{s:02d}" if h else f"{m}:{s:02d}"


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
        stamp = _clock(self.run.elapsed_s) if self.run is not None else "-:--"
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

    # -- drawing ----------------------------------------------------------------------

    def render(self) -> Group | Text:
        run = self.run
        if run is None:
            return Text("connecting...")
        table = Table(
            expand=False,
            title=self._title(run),
            title_justify="left",
            caption=_rejected_caption(run),
            caption_justify="left",
            caption_style="yellow",
        )
        for name, justify in (
            ("vehicle", "right"),
            ("type", "left"),
            ("state", "left"),
            ("planner", "left"),
            ("cell", "left"),
            ("battery", "right"),
            ("%/m est.", "right"),
            ("charges", "right"),
        ):
            table.add_column(name, justify=justify)  # type: ignore[arg-type]
        for view in run.views.values():
            battery = "-" if view.battery_pct is None else f"{view.battery_pct:.0f}%"
            energy = "-" if view.energy_pct_per_m is None else f"{view.energy_pct_per_m:.3f}"
            table.add_row(
                str(view.sysid),
                view.kind,
                Text(_state(view), style=_PHASE_STYLE.get(view.phase, "")),
                view.mode,
                "-" if view.cell is None else f"{view.cell[0]},{view.cell[1]}",
                battery,
                energy,
                str(view.charges),
            )
        return table

    def _title(self, run: LiveRun) -> Text:
        planner = run.planner
        elapsed = run.elapsed_s
        if planner is None:
            return Text(f"{run.mission.name}: getting ready")
        record = planner.record
        covered = planner.coordinator.belief.covered_count
        free = max(1, record.free_cells)
        pct = 100.0 * min(covered, free) / free
        left = ""
        if run.aborted:
            left = "aborted, going home"
        elif planner.coordinator.coverage_complete:
            left = "coverage complete, going home"
        elif covered > 1 and elapsed > 0:
            left = f"~{_clock((free - covered) * elapsed / covered)} to cover the rest"
        return Text(
            f"{run.mission.name}: {covered}/{free} cells ({pct:.0f}%), "
            f"mission time {_clock(elapsed)}, {left}"
        )
