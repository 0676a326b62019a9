"""Random map generators (sitl_mock.mapgen) and the ``gcs map`` command."""

from __future__ import annotations

import time
from collections import deque
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gcs import cli
from sitl_mock import mapgen
from sitl_mock.gridmap import GridMap
from sitl_mock.maps import load_map

Generator = Callable[[int, int, int], GridMap]

GENERATORS: dict[str, Generator] = {
    "bars": lambda h, w, seed: mapgen.bars(h, w, seed=seed),
    "rooms": lambda h, w, seed: mapgen.rooms(h, w, seed),
    "building": lambda h, w, seed: mapgen.building(h, w, seed, block=int(seed % 30) + 6),
    "caves": lambda h, w, seed: mapgen.caves(h, w, seed),
    "branching": lambda h, w, seed: mapgen.branching(h, w, seed),
    "open": lambda h, w, seed: mapgen.open_field(h, w, seed, 0.2),
    "open_dense": lambda h, w, seed: mapgen.open_field(h, w, seed, 0.5, clearance=0),
}

#: Generators whose passages are at least two cells wide by construction.
WIDE = {
    "rooms": lambda h, w, seed: mapgen.rooms(h, w, seed),
    "building": lambda h, w, seed: mapgen.building(h, w, seed),
    "branching": lambda h, w, seed: mapgen.branching(h, w, seed),
    "open_clear2": lambda h, w, seed: mapgen.open_field(h, w, seed, 0.3, clearance=2),
}


def assert_well_formed(grid: GridMap, height: int, width: int) -> None:
    assert grid.shape == (height, width)
    assert grid.obstacle.dtype == bool
    pad = (height - 1, width // 2)
    assert grid.pads == (pad,)
    assert not grid.obstacle[pad]
    border = np.ones((height, width), dtype=bool)
    border[1:-1, 1:-1] = False
    border[pad] = False
    assert grid.obstacle[border].all(), "the border must be wall except the pad"
    assert np.array_equal(grid.reachable(), ~grid.obstacle), "every free cell reachable"
    assert grid.free_count >= 2  # at least the pad and the cell inside it


def narrow_cells(grid: GridMap) -> int:
    """Free cells (other than the pad) that lie in no 2x2 block of free cells."""
    free = ~grid.obstacle
    block = free[:-1, :-1] & free[1:, :-1] & free[:-1, 1:] & free[1:, 1:]
    in_block = np.zeros_like(free)
    in_block[:-1, :-1] |= block
    in_block[1:, :-1] |= block
    in_block[:-1, 1:] |= block
    in_block[1:, 1:] |= block
    narrow = free & ~in_block
    narrow[grid.charger] = False
    return int(narrow.sum())


@pytest.mark.parametrize("kind", GENERATORS)
@given(seed=st.integers(0, 2**32 - 1), height=st.integers(5, 45), width=st.integers(5, 45))
@settings(max_examples=25, deadline=None)
def test_generators_make_bordered_connected_maps(
    kind: str, seed: int, height: int, width: int
) -> None:
    assert_well_formed(GENERATORS[kind](height, width, seed), height, width)


@pytest.mark.parametrize("kind", WIDE)
@given(seed=st.integers(0, 2**32 - 1), height=st.integers(12, 50), width=st.integers(12, 50))
@settings(max_examples=20, deadline=None)
def test_passages_are_at_least_two_cells_wide(
    kind: str, seed: int, height: int, width: int
) -> None:
    assert narrow_cells(WIDE[kind](height, width, seed)) == 0


@pytest.mark.parametrize("kind", GENERATORS)
def test_generators_are_deterministic_per_seed(kind: str) -> None:
    make = GENERATORS[kind]
    first, again, other = make(40, 50, 7), make(40, 50, 7), make(40, 50, 8)
    assert np.array_equal(first.obstacle, again.obstacle)
    assert first.pads == again.pads
    assert not np.array_equal(first.obstacle, other.obstacle)


def obstacle_pieces(grid: GridMap) -> list[list[tuple[int, int]]]:
    """8-connected groups of obstacle cells inside the border."""
    inner = grid.obstacle.copy()
    inner[[0, -1], :] = False
    inner[:, [0, -1]] = False
    pieces = []
    for start in zip(*np.nonzero(inner), strict=True):
        if not inner[start]:
            continue
        inner[start] = False
        piece, todo = [], [start]
        while todo:
            r, c = todo.pop()
            piece.append((int(r), int(c)))
            for dr in (-1, 0, 1):
                for dc in (-1, 0, 1):
                    if inner[r + dr, c + dc]:
                        inner[r + dr, c + dc] = False
                        todo.append((r + dr, c + dc))
        pieces.append(piece)
    return pieces


@given(seed=st.integers(0, 2**32 - 1))
@settings(max_examples=30, deadline=None)
def test_bars_are_separate_straight_bars_of_the_given_lengths(seed: int) -> None:
    grid = mapgen.bars(30, 30, count=13, min_len=4, max_len=9, seed=seed)
    pieces = obstacle_pieces(grid)
    assert len(pieces) == 13
    for piece in pieces:
        rows, cols = {r for r, _ in piece}, {c for _, c in piece}
        assert len(rows) == 1 or len(cols) == 1
        assert 4 <= len(piece) <= 9


def test_free_pockets_are_filled() -> None:
    # Caves with much rock have many small pockets; none may survive.
    grid = mapgen.caves(60, 60, seed=3, fill=0.55)
    assert np.array_equal(grid.reachable(), ~grid.obstacle)


def test_caves_with_solid_rock_still_have_an_entrance() -> None:
    grid = mapgen.caves(10, 10, seed=0, fill=1.0)
    assert grid.free_count == 2


@pytest.mark.parametrize(
    "call",
    [
        lambda: mapgen.bars(4, 30),
        lambda: mapgen.bars(30, 30, min_len=5, max_len=4),
        lambda: mapgen.rooms(30, 30, room_min=4, room_max=8),
        lambda: mapgen.rooms(30, 30, door_width=5),
        lambda: mapgen.building(30, 30, block=5),
        lambda: mapgen.building(30, 30, hall_width=0),
        lambda: mapgen.building(30, 30, door_width=5),
        lambda: mapgen.caves(30, 30, fill=1.5),
        lambda: mapgen.branching(30, 30, min_width=3, max_width=2),
        lambda: mapgen.open_field(30, 30, density=1.0),
    ],
)
def test_bad_parameters_raise_value_error(call: Callable[[], GridMap]) -> None:
    with pytest.raises(ValueError):
        call()


@pytest.mark.parametrize("kind", ["bars", "rooms", "building", "caves", "branching", "open"])
def test_300_by_300_is_fast(kind: str) -> None:
    start = time.perf_counter()
    GENERATORS[kind](300, 300, 1)
    assert time.perf_counter() - start < 2.0  # typically well under 0.5 s


def run_cli(*argv: str) -> int:
    return cli.main(list(argv))


def test_cli_writes_the_generated_map(tmp_path: Path) -> None:
    out = tmp_path / "m.txt"
    assert run_cli("map", "branching", "--size", "40x50", "--seed", "5", "--out", str(out)) == 0
    grid = load_map(out)
    assert np.array_equal(grid.obstacle, mapgen.branching(40, 50, 5).obstacle)


def test_cli_prints_the_map(capsys: pytest.CaptureFixture[str]) -> None:
    assert run_cli("map", "bars", "--size", "12x20", "--count", "3") == 0
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 12 and all(len(line) == 20 for line in lines)
    assert lines[-1][10] == "C"


def test_cli_reports_bad_parameters(capsys: pytest.CaptureFixture[str]) -> None:
    assert run_cli("map", "caves", "--size", "3x3") == 2
    assert capsys.readouterr().err == "gcs map caves: map must be at least 5x5 cells, got 3x3\n"


def test_cli_rejects_a_malformed_size() -> None:
    with pytest.raises(SystemExit) as info:
        run_cli("map", "open", "--size", "30by30")
    assert info.value.code == 2


def detour_ratio(grid: GridMap) -> float:
    """The mean, over the free cells, of the way from the pad over the Manhattan distance."""
    height, width = grid.shape
    pad = grid.charger
    dist = np.full((height, width), -1, dtype=np.int64)
    dist[pad] = 0
    queue = deque([pad])
    while queue:
        r, c = queue.popleft()
        for nr, nc in ((r - 1, c), (r + 1, c), (r, c - 1), (r, c + 1)):
            if 0 <= nr < height and 0 <= nc < width and dist[nr, nc] < 0 and grid.is_free((nr, nc)):
                dist[nr, nc] = dist[r, c] + 1
                queue.append((nr, nc))
    rows, cols = np.nonzero(dist > 0)
    manhattan = np.abs(rows - pad[0]) + np.abs(cols - pad[1])
    return float((dist[rows, cols] / manhattan).mean())


@pytest.mark.parametrize("seed", [1, 2])
def test_building_ways_follow_the_halls(seed: int) -> None:
    """Rooms off halls: the way to a cell is near the Manhattan distance, where
    in the maze of ``rooms`` it winds through the walls between."""
    building = mapgen.building(200, 200, seed)
    assert detour_ratio(building) < 1.15
    assert detour_ratio(mapgen.rooms(200, 200, seed)) > 2.0
    # Its rooms are walled off from the halls but for their doors.
    assert building.free_count < 0.9 * (198 * 198)


def test_cli_builds_a_building_with_its_options(tmp_path: Path) -> None:
    out = tmp_path / "b.txt"
    assert run_cli("map", "building", "--size", "90x70", "--block", "20", "--out", str(out)) == 0
    assert np.array_equal(load_map(out).obstacle, mapgen.building(90, 70, 0, block=20).obstacle)
