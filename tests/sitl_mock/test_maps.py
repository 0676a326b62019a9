"""ASCII and PNG map reading and writing (sitl_mock.maps)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from PIL import Image

from sitl_mock.maps import MapError, load_map, make_map, parse_ascii, reachable_mask, to_ascii

SMALL = "#####\n#...#\n#.#.#\n##C##\n"


def test_parse_reads_rows_from_the_north() -> None:
    grid = parse_ascii(SMALL)
    assert grid.shape == (4, 5)
    assert grid.pads == ((3, 2),)
    assert grid.charger == (3, 2)
    assert grid.obstacle[0].all()
    assert not grid.obstacle[1, 1]
    assert grid.obstacle[2, 2]
    assert grid.free_count == 6


def test_pad_cells_are_free_and_listed_in_reading_order() -> None:
    grid = parse_ascii("#C#\n#.#\n#C#\n")
    assert grid.pads == ((0, 1), (2, 1))
    assert not grid.obstacle[0, 1]


def test_trailing_whitespace_and_blank_lines_are_ignored() -> None:
    text = "#####  \r\n#...#\t\r\n#.#.#\r\n##C## \r\n\r\n   \n\n"
    assert np.array_equal(parse_ascii(text).obstacle, parse_ascii(SMALL).obstacle)


def test_to_ascii_round_trips() -> None:
    assert to_ascii(parse_ascii(SMALL)) == SMALL


def test_maps_are_read_only() -> None:
    grid = parse_ascii(SMALL)
    with pytest.raises(ValueError):
        grid.obstacle[1, 1] = True


@pytest.mark.parametrize(
    ("text", "problem"),
    [
        ("", "map is empty"),
        ("  \n\n \n", "map is empty"),
        ("#####\n#..#\n##C##\n", "not rectangular: line 2 has 4 cells, expected 5"),
        ("###\n\n#C#\n", "not rectangular: line 2 has 0 cells, expected 3"),
        (
            "#####\n#..x#\n##C##\n",
            "unknown character 'x' at line 2, column 4 (expected '#', '.' or 'C')",
        ),
        (
            " ####\n#...#\n##C##\n",
            "unknown character ' ' at line 1, column 1 (expected '#', '.' or 'C')",
        ),
        ("#####\n#...#\n#####\n", "no charging pad 'C'"),
    ],
)
def test_parse_errors_name_the_problem(text: str, problem: str) -> None:
    with pytest.raises(MapError) as info:
        parse_ascii(text, "maps/x.txt")
    assert info.value.problem == problem
    assert str(info.value) == f"maps/x.txt: {problem}"
    assert "\n" not in str(info.value)


def test_a_pad_can_be_optional() -> None:
    grid = parse_ascii("###\n#.#\n###\n", require_pad=False)
    assert grid.pads == ()


@given(
    st.integers(1, 12).flatmap(
        lambda w: st.lists(st.text("#.C", min_size=w, max_size=w), min_size=1, max_size=12)
    )
)
@settings(max_examples=60, deadline=None)
def test_any_grid_round_trips(rows: list[str]) -> None:
    text = "".join(row + "\n" for row in rows)
    grid = parse_ascii(text, require_pad=False)
    assert to_ascii(grid) == text
    assert grid.free_count == sum(ch != "#" for ch in text if ch != "\n")


def test_load_ascii_files(tmp_path: Path) -> None:
    for suffix in (".txt", ".map"):
        path = tmp_path / f"m{suffix}"
        path.write_text(SMALL)
        assert to_ascii(load_map(path)) == SMALL


def test_load_png_dark_pixels_are_obstacles(tmp_path: Path) -> None:
    pixels = np.full((4, 6, 3), 255, dtype=np.uint8)
    pixels[0, :] = (0, 0, 0)
    pixels[2, 3] = (100, 100, 100)  # luminance 100: obstacle
    pixels[3, 1] = (200, 200, 200)  # luminance 200: free
    path = tmp_path / "m.png"
    Image.fromarray(pixels).save(path)
    grid = load_map(path)
    assert grid.shape == (4, 6)
    assert grid.pads == ()
    expected = np.zeros((4, 6), dtype=bool)
    expected[0, :] = True
    expected[2, 3] = True
    assert np.array_equal(grid.obstacle, expected)


def test_transparent_png_pixels_are_free(tmp_path: Path) -> None:
    pixels = np.zeros((2, 2, 4), dtype=np.uint8)  # all black
    pixels[0, 0, 3] = 255  # only this one is opaque
    path = tmp_path / "m.png"
    Image.fromarray(pixels).save(path)
    assert load_map(path).obstacle.tolist() == [[True, False], [False, False]]


@pytest.mark.parametrize(
    ("name", "content", "problem"),
    [
        ("m.jpg", b"", "unsupported map format '.jpg' (expected .txt, .map, .png)"),
        ("m.png", b"not an image", "not a valid image"),
        ("m.txt", b"\xff\xfe#", "not a text map (not valid UTF-8)"),
        ("missing.txt", None, "cannot read file: No such file or directory"),
    ],
)
def test_load_errors(tmp_path: Path, name: str, content: bytes | None, problem: str) -> None:
    path = tmp_path / name
    if content is not None:
        path.write_bytes(content)
    with pytest.raises(MapError) as info:
        load_map(path)
    assert info.value.problem == problem


@given(st.integers(0, 2**32 - 1), st.integers(1, 25), st.integers(1, 25))
@settings(max_examples=40, deadline=None)
def test_reachable_mask_matches_gridmap(seed: int, height: int, width: int) -> None:
    rng = np.random.default_rng(seed)
    obstacle = rng.random((height, width)) < 0.4
    start = (int(rng.integers(height)), int(rng.integers(width)))
    grid = make_map(obstacle, (start,))
    assert np.array_equal(reachable_mask(obstacle, start), grid.reachable())
