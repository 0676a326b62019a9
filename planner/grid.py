"""The grid notions the planner uses, defined in :mod:`core.cells` (shared with the
vehicles, the mock fleet and the station) and named here for the planner's modules."""

from __future__ import annotations

from core.cells import MOVES, NEIGHBOURS, Cell, CellState, Direction, manhattan

__all__ = ["MOVES", "NEIGHBOURS", "Cell", "CellState", "Direction", "manhattan"]
