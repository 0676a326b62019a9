"""Seeded random ground-truth maps.

Every generator returns a :class:`GridMap` with a one-cell obstacle border, a
single charging pad in the middle of the bottom border (the only entrance, as
in the paper) and every free cell 4-connected to it: free pockets that cannot
be reached are filled with obstacle. The same arguments and seed always give
the same map (``numpy.random.default_rng(seed)``).
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np

from core.cells import Cell, Direction
from sitl_mock.gridmap import GridMap
from sitl_mock.maps import make_map, reachable_mask

#: Smallest map a generator accepts (border, pad and a little room).
MIN_SIZE = 5


def entrance(height: int, width: int) -> Cell:
    """The charging pad: the middle of the bottom border row."""
    return (height - 1, width // 2)


# --------------------------------------------------------------------------- bars


def bars(
    height: int = 30,
    width: int = 30,
    count: int = 13,
    min_len: int = 4,
    max_len: int = 9,
    seed: int = 0,
) -> GridMap:
    """One-cell-wide straight bars, horizontal or vertical (the paper's 30x30 benchmark).

    Bars never overlap or touch each other (each stays a separate obstacle) but
    may touch the border. When a bar cannot be placed after many tries the map
    has fewer bars.
    """
    _check_size(height, width)
    if not 1 <= min_len <= max_len:
        raise ValueError(f"bar lengths need 1 <= min_len <= max_len, got {min_len}..{max_len}")
    if count < 0:
        raise ValueError(f"bar count must be >= 0, got {count}")
    rng = np.random.default_rng(seed)
    placed = np.zeros((height, width), dtype=bool)
    entry = _entry(height, width)
    inner_h, inner_w = height - 2, width - 2
    done = 0
    for _ in range(count * 200):
        if done == count:
            break
        length = int(rng.integers(min_len, max_len + 1))
        horizontal = bool(rng.integers(2))
        span_h, span_w = (1, length) if horizontal else (length, 1)
        if span_h > inner_h or span_w > inner_w:
            continue
        r0 = 1 + int(rng.integers(inner_h - span_h + 1))
        c0 = 1 + int(rng.integers(inner_w - span_w + 1))
        r1, c1 = r0 + span_h, c0 + span_w
        if placed[r0 - 1 : r1 + 1, c0 - 1 : c1 + 1].any():
            continue
        if r0 <= entry[0] < r1 and c0 <= entry[1] < c1:
            continue
        placed[r0:r1, c0:c1] = True
        done += 1
    return _finish(placed, connect_width=1)


# -------------------------------------------------------------------------- rooms


def rooms(
    height: int = 60,
    width: int = 60,
    seed: int = 0,
    *,
    room_min: int = 4,
    room_max: int = 12,
    door_width: int = 2,
    corridor_width: int = 2,
    corridor_prob: float = 0.25,
) -> GridMap:
    """A maze of rooms and corridors by recursive division.

    Walls are one cell thick; every wall has one door of ``door_width`` cells.
    A split is sometimes a corridor (two parallel walls ``corridor_width``
    apart) instead of a single wall. Rooms are ``room_min`` to ``room_max``
    cells on a side (larger only when the map itself is too small to divide).
    """
    _check_size(height, width)
    shape = _RoomShape(room_min, room_max, door_width, corridor_width, corridor_prob)
    rng = np.random.default_rng(seed)
    obstacle = np.zeros((height, width), dtype=bool)
    _set_border(obstacle)
    _rooms_in(obstacle, (1, 1, height - 2, width - 2), rng, shape)
    return _finish(obstacle, connect_width=2)


@dataclass(frozen=True)
class _RoomShape:
    room_min: int
    room_max: int
    door_width: int
    corridor_width: int
    corridor_prob: float

    def __post_init__(self) -> None:
        room_min, room_max, door_width = self.room_min, self.room_max, self.door_width
        if room_min < 1 or room_max < 2 * room_min + 1:
            raise ValueError(
                f"need room_min >= 1 and room_max >= 2 * room_min + 1, got {room_min}, {room_max}"
            )
        if not 1 <= door_width <= room_min:
            raise ValueError(f"door_width must be in 1..room_min ({room_min}), got {door_width}")
        if self.corridor_width < 1:
            raise ValueError(f"corridor_width must be >= 1, got {self.corridor_width}")


#: A box of free cells, rows ``r0..r1`` and columns ``c0..c1`` inclusive.
_Box = tuple[int, int, int, int]


def _rooms_in(
    obstacle: np.ndarray, region: _Box, rng: np.random.Generator, shape: _RoomShape
) -> list[_Box]:
    """Divide ``region`` (walled all round in ``obstacle``) into rooms by recursive
    division, one door in every wall; returns the rooms."""
    leaves: list[_Box] = []
    stack = [region]
    while stack:
        r0, c0, r1, c1 = stack.pop()
        h, w = r1 - r0 + 1, c1 - c0 + 1
        if max(h, w) <= shape.room_max:
            leaves.append((r0, c0, r1, c1))
            continue
        if h >= w:
            # Horizontal walls: divide the transposed view, then swap back.
            parts = [
                (a, b, c, d) for b, a, d, c in _divide(obstacle.T, (c0, r0, c1, r1), rng, shape)
            ]
        else:
            parts = _divide(obstacle, (r0, c0, r1, c1), rng, shape)
        if not parts:
            leaves.append((r0, c0, r1, c1))
        stack.extend(parts)
    return leaves


def _divide(
    grid: np.ndarray,
    region: tuple[int, int, int, int],
    rng: np.random.Generator,
    shape: _RoomShape,
) -> list[tuple[int, int, int, int]]:
    """Split ``region`` by vertical wall(s) in ``grid`` (pass ``grid.T`` for horizontal ones).

    Returns the sub-regions still to divide; a corridor is not divided.
    """
    r0, c0, r1, c1 = region
    room_min, door_width = shape.room_min, shape.door_width
    corridor = (
        rng.random() < shape.corridor_prob
        and (c1 - c0 + 1) >= 2 * room_min + shape.corridor_width + 2
    )
    gap = shape.corridor_width + 1 if corridor else 0
    lo, hi = c0 + room_min, c1 - room_min - gap
    # A wall must not end in a door of the enclosing walls, or it would block it.
    columns = [
        c
        for c in range(lo, hi + 1)
        if all(grid[r0 - 1, x] and grid[r1 + 1, x] for x in {c, c + gap})
    ]
    if not columns:
        return []
    wall = columns[int(rng.integers(len(columns)))]
    walls = (wall, wall + gap) if corridor else (wall,)
    for col in walls:
        grid[r0 : r1 + 1, col] = True
        door = r0 + int(rng.integers(r1 - r0 + 2 - door_width))
        grid[door : door + door_width, col] = False
    return [(r0, c0, r1, wall - 1), (r0, walls[-1] + 1, r1, c1)]


# ----------------------------------------------------------------------- building


def building(
    height: int = 60,
    width: int = 60,
    seed: int = 0,
    *,
    block: int = 40,
    hall_width: int = 3,
    room_min: int = 4,
    room_max: int = 12,
    door_width: int = 2,
) -> GridMap:
    """Rooms off a grid of halls, like the floor of an office block.

    Halls ``hall_width`` cells wide run across the map both ways with blocks of
    ``block`` cells a side between them (walls included); each block is
    divided into rooms as ``rooms`` divides the map (one door in every wall),
    and each room on a block's edge has a door onto a hall beside it. So the
    way between two rooms follows the halls, near the Manhattan distance,
    where in the single maze of ``rooms`` it winds through every wall between.
    """
    _check_size(height, width)
    shape = _RoomShape(room_min, room_max, door_width, 1, 0.0)  # no corridors in a block
    if hall_width < 1:
        raise ValueError(f"hall_width must be >= 1, got {hall_width}")
    if block < room_min + 2:
        raise ValueError(f"block must be >= room_min + 2 ({room_min + 2}), got {block}")
    rng = np.random.default_rng(seed)
    obstacle = np.zeros((height, width), dtype=bool)
    _set_border(obstacle)
    for a0, a1 in _blocks_along(height, block, hall_width, room_min + 2):
        for b0, b1 in _blocks_along(width, block, hall_width, room_min + 2):
            obstacle[a0 : a1 + 1, b0 : b1 + 1] = True
            obstacle[a0 + 1 : a1, b0 + 1 : b1] = False
            for room in _rooms_in(obstacle, (a0 + 1, b0 + 1, a1 - 1, b1 - 1), rng, shape):
                _door_out(obstacle, room, (a0, b0, a1, b1), rng, door_width)
    return _finish(obstacle, connect_width=min(hall_width, 2))


def _blocks_along(length: int, block: int, hall: int, smallest: int) -> list[tuple[int, int]]:
    """The spans (first, last) of the blocks along a side of ``length`` cells, a
    hall inside each border and one between each two: as many blocks as fit at
    ``block`` cells (at least one, if one of ``smallest`` fits), stretched to
    fill the side."""
    inside = length - 2 - hall
    count = max(1, inside // (block + hall))
    if inside - count * hall < smallest:
        return []  # no room for a block with a wall round it
    room = inside - count * hall  # for the blocks themselves
    spans = []
    at = 1 + hall
    for k in range(count):
        size = room // count + (1 if k < room % count else 0)
        spans.append((at, at + size - 1))
        at += size + hall
    return spans


def _door_out(
    obstacle: np.ndarray, room: _Box, block: _Box, rng: np.random.Generator, door_width: int
) -> None:
    """A door in one of ``room``'s walls that are the walls of its ``block``, if any."""
    r0, c0, r1, c1 = room
    a0, b0, a1, b1 = block
    walls = [
        (row, c0, c1, True) for row, edge in ((a0, r0 == a0 + 1), (a1, r1 == a1 - 1)) if edge
    ] + [(col, r0, r1, False) for col, edge in ((b0, c0 == b0 + 1), (b1, c1 == b1 - 1)) if edge]
    if not walls:
        return
    line, lo, hi, across = walls[int(rng.integers(len(walls)))]
    door = lo + int(rng.integers(hi - lo + 2 - door_width))
    if across:
        obstacle[line, door : door + door_width] = False
    else:
        obstacle[door : door + door_width, line] = False


# -------------------------------------------------------------------------- caves


def caves(
    height: int = 60,
    width: int = 60,
    seed: int = 0,
    *,
    fill: float = 0.45,
    steps: int = 4,
) -> GridMap:
    """Cellular-automaton caves: random rock at ``fill``, smoothed ``steps`` times.

    A cell becomes rock when at least 5 of the 9 cells of its 3x3 block are
    rock. The largest cave is joined to the entrance by a short tunnel if they
    are apart; smaller caves are filled.
    """
    _check_size(height, width)
    if not 0.0 <= fill <= 1.0:
        raise ValueError(f"fill must be in [0, 1], got {fill}")
    if steps < 0:
        raise ValueError(f"steps must be >= 0, got {steps}")
    rng = np.random.default_rng(seed)
    rock = rng.random((height, width)) < fill
    for _ in range(steps):
        _set_border(rock)
        padded = np.pad(rock, 1, constant_values=True).astype(np.int8)
        count = sum(
            padded[1 + dr : 1 + dr + height, 1 + dc : 1 + dc + width]
            for dr in (-1, 0, 1)
            for dc in (-1, 0, 1)
        )
        rock = np.asarray(count >= 5)
    return _finish(rock, connect_width=2)


# ---------------------------------------------------------------------- branching


@dataclass(frozen=True)
class _Rect:
    """Rows ``r0..r1-1``, columns ``c0..c1-1``."""

    r0: int
    c0: int
    r1: int
    c1: int

    @property
    def vertical(self) -> bool:
        return self.r1 - self.r0 >= self.c1 - self.c0

    def lateral(self, direction: Direction) -> tuple[int, int]:
        """The span along which something leaving towards ``direction`` can attach."""
        return (self.r0, self.r1) if direction.dc else (self.c0, self.c1)

    def start(self, direction: Direction) -> int:
        """The first row/column just outside this rectangle towards ``direction``."""
        return {
            Direction.E: self.c1,
            Direction.W: self.c0 - 1,
            Direction.S: self.r1,
            Direction.N: self.r0 - 1,
        }[direction]


def _rect_from(direction: Direction, start: int, lo: int, span: int, length: int) -> _Rect:
    """The rectangle leaving line ``start`` towards ``direction``, laterally ``lo..lo+span``."""
    if direction is Direction.E:
        return _Rect(lo, start, lo + span, start + length)
    if direction is Direction.W:
        return _Rect(lo, start - length + 1, lo + span, start + 1)
    if direction is Direction.S:
        return _Rect(start, lo, start + length, lo + span)
    return _Rect(start - length + 1, lo, start + 1, lo + span)


def branching(
    height: int = 60,
    width: int = 60,
    seed: int = 0,
    *,
    branches: int | None = None,
    min_width: int = 2,
    max_width: int = 4,
    trunk_width: int | None = None,
    min_len: int = 4,
    max_len: int | None = None,
    wing_prob: float = 0.4,
    wing_min: int = 4,
    wing_max: int | None = None,
) -> GridMap:
    """An indoor area: a trunk corridor north from the entrance with branches and wings.

    Branches (``min_width``..``max_width`` wide) leave an existing corridor at a
    right angle; some end in a wider wing (a room of ``wing_min``..``wing_max``
    cells a side). The layout is a tree: any two corridors are separated by
    wall except where one leaves the other, so every passage is as wide as the
    narrower of the two. ``branches`` is how many branches to place (default:
    scaled to the area); fewer when no more fit. Wings come on top.
    """
    _check_size(height, width)
    if not 1 <= min_width <= max_width:
        raise ValueError(f"need 1 <= min_width <= max_width, got {min_width}..{max_width}")
    trunk_width = min(max_width, width - 2) if trunk_width is None else trunk_width
    max_len = max(min_len, min(height, width) // 2) if max_len is None else max_len
    wing_max = max(wing_min, min(height, width) // 5) if wing_max is None else wing_max
    branches = max(4, height * width // 80) if branches is None else branches
    if trunk_width < 1 or trunk_width > width - 2:
        raise ValueError(f"trunk_width must be in 1..{width - 2}, got {trunk_width}")
    if not 1 <= min_len <= max_len or not 1 <= wing_min <= wing_max:
        raise ValueError("need 1 <= min_len <= max_len and 1 <= wing_min <= wing_max")
    rng = np.random.default_rng(seed)
    free = np.zeros((height, width), dtype=bool)
    pad_row, pad_col = entrance(height, width)
    inner_h = height - 2
    trunk_len = int(rng.integers(max(1, inner_h * 2 // 5), inner_h + 1))
    left = min(max(1, pad_col - trunk_width // 2), width - 1 - trunk_width)
    trunk = _Rect(pad_row - trunk_len, left, pad_row, left + trunk_width)
    free[trunk.r0 : trunk.r1, trunk.c0 : trunk.c1] = True
    shape = _Branches(min_width, max_width, min_len, max_len, wing_prob, wing_min, wing_max)
    _place_branches(free, rng, [trunk], branches, shape)
    return _finish(~free, connect_width=min_width)


@dataclass(frozen=True)
class _Branches:
    """The sizes of ``branching``'s branches and of the wings at their ends."""

    min_width: int
    max_width: int
    min_len: int
    max_len: int
    wing_prob: float
    wing_min: int
    wing_max: int


def _place_branches(
    free: np.ndarray,
    rng: np.random.Generator,
    segments: list[_Rect],
    branches: int,
    shape: _Branches,
) -> None:
    """Up to ``branches`` branches off random corridors of ``segments`` (each, with
    ``wing_prob``, ending in a wing), carved into ``free``; fewer when no more fit."""
    placed = 0
    for _ in range(20 * branches):
        if placed == branches:
            break
        parent = segments[int(rng.integers(len(segments)))]
        sides = (Direction.E, Direction.W) if parent.vertical else (Direction.N, Direction.S)
        direction = sides[int(rng.integers(2))]
        span = int(rng.integers(shape.min_width, shape.max_width + 1))
        lo, hi = parent.lateral(direction)
        if hi - lo < span:
            continue
        offset = lo + int(rng.integers(hi - lo - span + 1))
        length = int(rng.integers(shape.min_len, shape.max_len + 1))
        branch = _grow(free, parent, direction, offset, span, shape.min_len, length)
        if branch is None:
            continue
        segments.append(branch)
        placed += 1
        if rng.random() < shape.wing_prob:
            wing_min, wing_max = shape.wing_min, shape.wing_max
            wing_span = int(rng.integers(max(wing_min, span), max(wing_max, span) + 1))
            wing_lo = offset - int(rng.integers(wing_span - span + 1))
            depth = int(rng.integers(wing_min, wing_max + 1))
            wing = _grow(free, branch, direction, wing_lo, wing_span, wing_min, depth)
            if wing is not None:
                segments.append(wing)


def _grow(
    free: np.ndarray,
    parent: _Rect,
    direction: Direction,
    lo: int,
    span: int,
    min_len: int,
    length: int,
) -> _Rect | None:
    """Carve the longest rectangle up to ``length`` that fits, or None below ``min_len``.

    It fits when it stays inside the border and no free cell other than the
    parent's lies in it or around it (so corridors never merge sideways).
    """
    start = parent.start(direction)

    def fits(n: int) -> bool:
        rect = _rect_from(direction, start, lo, span, n)
        height, width = free.shape
        if rect.r0 < 1 or rect.c0 < 1 or rect.r1 > height - 1 or rect.c1 > width - 1:
            return False
        r0, c0, r1, c1 = rect.r0 - 1, rect.c0 - 1, rect.r1 + 1, rect.c1 + 1
        around = int(free[r0:r1, c0:c1].sum())
        overlap = max(0, min(r1, parent.r1) - max(r0, parent.r0)) * max(
            0, min(c1, parent.c1) - max(c0, parent.c0)
        )
        return around == overlap

    if not fits(min_len):
        return None
    good, bad = min_len, length + 1
    while bad - good > 1:  # fits() is monotone in the length
        mid = (good + bad) // 2
        good, bad = (mid, bad) if fits(mid) else (good, mid)
    rect = _rect_from(direction, start, lo, span, good)
    free[rect.r0 : rect.r1, rect.c0 : rect.c1] = True
    return rect


# --------------------------------------------------------------------- open field


def open_field(
    height: int = 60,
    width: int = 60,
    seed: int = 0,
    density: float = 0.1,
    *,
    max_size: int = 3,
    clearance: int = 1,
) -> GridMap:
    """An open area with scattered rectangular obstacles of 1..``max_size`` cells a side.

    Obstacles are added until about ``density`` of the interior is covered (or
    no more fit). Each keeps at least ``clearance`` free cells from every other
    obstacle and from the border, so ``clearance >= 1`` never closes a pocket
    and ``clearance >= 2`` leaves every passage at least two cells wide.
    """
    _check_size(height, width)
    if not 0.0 <= density < 1.0:
        raise ValueError(f"density must be in [0, 1), got {density}")
    if max_size < 1 or clearance < 0:
        raise ValueError(f"need max_size >= 1 and clearance >= 0, got {max_size}, {clearance}")
    rng = np.random.default_rng(seed)
    obstacle = np.zeros((height, width), dtype=bool)
    _set_border(obstacle)
    entry = _entry(height, width)
    target = density * (height - 2) * (width - 2)
    mean_area = ((1 + max_size) / 2) ** 2
    tries = int(20 * target / mean_area) + 10
    sizes = rng.integers(1, max_size + 1, size=(tries, 2))
    corners = rng.random((tries, 2))
    covered = 0
    for (h, w), (fr, fc) in zip(sizes.tolist(), corners.tolist(), strict=True):
        if covered >= target:
            break
        r0 = 1 + int(fr * (height - 1 - h))
        c0 = 1 + int(fc * (width - 1 - w))
        r1, c1 = r0 + h, c0 + w
        if r1 > height - 1 or c1 > width - 1:
            continue
        if r0 - clearance <= entry[0] < r1 + clearance and c0 - clearance <= entry[1] < (
            c1 + clearance
        ):
            continue
        lo_r, lo_c = max(0, r0 - clearance), max(0, c0 - clearance)
        if clearance and obstacle[lo_r : r1 + clearance, lo_c : c1 + clearance].any():
            continue
        if not clearance and obstacle[r0:r1, c0:c1].any():
            continue
        obstacle[r0:r1, c0:c1] = True
        covered += h * w
    return _finish(obstacle, connect_width=max(1, clearance))


# ------------------------------------------------------------------------ helpers


def _check_size(height: int, width: int) -> None:
    if height < MIN_SIZE or width < MIN_SIZE:
        raise ValueError(f"map must be at least {MIN_SIZE}x{MIN_SIZE} cells, got {height}x{width}")


def _entry(height: int, width: int) -> Cell:
    """The free cell just inside the entrance."""
    row, col = entrance(height, width)
    return (row - 1, col)


def _set_border(obstacle: np.ndarray) -> None:
    obstacle[0, :] = obstacle[-1, :] = True
    obstacle[:, 0] = obstacle[:, -1] = True


def _finish(obstacle: np.ndarray, connect_width: int) -> GridMap:
    """Add the border and the pad, join the entrance to the largest area, fill the rest."""
    obstacle = obstacle.copy()
    height, width = obstacle.shape
    _set_border(obstacle)
    pad = entrance(height, width)
    entry = _entry(height, width)
    reach = reachable_mask(obstacle, entry)
    interior_free = int((~obstacle).sum())
    if 2 * int(reach.sum()) <= interior_free:
        largest = _largest_component(obstacle)
        if largest is None:
            obstacle[entry] = False
        else:
            _carve(obstacle, entry, _nearest(largest, entry), connect_width)
    obstacle[pad] = False
    reach = reachable_mask(obstacle, pad)
    return make_map(~reach, (pad,))


def _largest_component(obstacle: np.ndarray) -> np.ndarray | None:
    """Mask of the largest 4-connected free area, or None when nothing is free."""
    height, width = obstacle.shape
    stride = width + 2
    padded = np.ones((height + 2, stride), dtype=bool)
    padded[1:-1, 1:-1] = obstacle
    blocked = bytearray(padded.tobytes())
    best: list[int] = []
    for first in np.flatnonzero(~padded).tolist():
        if blocked[first]:
            continue
        blocked[first] = 1
        members = [first]
        queue = deque(members)
        while queue:
            idx = queue.popleft()
            for nxt in (idx - stride, idx + stride, idx + 1, idx - 1):
                if not blocked[nxt]:
                    blocked[nxt] = 1
                    queue.append(nxt)
                    members.append(nxt)
        if len(members) > len(best):
            best = members
    if not best:
        return None
    flat = np.zeros((height + 2) * stride, dtype=bool)
    flat[np.asarray(best, dtype=np.int64)] = True
    return flat.reshape(height + 2, stride)[1:-1, 1:-1].copy()


def _nearest(mask: np.ndarray, cell: Cell) -> Cell:
    rows, cols = np.nonzero(mask)
    best = int(np.argmin(np.abs(rows - cell[0]) + np.abs(cols - cell[1])))
    return (int(rows[best]), int(cols[best]))


def _carve(obstacle: np.ndarray, start: Cell, goal: Cell, width: int) -> None:
    """Clear an L-shaped tunnel ``width`` cells wide: north/south first, then east/west."""
    full_width = obstacle.shape[1]
    (r0, c0), (r1, c1) = start, goal
    path = [(r, c0) for r in range(min(r0, r1), max(r0, r1) + 1)]
    path += [(r1, c) for c in range(min(c0, c1), max(c0, c1) + 1)]
    for r, c in path:
        rows = slice(max(1, r - width + 1), r + 1)
        cols = slice(c, min(full_width - 1, c + width))
        obstacle[rows, cols] = False
    obstacle[start] = False
