"""PNG figures of a finished run, after the paper's Figures 7, 10, 12 and 13.

Every figure is meant to be read without the README: axes carry units, legends
use plain words and sit outside the plotting area, and the two plots over time
(battery and explored area) share one clock, named the same on both:

* a live run (``gcs run``): mission time in seconds. A live result does not
  stamp its samples, so the times come from the mission log beside it (see
  :func:`timeline`);
* an offline plan (``gcs plan``): the plan's step, in which every vehicle moves
  at most one cell; with ``--timed``, the mission time the plan predicts.

Only ``matplotlib.figure.Figure`` objects with the Agg canvas are used, never
pyplot, so drawing holds no global state and works without a display or in
threads.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib import colormaps
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.colors import to_rgb
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch
from matplotlib.ticker import FixedLocator, MaxNLocator
from numpy.typing import ArrayLike

from core.cells import Cell, CellState
from core.geo import cell_centre_local
from gcs.log.reader import LogContents, LogError, VehicleState, read_contents
from gcs.outcome.result import AgentTrace, RunResult

COVERAGE_PNG = "coverage.png"
PATH_LENGTH_PNG = "path_length.png"
BATTERY_PNG = "battery.png"
EXPLORED_PNG = "explored.png"
#: The mission log's name in an output folder, as the commands write it.
MISSION_LOG = "mission.mcap"

DPI = 150
#: Map colours (RGB) of the coverage figure.
OBSTACLE_RGB = (0.0, 0.0, 0.0)
UNKNOWN_RGB = (0.6, 0.6, 0.6)
COVERED_RGB = (1.0, 1.0, 1.0)
UNCOVERED_RGB = (1.0, 0.85, 0.2)
CHARGER_COLOUR = "tab:blue"
BTP_COLOUR = "red"
RESERVE_COLOUR = "red"
COVERED_AT_COLOUR = "0.3"
#: Longest side of the coverage figure's map, in inches.
MAP_INCHES = 8.0
#: Maps at most this many cells on a side get per-cell gridlines.
GRIDLINE_MAX_CELLS = 60

#: Time-axis labels: one of them is on every plot over time of a run.
STEP_LABEL = "plan step (in one step every vehicle moves at most one cell)"
TIME_LABEL = "mission time [s]"
PREDICTED_TIME_LABEL = "mission time [s], as the plan predicts it"
NO_TIMES_TEXT = (
    "This run's result does not say when its samples were taken,\n"
    "and its mission log was not found beside the figures."
)

BTP_LABEL = "backtracking point\n(a gap passed by, to come back to)"
BTP_OPEN_LABEL = "backtracking point\nnobody came back to"

RGB = tuple[float, float, float]
AgentColours = dict[int, RGB]


def _title(result: RunResult, what: str) -> str:
    n = len(result.agents)
    return f"{result.mission}: {what} ({n} vehicle{'s' if n != 1 else ''})"


def agent_colours(result: RunResult) -> AgentColours:
    """One distinct colour per vehicle id, the same in every figure.

    Blue and red are skipped for small fleets because they mean the charger
    and the backtracking points on the coverage map.
    """
    ids = [a.id for a in result.agents]
    if len(ids) <= 8:
        palette = ["tab:orange", "tab:green", "tab:purple", "tab:brown"]
        palette += ["tab:pink", "tab:olive", "tab:cyan", "tab:gray"]
        return {aid: to_rgb(palette[i]) for i, aid in enumerate(ids)}
    cmap = colormaps["turbo"]
    return {aid: cmap(0.05 + 0.9 * i / (len(ids) - 1))[:3] for i, aid in enumerate(ids)}


def _lighter(rgb: RGB, amount: float = 0.55) -> RGB:
    """``rgb`` mixed towards white by ``amount``."""
    r, g, b = rgb
    return (r + (1 - r) * amount, g + (1 - g) * amount, b + (1 - b) * amount)


def _new_figure(size: tuple[float, float]) -> Figure:
    fig = Figure(figsize=size, dpi=DPI, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def _save(fig: Figure, path: Path) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, format="png", dpi=DPI)
    return path


#: Legend rows (8 pt text) that fit in an inch of figure height.
_LEGEND_ROWS_PER_INCH = 5.0
#: Width of one legend column of "vehicle NN" entries.
_LEGEND_COLUMN_INCHES = 1.3


def _legend_columns(entries: int, height_in: float) -> int:
    rows = max(1, int(height_in * _LEGEND_ROWS_PER_INCH))
    return -(-entries // rows)


def _side_legend(fig: Figure, handles: list) -> None:
    """The figure's legend, right of every axes and their labels (the layout makes room
    for it), in as many columns as the figure's height needs: a fleet of 64 in one
    column is taller than the figure."""
    fig.legend(
        handles=handles,
        loc="outside right upper",
        fontsize=8,
        frameon=False,
        ncols=_legend_columns(len(handles), fig.get_figheight()),
    )


def _vehicle_label(agent: AgentTrace) -> str:
    return f"vehicle {agent.id}" + (" (lost)" if agent.lost else "")


# --------------------------------------------------------------------------- time axis


@dataclass(frozen=True)
class Series:
    """Samples ``y`` taken at times ``x`` (on a :class:`Timeline`'s clock)."""

    x: np.ndarray
    y: np.ndarray


@dataclass(frozen=True)
class Timeline:
    """A run's series over time, all on one clock, so that every plot over time
    shows the same moments at the same places."""

    label: str
    battery: dict[int, Series]
    covered: Series
    #: When the last free cell was covered, or None if that never happened.
    covered_at: float | None
    end: float

    def when(self, value: float) -> str:
        """A moment on this clock, in words."""
        return f"step {value:.0f}" if self.label == STEP_LABEL else f"{value:.0f} s"


def timeline(result: RunResult, log: LogContents | None = None) -> Timeline | None:
    """The run's battery and coverage series on one clock; None when it cannot be known.

    A plan's samples are one per step (or per tick of ``--timed``). A live run's
    result orders its samples but does not stamp them, and a result rebuilt from
    a cut log holds no clock of its own: both need the mission log they came
    from (``log``).
    """
    live = bool(result.extra.get("live")) or (log is not None and _is_live_log(log))
    if live:
        return None if log is None else _live_timeline(result, log)
    if result.interrupted and log is None:
        return None
    return _plan_timeline(result)


def _is_live_log(log: LogContents) -> bool:
    """Only a live run logs the MAVLink frames it exchanged."""
    return any(topic.startswith("/mavlink/") for topic in log.topics)


def _plan_clock(result: RunResult) -> tuple[float, str]:
    """Duration of one sample of a plan and the axis label that goes with it."""
    ticks = float(result.extra.get("total_iterations", 0))
    mission_s = float(result.extra.get("mission_s", 0.0))
    if ticks > 0 and mission_s > 0:
        return mission_s / ticks, PREDICTED_TIME_LABEL
    return 1.0, STEP_LABEL


def _plan_timeline(result: RunResult) -> Timeline:
    scale, label = _plan_clock(result)
    battery = {
        a.id: Series(np.arange(len(a.battery_pct)) * scale, np.asarray(a.battery_pct, float))
        for a in result.agents
    }
    covered = np.asarray(result.covered_per_iteration, dtype=float)
    if result.covered_cells < result.free_cells or result.free_cells == 0:
        covered_at = None
    elif "coverage_s" in result.extra:
        covered_at = float(result.extra["coverage_s"])
    else:
        covered_at = result.iterations * scale
    samples = max([len(covered), *(len(a.battery_pct) for a in result.agents)])
    return Timeline(
        label=label,
        battery=battery,
        covered=Series(np.arange(len(covered)) * scale, covered),
        covered_at=covered_at,
        end=max(samples - 1, 1) * scale,
    )


def _live_timeline(result: RunResult, log: LogContents) -> Timeline | None:
    """Mission times from the log's vehicle states, one per arrival; None when the log
    does not match the result (another run's log)."""
    end = float(result.extra.get("mission_s", 0.0))
    end = max([end, *(s.t_s for states in log.states.values() for s in states)])
    battery: dict[int, Series] = {}
    for agent in result.agents:
        logged = log.states.get(agent.id, [])
        if result.interrupted:
            times = _logged_times(agent, logged)
        else:
            times = _sample_times(agent, logged, end)
        if times is None:
            return None
        battery[agent.id] = Series(times, np.asarray(agent.battery_pct, dtype=float))
    covered = _covered_series(result, log)
    if covered is None:
        return None
    coverage_s = float(result.extra.get("coverage_s", -1.0))
    return Timeline(
        label=TIME_LABEL,
        battery=battery,
        covered=covered,
        covered_at=coverage_s if coverage_s >= 0 and not result.interrupted else None,
        end=max(end, 1.0),
    )


def _logged_times(agent: AgentTrace, logged: list[VehicleState]) -> np.ndarray | None:
    """A result rebuilt from a cut log: its samples are the log's states, in order."""
    if len(logged) < len(agent.battery_pct):
        return None
    return np.array([s.t_s for s in logged[: len(agent.battery_pct)]], dtype=float)


def _sample_times(agent: AgentTrace, logged: list[VehicleState], end: float) -> np.ndarray | None:
    """Mission time of each of a live vehicle's samples.

    Sample 0 is the start (time 0). Every arrival is in the log with its time;
    the samples taken while on the charger are not, and are spread evenly
    between the stamped samples around them (the last ones up to the mission's
    end). None when the log's arrivals are not the vehicle's.
    """
    if not agent.battery_pct:
        return np.empty(0) if not logged else None
    times = np.full(len(agent.battery_pct), np.nan)
    times[0] = 0.0
    j = 0
    for i in range(1, len(times)):
        if j < len(logged) and _same_sample(agent, i, logged[j]):
            times[i] = logged[j].t_s
            j += 1
    if j != len(logged):
        return None
    if np.isnan(times[-1]):
        times[-1] = max(end, float(np.nanmax(times)))
    known = np.flatnonzero(~np.isnan(times))
    return np.interp(np.arange(len(times)), known, times[known])


def _same_sample(agent: AgentTrace, i: int, state: VehicleState) -> bool:
    return agent.track[i] == state.cell and agent.battery_pct[i] == state.battery_pct


def _covered_series(result: RunResult, log: LogContents) -> Series | None:
    """Covered cells over mission time: a live result counts them after every arrival of
    the fleet, which the log stamps; a cut log's count is that of the cells stood on."""
    arrivals = sorted(
        ((s.t_s, s.cell) for states in log.states.values() for s in states),
        key=lambda pair: pair[0],
    )
    times = np.array([t for t, _ in arrivals], dtype=float)
    if result.interrupted:
        return Series(times, np.array(_first_visits(c for _, c in arrivals), dtype=float))
    if len(times) != len(result.covered_per_iteration):
        return None
    return Series(times, np.asarray(result.covered_per_iteration, dtype=float))


def _first_visits(cells: Iterable[Cell]) -> list[int]:
    """After each cell of ``cells``, how many distinct cells were seen."""
    seen: set[Cell] = set()
    counts = []
    for cell in cells:
        seen.add(cell)
        counts.append(len(seen))
    return counts


def _read_log(path: Path | None, result: RunResult) -> LogContents | None:
    """The mission log at ``path`` if it is one and records this run's mission."""
    if path is None or not Path(path).is_file():
        return None
    try:
        return _of_this_run(read_contents(path), result)
    except LogError:
        return None


def _of_this_run(contents: LogContents, result: RunResult) -> LogContents | None:
    """``contents`` if they record this run's mission, else None."""
    meta = contents.meta or {}
    if meta.get("mission") != result.mission or list(meta.get("shape", ())) != list(result.shape):
        return None
    return contents


def _time_axis(ax: Axes, clock: Timeline) -> None:
    ax.set_xlim(0, clock.end)
    ax.set_xlabel(clock.label)
    if clock.covered_at is not None:
        ax.axvline(clock.covered_at, color=COVERED_AT_COLOUR, linestyle=":", linewidth=1.2)


def _covered_at_handle(clock: Timeline) -> list:
    if clock.covered_at is None:
        return []
    return [
        Line2D(
            [],
            [],
            color=COVERED_AT_COLOUR,
            linestyle=":",
            linewidth=1.2,
            label=f"every free cell covered\n({clock.when(clock.covered_at)})",
        )
    ]


def _no_times(ax: Axes) -> None:
    """Say why a plot over time is empty instead of drawing it on a made-up clock."""
    ax.set_axis_off()
    ax.text(0.5, 0.5, NO_TIMES_TEXT, ha="center", va="center", transform=ax.transAxes)


# --------------------------------------------------------------------------- coverage map


def map_rgb(result: RunResult) -> np.ndarray:
    """The belief map as an ``(rows, cols, 3)`` RGB image.

    Covered cells are light, free cells nobody covered stand out in yellow,
    obstacles are black and cells never sensed are grey.
    """
    belief = np.asarray(result.belief)
    covered = np.asarray(result.covered, dtype=bool)
    image = np.empty((*belief.shape, 3), dtype=float)
    image[...] = UNKNOWN_RGB
    image[belief == CellState.FREE] = UNCOVERED_RGB
    image[covered] = COVERED_RGB
    image[belief == CellState.OBSTACLE] = OBSTACLE_RGB
    return image


def cell_centre_m(cell: Cell, cell_size_m: float) -> tuple[float, float]:
    """East and north metres of a cell's centre from the map's north-west corner, as
    :func:`core.geo.cell_centre_local` places it (row 0 is the northern edge: north <= 0)."""
    north, east = cell_centre_local(cell, cell_size_m)
    return east, north


def _cells_m(cells: list[Cell] | tuple[Cell, ...], cell_size_m: float) -> np.ndarray:
    """``(east, north)`` rows of metres for ``cells``."""
    if not cells:
        return np.empty((0, 2))
    rc = np.asarray(cells, dtype=float)
    return np.column_stack(((rc[:, 1] + 0.5) * cell_size_m, -(rc[:, 0] + 0.5) * cell_size_m))


def _cell_points(result: RunResult) -> float:
    """The approximate side of one cell on the page, in points."""
    return MAP_INCHES * 72.0 / max(result.shape)


def _metre_axes(ax: Axes, result: RunResult) -> None:
    """East and north in metres, ticks on whole metres, light lines between the cells."""
    rows, cols = result.shape
    size = result.cell_size_m
    ax.set_xlim(0, cols * size)
    ax.set_ylim(-rows * size, 0)
    ax.set_aspect("equal")
    for axis in (ax.xaxis, ax.yaxis):
        axis.set_major_locator(MaxNLocator(integer=True, steps=[1, 2, 5, 10]))
    if max(rows, cols) <= GRIDLINE_MAX_CELLS:
        ax.xaxis.set_minor_locator(FixedLocator([c * size for c in range(cols + 1)]))
        ax.yaxis.set_minor_locator(FixedLocator([-r * size for r in range(rows + 1)]))
        ax.grid(which="minor", color="0.8", linewidth=0.3)
        ax.tick_params(which="minor", length=0)
    ax.set_xlabel("east [m] (0, 0: the map's north-west corner)")
    ax.set_ylabel("north [m]")


def _draw_tracks(ax: Axes, result: RunResult, colours: AgentColours) -> None:
    width = float(np.clip(_cell_points(result) * 0.12, 0.4, 2.0))
    for agent in result.agents:
        if not agent.track:
            continue
        east, north = _cells_m(agent.track, result.cell_size_m).T
        ax.plot(east, north, color=colours[agent.id], linewidth=width, solid_capstyle="round")
        if agent.lost:
            ax.plot(
                east[-1],
                north[-1],
                marker="X",
                color=colours[agent.id],
                markeredgecolor="black",
                markersize=float(np.clip(_cell_points(result) * 0.6, 7.0, 14.0)),
                zorder=5,
            )


def _draw_btps(ax: Axes, result: RunResult) -> None:
    """Rings around the backtracking points, over the tracks but hollow, so the tracks
    through them stay visible; those nobody came back to are filled."""
    if not result.btps:
        return
    diameter = float(np.clip(_cell_points(result) * 0.55, 3.0, 24.0))
    width = float(np.clip(diameter / 12, 0.5, 1.5))
    for covered in (True, False):
        cells = [b.cell for b in result.btps if (b.covered_by is not None) == covered]
        if not cells:
            continue
        east, north = _cells_m(cells, result.cell_size_m).T
        ax.scatter(
            east,
            north,
            s=diameter**2,
            marker="o",
            facecolors="none" if covered else BTP_COLOUR,
            edgecolors=BTP_COLOUR,
            linewidths=width,
            zorder=4,
        )


def _draw_charger(ax: Axes, result: RunResult) -> None:
    east, north = cell_centre_m(result.charger, result.cell_size_m)
    ax.plot(
        east,
        north,
        marker="s",
        linestyle="none",
        color=CHARGER_COLOUR,
        markersize=float(np.clip(_cell_points(result) * 0.8, 7.0, 40.0)),
        markeredgecolor="white",
        zorder=1.5,  # under the tracks, which all start here
        clip_on=False,
    )


def _marker(label: str, **style: Any) -> Line2D:
    return Line2D([], [], linestyle="none", markersize=8, label=label, **style)


def _coverage_legend(fig: Figure, result: RunResult, colours: AgentColours) -> None:
    handles: list = [
        Line2D([], [], color=colours[a.id], linewidth=2, label=_vehicle_label(a))
        for a in result.agents
    ]
    handles.append(_marker("charger (start and charging pad)", marker="s", color=CHARGER_COLOUR))
    if any(b.covered_by is not None for b in result.btps):
        handles.append(
            _marker(BTP_LABEL, marker="o", markerfacecolor="none", markeredgecolor=BTP_COLOUR)
        )
    if any(b.covered_by is None for b in result.btps):
        handles.append(_marker(BTP_OPEN_LABEL, marker="o", color=BTP_COLOUR))
    belief = np.asarray(result.belief)
    covered = np.asarray(result.covered, dtype=bool)
    if covered.any():
        handles.append(Patch(facecolor=COVERED_RGB, edgecolor="0.3", label="covered"))
    if ((belief == CellState.FREE) & ~covered).any():
        handles.append(Patch(facecolor=UNCOVERED_RGB, edgecolor="0.3", label="free, not covered"))
    handles.append(Patch(facecolor=OBSTACLE_RGB, label="obstacle"))
    handles.append(Patch(facecolor=UNKNOWN_RGB, edgecolor="0.3", label="never sensed"))
    _side_legend(fig, handles)


def coverage_plot(result: RunResult) -> Figure:
    """Paper Figure 7: the final map in metres, with every vehicle's track and the
    backtracking points."""
    rows, cols = result.shape
    scale = MAP_INCHES / max(rows, cols)
    height = max(rows * scale + 0.9, 3.0)
    # Room for the legend: the vehicles, charger, two kinds of BTP and four map colours.
    extra = _legend_columns(len(result.agents) + 8, height) - 1
    # The legend and the labels take about 3.5 in; the rest is slack, so that the map (of a
    # fixed aspect) is narrower than its slot and the layout never squeezes the labels out.
    fig = _new_figure((cols * scale + 4.4 + extra * _LEGEND_COLUMN_INCHES, height))
    ax = fig.add_subplot()
    size = result.cell_size_m
    ax.imshow(
        map_rgb(result),
        interpolation="nearest",
        origin="upper",
        extent=(0, cols * size, -rows * size, 0),
    )
    colours = agent_colours(result)
    _draw_charger(ax, result)
    _draw_tracks(ax, result, colours)
    _draw_btps(ax, result)
    _metre_axes(ax, result)
    ax.set_title(_title(result, f"{result.coverage_pct:.1f} % of the free area covered"))
    _coverage_legend(fig, result, colours)
    return fig


# --------------------------------------------------------------------------- charts


def _metres(value: float) -> str:
    return f"{value:.0f}" if abs(value) >= 100 else f"{value:.1f}"


def _annotate_bars(ax: Axes, paths: np.ndarray, homing: np.ndarray) -> None:
    for xi, (p, h) in enumerate(zip(paths, homing, strict=True)):
        ax.annotate(_metres(p), (xi, p / 2), ha="center", va="center", fontsize=7)
        if h > 0:
            ax.annotate(
                f"+{_metres(h)}",
                (xi, p + h),
                xytext=(0, 2),
                textcoords="offset points",
                ha="center",
                va="bottom",
                fontsize=7,
            )


def path_length_plot(result: RunResult) -> Figure:
    """Paper Figure 10: metres each vehicle drove while covering (trips to charge
    included), with its drive home after full coverage stacked on top."""
    colours = agent_colours(result)
    x = np.arange(len(result.agents))
    paths = np.array([a.path_m for a in result.agents], dtype=float)
    homing = np.array([a.homing_m for a in result.agents], dtype=float)
    fig = _new_figure((max(7.0, 3.5 + 0.5 * len(x)), 4.0))
    ax = fig.add_subplot()
    faces = [colours[a.id] for a in result.agents]
    ax.bar(x, paths, color=faces, edgecolor="black", linewidth=0.5)
    ax.bar(
        x,
        homing,
        bottom=paths,
        color=[_lighter(c) for c in faces],
        edgecolor="black",
        linewidth=0.5,
        hatch="//",
    )
    if len(x) <= 16:
        _annotate_bars(ax, paths, homing)
    ax.set_xticks(x, [str(a.id) for a in result.agents])
    ax.set_xlabel("vehicle")
    ax.set_ylabel("distance driven [m]")
    ax.set_ylim(0, max(float((paths + homing).max(initial=0.0)), 1.0) * 1.12)
    ax.set_title(_title(result, "distance driven per vehicle"))
    _side_legend(
        fig,
        [
            Patch(
                facecolor="0.45", edgecolor="black", label="covering\n(trips to charge included)"
            ),
            Patch(
                facecolor="0.85", edgecolor="black", hatch="//", label="home after\nfull coverage"
            ),
        ],
    )
    return fig


def battery_plot(result: RunResult, clock: Timeline | None) -> Figure:
    """Paper Figure 13: every vehicle's battery over time, the reserve it keeps for the
    way back, and when the last free cell was covered."""
    fig = _new_figure((8.0, 4.0))
    ax = fig.add_subplot()
    ax.set_title(_title(result, "battery"))
    if clock is None:
        _no_times(ax)
        return fig
    colours = agent_colours(result)
    handles: list = []
    for agent in result.agents:
        series = clock.battery[agent.id]
        (line,) = ax.plot(
            series.x, series.y, color=colours[agent.id], linewidth=1.0, label=_vehicle_label(agent)
        )
        handles.append(line)
    ax.axhline(result.reserve_pct, color=RESERVE_COLOUR, linewidth=1.5)
    handles.append(
        Line2D(
            [],
            [],
            color=RESERVE_COLOUR,
            linewidth=1.5,
            label=f"reserve {result.reserve_pct:g} %\n(kept for the way to the charger)",
        )
    )
    _time_axis(ax, clock)
    ax.set_ylim(0, 105)
    ax.set_ylabel("battery [%]")
    _side_legend(fig, handles + _covered_at_handle(clock))
    return fig


def explored_plot(result: RunResult, clock: Timeline | None) -> Figure:
    """Paper Figure 12: covered cells over time, also as % of the free cells."""
    fig = _new_figure((8.0, 4.0))
    ax = fig.add_subplot()
    ax.set_title(_title(result, "area covered"))
    if clock is None:
        _no_times(ax)
        return fig
    free = max(result.free_cells, 1)
    ax.plot(clock.covered.x, clock.covered.y, color="tab:green", linewidth=1.5)
    ax.axhline(result.free_cells, color="0.4", linestyle="--", linewidth=1.0)
    _time_axis(ax, clock)
    ax.set_ylim(0, free * 1.05)
    ax.set_ylabel("covered cells")

    def to_pct(cells: ArrayLike) -> ArrayLike:
        return 100.0 * np.asarray(cells) / free

    def to_cells(pct: ArrayLike) -> ArrayLike:
        return np.asarray(pct) * free / 100.0

    pct = ax.secondary_yaxis("right", functions=(to_pct, to_cells))
    pct.set_ylabel("covered [% of the free cells]")
    handles = [
        Line2D([], [], color="tab:green", linewidth=1.5, label="covered cells"),
        Line2D([], [], color="0.4", linestyle="--", label=f"all free cells ({result.free_cells})"),
    ]
    _side_legend(fig, handles + _covered_at_handle(clock))
    return fig


def write_figures(
    result: RunResult,
    out_dir: Path,
    log: Path | None = None,
    contents: LogContents | None = None,
) -> list[Path]:
    """Write every figure into ``out_dir``; return their paths in a fixed order.

    ``log`` is the run's mission log (default: ``mission.mcap`` in ``out_dir``,
    where the commands write it), or ``contents`` that log as already read; it is
    read only when the result needs it for its clock (a live run, or one rebuilt
    from a cut log), and ignored if it records another mission.
    """
    out_dir = Path(out_dir)
    if not (result.extra.get("live") or result.interrupted):
        contents = None
    elif contents is not None:
        contents = _of_this_run(contents, result)
    else:
        contents = _read_log(out_dir / MISSION_LOG if log is None else log, result)
    clock = timeline(result, contents)
    return [
        _save(coverage_plot(result), out_dir / COVERAGE_PNG),
        _save(path_length_plot(result), out_dir / PATH_LENGTH_PNG),
        _save(battery_plot(result, clock), out_dir / BATTERY_PNG),
        _save(explored_plot(result, clock), out_dir / EXPLORED_PNG),
    ]
