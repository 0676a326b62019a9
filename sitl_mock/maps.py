"""Reading and writing ground-truth maps: ASCII grids and PNG images.

ASCII maps use ``#`` for an obstacle, ``.`` for a free cell and ``C`` for a
charging pad (a free cell); the first line is the northern edge (row 0).
Trailing whitespace on a line and blank lines at the end are ignored.

PNG maps mark obstacles with dark pixels (luminance < 128, transparent pixels
count as white) and carry no charging pad: the mission gives it separately.
"""

from __future__ import annotations

import warnings
from collections import deque
from pathlib import Path

import numpy as np
from PIL import Image, UnidentifiedImageError

from core.cells import Cell
from sitl_mock.gridmap import GridMap

OBSTACLE_CHAR = "#"
FREE_CHAR = "."
PAD_CHAR = "C"
ASCII_SUFFIXES = (".txt", ".map")
PNG_SUFFIXES = (".png",)
#: Pixels darker than this (0..255 luminance) are obstacles.
DARK_THRESHOLD = 128


#: The largest map read, in cells (2000 x 2000): four times the largest the planner is
#: benchmarked on. A map file can claim any size (a 76 KB PNG of 20000 x 20000 pixels,
#: an ASCII file of 400 MB), so the size is checked before anything is decoded.
MAX_MAP_CELLS = 4_000_000
#: Bytes an ASCII map of the largest size takes at most (CRLF line ends, trailing blanks).
_MAX_ASCII_BYTES = 2 * MAX_MAP_CELLS + 100_000


class MapError(ValueError):
    """A map that cannot be read or is malformed.

    ``problem`` is the bare one-line description; ``str()`` prefixes it with
    the source (file name or ``<string>``).
    """

    def __init__(self, problem: str, source: str = "<string>") -> None:
        super().__init__(f"{source}: {problem}")
        self.problem = problem
        self.source = source


def check_map_size(rows: int, cols: int, source: str = "<string>") -> None:
    """Refuse a map larger than ``MAX_MAP_CELLS`` before it is allocated."""
    if rows * cols > MAX_MAP_CELLS:
        raise MapError(
            f"{rows} x {cols} cells is more than the {MAX_MAP_CELLS:,} cells a map may have",
            source,
        )


def make_map(obstacle: np.ndarray, pads: tuple[Cell, ...]) -> GridMap:
    """A GridMap over a read-only copy of ``obstacle`` (ground truth never changes)."""
    grid = np.array(obstacle, dtype=bool, copy=True)
    grid.flags.writeable = False
    return GridMap(obstacle=grid, pads=tuple((int(r), int(c)) for r, c in pads))


def parse_ascii(text: str, source: str = "<string>", *, require_pad: bool = True) -> GridMap:
    """Parse an ASCII map; pads are listed in reading order (the first is the charger).

    With ``require_pad=False`` a map without any ``C`` is accepted (its pads are
    then empty and the caller must supply the charger).
    """
    lines = [line.rstrip() for line in text.splitlines()]
    while lines and not lines[-1]:
        lines.pop()
    if not lines:
        raise MapError("map is empty", source)
    width = len(lines[0])
    check_map_size(len(lines), width, source)
    codes = {OBSTACLE_CHAR: True, FREE_CHAR: False, PAD_CHAR: False}
    obstacle = np.zeros((len(lines), width), dtype=bool)
    pads: list[Cell] = []
    for row, line in enumerate(lines):
        if len(line) != width:
            raise MapError(
                f"not rectangular: line {row + 1} has {len(line)} cells, expected {width}",
                source,
            )
        for col, char in enumerate(line):
            if char not in codes:
                raise MapError(
                    f"unknown character {char!r} at line {row + 1}, column {col + 1}"
                    f" (expected '{OBSTACLE_CHAR}', '{FREE_CHAR}' or '{PAD_CHAR}')",
                    source,
                )
            obstacle[row, col] = codes[char]
            if char == PAD_CHAR:
                pads.append((row, col))
    if require_pad and not pads:
        raise MapError(f"no charging pad '{PAD_CHAR}'", source)
    return make_map(obstacle, tuple(pads))


def to_ascii(grid: GridMap) -> str:
    """The ASCII form of ``grid``, one line per row, ending with a newline."""
    chars = np.where(grid.obstacle, OBSTACLE_CHAR, FREE_CHAR).astype("<U1")
    for pad in grid.pads:
        chars[pad] = PAD_CHAR
    return "".join("".join(row) + "\n" for row in chars)


def load_map(path: str | Path, *, require_pad: bool = True) -> GridMap:
    """Load an ASCII (``.txt``, ``.map``) or PNG (``.png``) map file.

    ``require_pad`` applies to ASCII maps only; PNG maps never have pads.
    """
    path = Path(path)
    source = str(path)
    suffix = path.suffix.lower()
    if suffix in ASCII_SUFFIXES:
        try:
            if path.stat().st_size > _MAX_ASCII_BYTES:
                raise MapError(
                    f"file of {path.stat().st_size:,} bytes is larger than a map of the "
                    f"largest size ({MAX_MAP_CELLS:,} cells)",
                    source,
                )
            text = path.read_text(encoding="utf-8")
        except UnicodeDecodeError:
            raise MapError("not a text map (not valid UTF-8)", source) from None
        except OSError as exc:
            raise MapError(f"cannot read file: {exc.strerror or exc}", source) from None
        return parse_ascii(text, source, require_pad=require_pad)
    if suffix in PNG_SUFFIXES:
        return _load_png(path)
    expected = ", ".join([*ASCII_SUFFIXES, *PNG_SUFFIXES])
    raise MapError(f"unsupported map format {suffix or '(none)'!r} (expected {expected})", source)


def _load_png(path: Path) -> GridMap:
    source = str(path)
    try:
        with warnings.catch_warnings():
            # PIL warns of a decompression bomb already at the header: far beyond the limit.
            warnings.simplefilter("error", Image.DecompressionBombWarning)
            with Image.open(path) as image:  # reads the header only
                check_map_size(image.height, image.width, source)
                image.load()
                rgba = image.convert("RGBA")
    except UnidentifiedImageError:
        raise MapError("not a valid image", source) from None
    except (Image.DecompressionBombError, Image.DecompressionBombWarning):
        raise MapError(
            f"image larger than a map may be ({MAX_MAP_CELLS:,} cells)", source
        ) from None
    except OSError as exc:
        raise MapError(f"cannot read file: {exc.strerror or exc}", source) from None
    background = Image.new("RGBA", rgba.size, (255, 255, 255, 255))
    luminance = np.asarray(Image.alpha_composite(background, rgba).convert("L"))
    if luminance.size == 0:
        raise MapError("map is empty", source)
    return make_map(luminance < DARK_THRESHOLD, ())


def reachable_mask(obstacle: np.ndarray, start: Cell) -> np.ndarray:
    """Free cells 4-connected to ``start`` (empty if ``start`` is not free).

    Same result as ``GridMap.reachable`` but over a flat padded array, fast
    enough for million-cell maps.
    """
    height, width = obstacle.shape
    seen = np.zeros((height, width), dtype=bool)
    if not (0 <= start[0] < height and 0 <= start[1] < width) or obstacle[start]:
        return seen
    stride = width + 2
    padded = np.ones((height + 2, stride), dtype=bool)
    padded[1:-1, 1:-1] = obstacle
    blocked = bytearray(padded.tobytes())  # 1 = obstacle or already visited
    first = (start[0] + 1) * stride + start[1] + 1
    blocked[first] = 1
    queue = deque([first])
    order = [first]
    steps = (-stride, stride, 1, -1)
    while queue:
        idx = queue.popleft()
        for step in steps:
            nxt = idx + step
            if not blocked[nxt]:
                blocked[nxt] = 1
                queue.append(nxt)
                order.append(nxt)
    flat = np.zeros((height + 2) * stride, dtype=bool)
    flat[np.asarray(order, dtype=np.int64)] = True
    seen[:] = flat.reshape(height + 2, stride)[1:-1, 1:-1]
    return seen
