"""Grid geometry shared by every layer: cells, compass directions, cell states.

A cell is ``(row, col)`` with row 0 on the northern edge of the map, so North
is ``row - 1`` and East is ``col + 1``. Moves are the four compass directions
of one cell (the paper's eq. 1); sensing covers the eight neighbours.
"""

from __future__ import annotations

from enum import Enum, IntEnum

Cell = tuple[int, int]


class CellState(IntEnum):
    """What the planner believes (or the world knows) of one cell."""

    UNKNOWN = 0
    FREE = 1
    OBSTACLE = 2


class Direction(Enum):
    """The eight compass neighbours, clockwise from the north-west.

    The paper numbers them s1..s8 in this order (s1 NW, s2 N, ... s8 W).
    """

    NW = (-1, -1)
    N = (-1, 0)
    NE = (-1, 1)
    E = (0, 1)
    SE = (1, 1)
    S = (1, 0)
    SW = (1, -1)
    W = (0, -1)

    #: Members are singletons: hashing by identity (in C) instead of by name (in
    #: Python, Enum's default) makes the many look-ups keyed by direction cheap.
    __hash__ = object.__hash__

    @property
    def dr(self) -> int:
        return self.value[0]

    @property
    def dc(self) -> int:
        return self.value[1]

    def of(self, cell: Cell) -> Cell:
        """The neighbour of ``cell`` in this direction."""
        return (cell[0] + self.value[0], cell[1] + self.value[1])

    @property
    def opposite(self) -> Direction:
        return _OPPOSITE[self]

    @property
    def heading_deg(self) -> float:
        """Compass heading of this direction in degrees (N = 0, E = 90)."""
        return _HEADING[self]

    @staticmethod
    def between(a: Cell, b: Cell) -> Direction:
        """The direction of the step from ``a`` to its neighbour ``b``."""
        return _BY_DELTA[(b[0] - a[0], b[1] - a[1])]


_OPPOSITE = {d: Direction((-d.dr, -d.dc)) for d in Direction}
_HEADING = {
    Direction.N: 0.0,
    Direction.NE: 45.0,
    Direction.E: 90.0,
    Direction.SE: 135.0,
    Direction.S: 180.0,
    Direction.SW: 225.0,
    Direction.W: 270.0,
    Direction.NW: 315.0,
}
_BY_DELTA = {d.value: d for d in Direction}

#: The boustrophedon priority of the paper: North, South, East, West.
MOVES: tuple[Direction, ...] = (Direction.N, Direction.S, Direction.E, Direction.W)
#: All eight neighbours in the paper's s1..s8 order.
NEIGHBOURS: tuple[Direction, ...] = tuple(Direction)


def manhattan(a: Cell, b: Cell) -> int:
    return abs(a[0] - b[0]) + abs(a[1] - b[1])
