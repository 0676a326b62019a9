"""``gcs map KIND``: generate a random ground-truth map and write it as ASCII."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable

from gcs.errors import EXIT_BAD_INPUT, EXIT_OK
from gcs.options.map import MapKind
from sitl_mock import mapgen
from sitl_mock.gridmap import GridMap
from sitl_mock.maps import MAX_MAP_CELLS, to_ascii

#: How each kind of map is made from its options (``gcs.options.map``).
BUILDERS: dict[MapKind, Callable[[argparse.Namespace, int, int], GridMap]] = {
    MapKind.BARS: lambda a, h, w: mapgen.bars(h, w, a.count, a.min_len, a.max_len, a.seed),
    MapKind.ROOMS: lambda a, h, w: mapgen.rooms(
        h,
        w,
        a.seed,
        room_min=a.room_min,
        room_max=a.room_max,
        door_width=a.door_width,
        corridor_width=a.corridor_width,
        corridor_prob=a.corridor_prob,
    ),
    MapKind.BUILDING: lambda a, h, w: mapgen.building(
        h,
        w,
        a.seed,
        block=a.block,
        hall_width=a.hall_width,
        room_min=a.room_min,
        room_max=a.room_max,
        door_width=a.door_width,
    ),
    MapKind.CAVES: lambda a, h, w: mapgen.caves(h, w, a.seed, fill=a.fill, steps=a.steps),
    MapKind.BRANCHING: lambda a, h, w: mapgen.branching(
        h,
        w,
        a.seed,
        branches=a.branches,
        min_width=a.min_width,
        max_width=a.max_width,
        trunk_width=a.trunk_width,
        min_len=a.min_len,
        max_len=a.max_len,
        wing_prob=a.wing_prob,
        wing_min=a.wing_min,
        wing_max=a.wing_max,
    ),
    MapKind.OPEN: lambda a, h, w: mapgen.open_field(
        h, w, a.seed, a.density, max_size=a.max_size, clearance=a.clearance
    ),
}


def run(args: argparse.Namespace) -> int:
    """Generate the map described by ``args``; return the exit status."""
    height, width = args.size
    if height * width > MAX_MAP_CELLS:
        print(
            f"gcs map {args.map_kind}: --size {height}x{width} is more than the "
            f"{MAX_MAP_CELLS:,} cells a map may have",
            file=sys.stderr,
        )
        return EXIT_BAD_INPUT
    try:
        grid = BUILDERS[args.map_kind](args, height, width)
    except ValueError as exc:
        print(f"gcs map {args.map_kind}: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    text = to_ascii(grid)
    if args.out is None:
        sys.stdout.write(text)
        return EXIT_OK
    try:
        args.out.write_text(text, encoding="utf-8")
    except OSError as exc:
        print(f"gcs map: cannot write {args.out}: {exc.strerror or exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    print(
        f"wrote {args.out}: {height}x{width} cells, {grid.free_count} free, "
        f"charger at {grid.charger}",
        file=sys.stderr,
    )
    return EXIT_OK
