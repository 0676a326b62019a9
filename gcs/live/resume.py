"""Where an earlier run of a mission stopped, read from its log (``gcs run --resume LOG``).

A ground station that dies (SIGKILL, power, a crash) leaves an MCAP log that
is readable up to its last flushed chunk (about a second before the end).
From it we take what the planner knew: the map (the last ``/map`` grid, plus
every cell a vehicle stood on since), the covered cells, the backtracking
points, and each vehicle's last logged state. The vehicles themselves are
asked where they are when the new run connects: their own failsafe (hold,
or return to launch) has moved or kept them since.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from core.cells import Cell
from gcs.log.reader import LogError, VehicleState, final_map, read_contents
from gcs.mission import Mission


class ResumeError(ValueError):
    """The log cannot be resumed from with this mission; one line naming the log."""


@dataclass(frozen=True)
class ResumePoint:
    source: Path
    #: ``CellState`` values the earlier run knew.
    known: np.ndarray
    covered: np.ndarray
    btps: tuple[Cell, ...]
    #: Each vehicle's last logged state.
    vehicles: Mapping[int, VehicleState]
    #: Mission seconds of the last logged record.
    last_t_s: float
    #: The earlier run died (its log has no end); False if it ended (aborted, time limit).
    crashed: bool

    @property
    def covered_cells(self) -> int:
        return int(self.covered.sum())


def load_resume_point(path: Path, mission: Mission) -> ResumePoint:
    """Read ``path`` and check it records ``mission``; raises ``ResumeError``."""
    try:
        contents = read_contents(path)
    except LogError as exc:
        raise ResumeError(f"--resume: {exc}") from exc
    meta = contents.meta
    if meta is None:
        raise ResumeError(f"--resume: {path}: no /run/meta record: the log holds no run")
    shape = (int(meta["shape"][0]), int(meta["shape"][1]))
    charger = (int(meta["charger"][0]), int(meta["charger"][1]))
    if meta["mission"] != mission.name or shape != mission.map.shape:
        raise ResumeError(
            f"--resume: {path} records mission {meta['mission']!r} on a "
            f"{shape[0]}x{shape[1]} map, not {mission.name!r} on a "
            f"{mission.map.shape[0]}x{mission.map.shape[1]} map"
        )
    if charger != mission.charger:
        raise ResumeError(
            f"--resume: {path} has the charger on {charger}, the mission on {mission.charger}"
        )
    unknown = sorted(set(contents.states) - {v.sysid for v in mission.fleet})
    if unknown:
        raise ResumeError(
            f"--resume: {path} records vehicle {unknown[0]}, which is not in the mission's fleet"
        )
    known, covered = final_map(contents, shape, contents.states)
    times = [s[-1].t_s for s in contents.states.values() if s]
    times += [e.t_s for e in contents.events]
    return ResumePoint(
        source=path,
        known=known,
        covered=covered,
        btps=tuple(contents.btps),
        vehicles={sysid: states[-1] for sysid, states in contents.states.items() if states},
        last_t_s=max(times, default=0.0),
        crashed=contents.result is None,
    )


def _clock(seconds: float) -> str:
    m, s = divmod(round(seconds), 60)
    return f"{m}:{s:02d}"


def resumed_text(resume: ResumePoint, kept: int) -> str:
    """What the operator is told of a resumed mission: how far the earlier run got, and
    which of its covered cells are covered again (``kept``: those the planner took over;
    the others' sensing did not reach the log, so the planner cannot count on them)."""
    logged = resume.covered_cells
    text = (
        f"resumed from {resume.source.name} (its log ends at mission time "
        f"{_clock(resume.last_t_s)}): {kept} covered cells are kept"
    )
    if kept >= logged:
        return text + ", none is covered again"
    again = logged - kept
    return (
        f"{text}; {again} more it covered will be covered again, as what was sensed "
        f"there did not reach the log"
    )
