"""PNG figures of a finished run, after the paper's Figures 7, 10, 12 and 13.

Only ``matplotlib.figure.Figure`` objects with the Agg canvas are used, never
pyplot, so drawing holds no global state and works without a display or in
threads.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
from matplotlib import colormaps
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.colors import to_rgb
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from gcs.result import RunResult
from planner.grid import CellState

COVERAGE_PNG = "coverage.png"
PATH_LENGTH_PNG = "path_length.png"
BATTERY_PNG = "battery.png"
EXPLORED_PNG = "explored.png"

DPI = 150
#: Map colours (RGB) of the coverage figure.
OBSTACLE_RGB = (0.0, 0.0, 0.0)
UNKNOWN_RGB = (0.6, 0.6, 0.6)
COVERED_RGB = (1.0, 1.0, 1.0)
UNCOVERED_RGB = (1.0, 0.85, 0.2)
CHARGER_COLOUR = "tab:blue"
BTP_EDGE = "red"
RESERVE_COLOUR = "red"
#: Longest side of the coverage figure's map, in inches.
MAP_INCHES = 8.0
#: Maps at most this many cells on a side get per-cell gridlines.
GRIDLINE_MAX_CELLS = 60

RGB = tuple[float, float, float]
AgentColours = dict[int, RGB]


def _title(result: RunResult, what: str) -> str:
    n = len(result.agents)
    return f"{result.mission}: {what} ({n} agent{'s' if n != 1 else ''})"


def agent_colours(result: RunResult) -> AgentColours:
    """One distinct colour per agent id, the same in every figure.

    Blue and red are skipped for small fleets because they mean the charger
    and the BTPs on the coverage map.
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


def _cell_points(result: RunResult) -> float:
    """The approximate side of one cell on the page, in points."""
    return MAP_INCHES * 72.0 / max(result.shape)


def _draw_gridlines(ax: Axes, rows: int, cols: int) -> None:
    ax.set_xticks(np.arange(-0.5, cols, 1.0), minor=True)
    ax.set_yticks(np.arange(-0.5, rows, 1.0), minor=True)
    ax.grid(which="minor", color="0.8", linewidth=0.3)
    ax.tick_params(which="minor", length=0)


def _draw_tracks(ax: Axes, result: RunResult, colours: AgentColours) -> None:
    width = float(np.clip(_cell_points(result) * 0.12, 0.4, 2.0))
    for agent in result.agents:
        if not agent.track:
            continue
        rows, cols = np.asarray(agent.track, dtype=float).T
        ax.plot(cols, rows, color=colours[agent.id], linewidth=width, solid_capstyle="round")
        if agent.lost:
            ax.plot(
                cols[-1],
                rows[-1],
                marker="X",
                color=colours[agent.id],
                markeredgecolor="black",
                markersize=float(np.clip(_cell_points(result) * 0.6, 7.0, 14.0)),
                zorder=5,
            )


def _draw_btps(ax: Axes, result: RunResult, colours: AgentColours) -> None:
    if not result.btps:
        return
    side = float(np.clip(_cell_points(result) * 0.6, 3.0, 30.0))
    white = (1.0, 1.0, 1.0)
    # Like the paper: a white face until an agent covers the BTP, then that agent's colour.
    faces = [
        white if b.covered_by is None else colours.get(b.covered_by, white) for b in result.btps
    ]
    rows = [b.cell[0] for b in result.btps]
    cols = [b.cell[1] for b in result.btps]
    ax.scatter(
        cols,
        rows,
        s=side**2,
        marker="s",
        c=faces,
        edgecolors=BTP_EDGE,
        linewidths=float(np.clip(side / 10, 0.4, 2.0)),
        zorder=3,
        clip_on=False,
    )


#: Legend rows (8 pt text) that fit in an inch of figure height.
_LEGEND_ROWS_PER_INCH = 5.0


#: Width of one legend column of "agent NN" entries.
_LEGEND_COLUMN_INCHES = 1.3


def _legend_columns(entries: int, height_in: float) -> int:
    rows = max(1, int(height_in * _LEGEND_ROWS_PER_INCH))
    return -(-entries // rows)


def _side_legend(ax: Axes, handles: list | None = None) -> None:
    """A legend to the right of the axes, in as many columns as the figure's
    height needs: a fleet of 64 in one column is taller than the figure, and
    the layout then has no room left for the axes."""
    if handles is None:
        handles, _ = ax.get_legend_handles_labels()
    ax.legend(
        handles=handles,
        loc="upper left",
        bbox_to_anchor=(1.01, 1.0),
        fontsize=8,
        frameon=False,
        ncols=_legend_columns(len(handles), ax.figure.get_figheight()),
    )


def _coverage_legend(ax: Axes, result: RunResult, colours: AgentColours) -> None:
    handles: list = [
        Line2D(
            [],
            [],
            color=colours[a.id],
            linewidth=2,
            label=f"agent {a.id}" + (" (lost)" if a.lost else ""),
        )
        for a in result.agents
    ]
    handles.append(
        Line2D(
            [],
            [],
            linestyle="none",
            marker="s",
            color=CHARGER_COLOUR,
            markersize=8,
            label="charger",
        )
    )
    if result.btps:
        handles.append(
            Line2D(
                [],
                [],
                linestyle="none",
                marker="s",
                markerfacecolor="white",
                markeredgecolor=BTP_EDGE,
                markersize=8,
                label="BTP",
            )
        )
    handles.append(Patch(facecolor=OBSTACLE_RGB, label="obstacle"))
    handles.append(Patch(facecolor=UNKNOWN_RGB, edgecolor="0.3", label="unknown"))
    uncovered = (np.asarray(result.belief) == CellState.FREE) & ~np.asarray(result.covered, bool)
    if uncovered.any():
        handles.append(Patch(facecolor=UNCOVERED_RGB, edgecolor="0.3", label="free, uncovered"))
    _side_legend(ax, handles)


def coverage_figure(result: RunResult, path: Path) -> Path:
    """Paper Figure 7: the final belief map with every agent's track and the BTPs."""
    rows, cols = result.shape
    scale = MAP_INCHES / max(rows, cols)
    height = max(rows * scale + 0.6, 3.0)
    # Room for the legend: the agents, charger, BTP and up to three map colours.
    extra = _legend_columns(len(result.agents) + 6, height) - 1
    fig = _new_figure((cols * scale + 2.0 + extra * _LEGEND_COLUMN_INCHES, height))
    ax = fig.add_subplot()
    ax.imshow(
        map_rgb(result),
        interpolation="nearest",
        origin="upper",
        extent=(-0.5, cols - 0.5, rows - 0.5, -0.5),
    )
    if max(rows, cols) <= GRIDLINE_MAX_CELLS:
        _draw_gridlines(ax, rows, cols)
    colours = agent_colours(result)
    _draw_tracks(ax, result, colours)
    _draw_btps(ax, result, colours)
    charger_side = float(np.clip(_cell_points(result) * 0.8, 7.0, 40.0))
    ax.plot(
        result.charger[1],
        result.charger[0],
        marker="s",
        linestyle="none",
        color=CHARGER_COLOUR,
        markersize=charger_side,
        markeredgecolor="white",
        zorder=1.5,  # under the tracks, which all start here
        clip_on=False,
    )
    ax.set_xlim(-0.5, cols - 0.5)
    ax.set_ylim(rows - 0.5, -0.5)  # row 0 is the northern edge: keep north up
    ax.set_aspect("equal")
    ax.set_xlabel("column")
    ax.set_ylabel("row")
    ax.set_title(_title(result, f"coverage {result.coverage_pct:.1f} %"))
    _coverage_legend(ax, result, colours)
    return _save(fig, path)


# --------------------------------------------------------------------------- charts


def _metres(value: float) -> str:
    return f"{value:.0f}" if abs(value) >= 100 else f"{value:.1f}"


def path_length_figure(result: RunResult, path: Path) -> Path:
    """Paper Figure 10: coverage path length per agent, with homing stacked on top."""
    colours = agent_colours(result)
    labels = [str(a.id) for a in result.agents]
    x = np.arange(len(result.agents))
    paths = np.array([a.path_m for a in result.agents], dtype=float)
    homing = np.array([a.homing_m for a in result.agents], dtype=float)
    fig = _new_figure((max(5.5, 1.5 + 0.5 * len(x)), 4.0))
    ax = fig.add_subplot()
    ax.bar(
        x,
        paths,
        color=[colours[a.id] for a in result.agents],
        edgecolor="black",
        linewidth=0.5,
    )
    ax.bar(
        x,
        homing,
        bottom=paths,
        color=[_lighter(colours[a.id]) for a in result.agents],
        edgecolor="black",
        linewidth=0.5,
        hatch="//",
    )
    if len(x) <= 16:
        for xi, p, h in zip(x, paths, homing, strict=True):
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
    ax.set_xticks(x, labels)
    ax.set_xlabel("agent")
    ax.set_ylabel("path length [m]")
    ax.set_ylim(0, max(float((paths + homing).max(initial=0.0)), 1.0) * 1.12)
    ax.legend(
        handles=[
            Patch(facecolor="0.45", edgecolor="black", label="coverage path"),
            Patch(facecolor="0.85", edgecolor="black", hatch="//", label="homing"),
        ],
        fontsize=8,
        loc="upper left",
        bbox_to_anchor=(1.01, 1.0),
        frameon=False,
    )
    ax.set_title(_title(result, "path length per agent"), fontsize=10)
    return _save(fig, path)


def battery_figure(result: RunResult, path: Path) -> Path:
    """Paper Figure 13: every agent's battery over the iterations, and the reserve."""
    colours = agent_colours(result)
    fig = _new_figure((7.0, 4.0))
    ax = fig.add_subplot()
    for agent in result.agents:
        ax.plot(
            np.arange(len(agent.battery_pct)),
            agent.battery_pct,
            color=colours[agent.id],
            linewidth=1.0,
            label=f"agent {agent.id}",
        )
    ax.axhline(
        result.reserve_pct,
        color=RESERVE_COLOUR,
        linewidth=1.5,
        label=f"reserve {result.reserve_pct:g} %",
    )
    ax.set_ylim(0, 105)
    ax.set_xlim(left=0)
    ax.set_xlabel("iteration")
    ax.set_ylabel("battery [%]")
    _side_legend(ax)
    ax.set_title(_title(result, "battery"))
    return _save(fig, path)


def explored_figure(result: RunResult, path: Path) -> Path:
    """Paper Figure 12: covered cells over the iterations, with % of the free cells."""
    covered = np.asarray(result.covered_per_iteration, dtype=float)
    free = max(result.free_cells, 1)
    fig = _new_figure((7.0, 4.0))
    ax = fig.add_subplot()
    ax.plot(np.arange(len(covered)), covered, color="tab:green", linewidth=1.5)
    ax.axhline(
        result.free_cells,
        color="0.4",
        linestyle="--",
        linewidth=1.0,
        label=f"free cells ({result.free_cells})",
    )
    ax.set_ylim(0, free * 1.05)
    ax.set_xlim(left=0)
    ax.set_xlabel("iteration")
    ax.set_ylabel("covered cells")
    pct = ax.secondary_yaxis(
        "right", functions=(lambda c: 100.0 * c / free, lambda p: p * free / 100.0)
    )
    pct.set_ylabel("covered [% of free]")
    ax.legend(
        handles=[
            Patch(facecolor="0.45", edgecolor="black", label="coverage path"),
            Patch(facecolor="0.85", edgecolor="black", hatch="//", label="homing"),
        ],
        fontsize=8,
        loc="upper left",
        bbox_to_anchor=(1.01, 1.0),
        frameon=False,
    )
    ax.set_title(_title(result, "explored area"))
    return _save(fig, path)


FIGURES: Sequence[tuple[str, Callable[[RunResult, Path], Path]]] = (
    (COVERAGE_PNG, coverage_figure),
    (PATH_LENGTH_PNG, path_length_figure),
    (BATTERY_PNG, battery_figure),
    (EXPLORED_PNG, explored_figure),
)


def write_figures(result: RunResult, out_dir: Path) -> list[Path]:
    """Write every figure into ``out_dir``; return their paths in a fixed order."""
    out_dir = Path(out_dir)
    return [draw(result, out_dir / name) for name, draw in FIGURES]
