"""Cells and compass directions (``core.cells``), the grid every layer shares."""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from core.cells import MOVES, NEIGHBOURS, CellState, Direction, manhattan

cells = st.tuples(st.integers(-50, 50), st.integers(-50, 50))


def test_north_is_the_row_above_and_east_the_next_column() -> None:
    assert Direction.N.of((5, 5)) == (4, 5)
    assert Direction.E.of((5, 5)) == (5, 6)
    assert Direction.SW.of((5, 5)) == (6, 4)


def test_neighbours_in_the_papers_order_and_moves_north_south_east_west() -> None:
    assert [d.name for d in NEIGHBOURS] == ["NW", "N", "NE", "E", "SE", "S", "SW", "W"]
    assert MOVES == (Direction.N, Direction.S, Direction.E, Direction.W)


def test_headings_go_clockwise_from_north() -> None:
    headings = {d: d.heading_deg for d in Direction}
    assert headings[Direction.N] == 0.0 and headings[Direction.E] == 90.0
    assert headings[Direction.S] == 180.0 and headings[Direction.NW] == 315.0


@given(cells, st.sampled_from(list(Direction)))
def test_a_step_and_its_opposite_come_back(cell: tuple[int, int], d: Direction) -> None:
    there = d.of(cell)
    assert Direction.between(cell, there) is d
    assert d.opposite.of(there) == cell
    assert (d.dr, d.dc) == (there[0] - cell[0], there[1] - cell[1])


@given(cells, cells)
def test_manhattan_is_a_symmetric_distance(a: tuple[int, int], b: tuple[int, int]) -> None:
    assert manhattan(a, b) == manhattan(b, a) == abs(a[0] - b[0]) + abs(a[1] - b[1])
    assert (manhattan(a, b) == 0) == (a == b)


def test_moves_are_one_step_away() -> None:
    assert all(manhattan((0, 0), d.of((0, 0))) == 1 for d in MOVES)


def test_cell_states_are_the_bytes_the_belief_stores() -> None:
    assert [int(s) for s in CellState] == [0, 1, 2]
