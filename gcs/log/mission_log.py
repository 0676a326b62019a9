"""What a mission log records, as an interface: the MCAP writer implements it.

Times are mission seconds (simulated time under a speed-up; iterations in an
offline run). Both the live mission and the offline simulation write through
this interface, so that a log looks the same whichever produced it. The live
mission says when its mission time 0 is (``start``): the MCAP log stamps its
messages in UTC from there (:mod:`gcs.log.mcap_log`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import NamedTuple, Protocol

import numpy as np

from core.cells import Cell, CellState, Direction
from gcs.outcome.result import RunResult


class GeoFix(NamedTuple):
    """Where a vehicle's own telemetry puts it (a live run's; an offline run has none,
    and the log places it on its cell's centre)."""

    lat_deg: float
    lon_deg: float
    #: None: the log takes the heading of the vehicle's last move.
    heading_deg: float | None = None


class FleetStep(NamedTuple):
    """Every vehicle at one step of an offline run, in the order of ``sysids``."""

    sysids: Sequence[int]
    cells: Sequence[Cell]
    battery_pct: Sequence[float]
    modes: Sequence[str]


@dataclass(frozen=True)
class VehicleStatus:
    """One vehicle as the operator sees it (the live display's row, and the web page's)."""

    sysid: int
    kind: str
    #: What the ground station is doing with it (``gcs.live.shared.Phase``), in the
    #: vehicle's words (a rover drives), with what it waits for: "connecting: GPS fix".
    activity: str
    #: ``Phase`` value (connecting, moving, charging, link lost, lost, done...).
    phase: str
    #: The planner's mode (exploring, transit, returning, charging, homing, done, lost).
    task: str
    cell: Cell | None
    battery_pct: float | None
    #: The online estimate of battery per metre, and how far the battery above the
    #: reserve takes the vehicle at it.
    energy_pct_per_m: float | None
    range_m: float | None
    #: The length of the shortest known way home (to the charger).
    home_m: float | None
    charges: int
    #: The cells the planner has it go through next, first next (at most ``WAY_CELLS``).
    way: tuple[Cell, ...]
    link_up: bool
    #: Mission seconds since anything was heard from it (None: never).
    heard_s_ago: float | None
    #: Frames from it thrown away (garbage, bad signatures, implausible values...).
    rejected_frames: int


#: The most cells of a planned way a status carries (a way home across a large map is
#: thousands of cells; the first ones say where the vehicle goes).
WAY_CELLS = 400


@dataclass(frozen=True)
class MissionProgress:
    """The mission as a whole: the live display's title, and the web page's header."""

    covered: int
    free: int
    #: What the mission is doing in a few words: "getting ready", "covering", "coverage
    #: complete, going home", "aborted, every vehicle parked"...
    state: str
    #: At this run's pace so far; None when not known (or nothing left).
    time_left_s: float | None
    #: Mission seconds per real second (None: not known).
    speedup: float | None

    @property
    def pct(self) -> float:
        free = max(1, self.free)
        return 100.0 * min(self.covered, free) / free


class MissionLog(Protocol):
    def start(self, unix_s: float | None = None) -> None:
        """Mission time 0 is now (or ``unix_s``, the wall clock in Unix seconds)."""

    def raw(self, sysid: int, outgoing: bool, t_s: float, frame: bytes) -> None:
        """One MAVLink frame exactly as it crossed the wire."""

    def agent_state(
        self,
        t_s: float,
        sysid: int,
        cell: Cell,
        battery_pct: float,
        mode: str,
        fix: GeoFix | None = None,
        readings: Mapping[Direction, CellState] | None = None,
    ) -> None:
        """Where a vehicle is and how it is doing (after every move, and on changes), and
        what it sensed there."""

    def fleet_step(self, t_s: float, step: FleetStep) -> None:
        """Where every vehicle is and how it is doing at one step of an offline run (tens
        of thousands of steps a second): the log may gather steps and write them
        together."""

    def coverage(self, t_s: float, belief: np.ndarray, covered: np.ndarray) -> None:
        """The planner's map: ``CellState`` values, and which cells are covered."""

    def btps(self, t_s: float, cells: Sequence[Cell]) -> None:
        """The backtracking points currently in the stacks."""

    def event(self, t_s: float, text: str, level: str = "info", sysid: int | None = None) -> None:
        """Something an operator should see in the timeline."""

    def status(
        self, t_s: float, vehicles: Sequence[VehicleStatus], progress: MissionProgress
    ) -> None:
        """What the operator sees of each vehicle and of the mission (live runs, a few
        times a second; only what changed needs to be written)."""

    def result(self, t_s: float, result: RunResult) -> None:
        """The run's final result (what report.json and the figures are made of)."""

    def close(self) -> None:
        """Flush and finish the file; the log must also be readable if this never runs."""


class NullLog:
    """Logs nothing: for runs without ``--out``."""

    def start(self, unix_s: float | None = None) -> None:
        pass

    def raw(self, sysid: int, outgoing: bool, t_s: float, frame: bytes) -> None:
        pass

    def agent_state(
        self,
        t_s: float,
        sysid: int,
        cell: Cell,
        battery_pct: float,
        mode: str,
        fix: GeoFix | None = None,
        readings: Mapping[Direction, CellState] | None = None,
    ) -> None:
        pass

    def fleet_step(self, t_s: float, step: FleetStep) -> None:
        pass

    def coverage(self, t_s: float, belief: np.ndarray, covered: np.ndarray) -> None:
        pass

    def btps(self, t_s: float, cells: Sequence[Cell]) -> None:
        pass

    def event(self, t_s: float, text: str, level: str = "info", sysid: int | None = None) -> None:
        pass

    def status(
        self, t_s: float, vehicles: Sequence[VehicleStatus], progress: MissionProgress
    ) -> None:
        pass

    def result(self, t_s: float, result: RunResult) -> None:
        pass

    def close(self) -> None:
        pass
