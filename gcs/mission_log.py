"""What a mission log records, as an interface: the MCAP writer implements it.

Times are mission seconds (simulated time under a speed-up; iterations in an
offline run). Both the live mission and the offline simulation write through
this interface, so that a log looks the same whichever produced it. The live
mission says when its mission time 0 is (``start``): the MCAP log stamps its
messages in UTC from there (:mod:`gcs.mcap_log`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Protocol

import numpy as np

from gcs.result import RunResult
from planner.grid import Cell, CellState, Direction


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
        lat_deg: float | None = None,
        lon_deg: float | None = None,
        heading_deg: float | None = None,
        readings: Mapping[Direction, CellState] | None = None,
    ) -> None:
        """Where a vehicle is and how it is doing (after every move, and on changes), and
        what it sensed there."""

    def coverage(self, t_s: float, belief: np.ndarray, covered: np.ndarray) -> None:
        """The planner's map: ``CellState`` values, and which cells are covered."""

    def btps(self, t_s: float, cells: Sequence[Cell]) -> None:
        """The backtracking points currently in the stacks."""

    def event(self, t_s: float, text: str, level: str = "info", sysid: int | None = None) -> None:
        """Something an operator should see in the timeline."""

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
        lat_deg: float | None = None,
        lon_deg: float | None = None,
        heading_deg: float | None = None,
        readings: Mapping[Direction, CellState] | None = None,
    ) -> None:
        pass

    def coverage(self, t_s: float, belief: np.ndarray, covered: np.ndarray) -> None:
        pass

    def btps(self, t_s: float, cells: Sequence[Cell]) -> None:
        pass

    def event(self, t_s: float, text: str, level: str = "info", sysid: int | None = None) -> None:
        pass

    def result(self, t_s: float, result: RunResult) -> None:
        pass

    def close(self) -> None:
        pass
