"""``gcs map KIND``: generate a random ground-truth map and write it as ASCII."""

from __future__ import annotations

import argparse
import re
import sys
from collections.abc import Callable
from dataclasses import dataclass
from enum import StrEnum
from pathlib import Path

from gcs.errors import EXIT_BAD_INPUT, EXIT_OK
from sitl_mock import mapgen
from sitl_mock.gridmap import GridMap
from sitl_mock.maps import MAX_MAP_CELLS, to_ascii


class MapKind(StrEnum):
    BARS = "bars"
    ROOMS = "rooms"
    BUILDING = "building"
    CAVES = "caves"
    BRANCHING = "branching"
    OPEN = "open"


@dataclass(frozen=True)
class _KindInfo:
    help: str
    default_size: tuple[int, int]
    add_options: Callable[[argparse.ArgumentParser], None]
    build: Callable[[argparse.Namespace, int, int], GridMap]


def _size(text: str) -> tuple[int, int]:
    match = re.fullmatch(r"\s*(\d+)\s*[xX]\s*(\d+)\s*", text)
    if not match:
        raise argparse.ArgumentTypeError(f"expected HEIGHTxWIDTH such as 30x30, got {text!r}")
    rows, cols = int(match[1]), int(match[2])
    if rows * cols > MAX_MAP_CELLS:
        raise argparse.ArgumentTypeError(
            f"{rows}x{cols} is more than the {MAX_MAP_CELLS:,} cells a map may have"
        )
    return rows, cols


def _bars_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--count", type=int, default=13, help="number of bars (default: 13)")
    parser.add_argument("--min-len", type=int, default=4, help="shortest bar (default: 4)")
    parser.add_argument("--max-len", type=int, default=9, help="longest bar (default: 9)")


def _rooms_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--room-min", type=int, default=4, help="smallest room side (default: 4)")
    parser.add_argument(
        "--room-max", type=int, default=12, help="rooms larger than this are divided (default: 12)"
    )
    parser.add_argument("--door-width", type=int, default=2, help="door width (default: 2)")
    parser.add_argument("--corridor-width", type=int, default=2, help="corridor width (default: 2)")
    parser.add_argument(
        "--corridor-prob",
        type=float,
        default=0.25,
        help="chance that a division is a corridor (default: 0.25)",
    )


def _building_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--block", type=int, default=40, help="block side between halls, walls in (default: 40)"
    )
    parser.add_argument("--hall-width", type=int, default=3, help="hall width (default: 3)")
    parser.add_argument("--room-min", type=int, default=4, help="smallest room side (default: 4)")
    parser.add_argument(
        "--room-max", type=int, default=12, help="rooms larger than this are divided (default: 12)"
    )
    parser.add_argument("--door-width", type=int, default=2, help="door width (default: 2)")


def _caves_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--fill", type=float, default=0.45, help="initial rock fraction (default: 0.45)"
    )
    parser.add_argument("--steps", type=int, default=4, help="smoothing steps (default: 4)")


def _branching_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--branches", type=int, default=None, help="branches to place (default: area / 80)"
    )
    parser.add_argument("--min-width", type=int, default=2, help="narrowest branch (default: 2)")
    parser.add_argument("--max-width", type=int, default=4, help="widest branch (default: 4)")
    parser.add_argument(
        "--trunk-width", type=int, default=None, help="trunk width (default: --max-width)"
    )
    parser.add_argument("--min-len", type=int, default=4, help="shortest branch (default: 4)")
    parser.add_argument(
        "--max-len", type=int, default=None, help="longest branch (default: half the map)"
    )
    parser.add_argument(
        "--wing-prob",
        type=float,
        default=0.4,
        help="chance that a branch ends in a wing (default: 0.4)",
    )
    parser.add_argument("--wing-min", type=int, default=4, help="smallest wing side (default: 4)")
    parser.add_argument(
        "--wing-max", type=int, default=None, help="largest wing side (default: map / 5)"
    )


def _open_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--density", type=float, default=0.1, help="obstacle fraction (default: 0.1)"
    )
    parser.add_argument(
        "--max-size", type=int, default=3, help="largest obstacle side (default: 3)"
    )
    parser.add_argument(
        "--clearance",
        type=int,
        default=1,
        help="free cells kept around each obstacle; 2 keeps passages 2 wide (default: 1)",
    )


KINDS: dict[MapKind, _KindInfo] = {
    MapKind.BARS: _KindInfo(
        "one-cell-wide straight bars (the paper's 30x30 benchmark)",
        (30, 30),
        _bars_options,
        lambda a, h, w: mapgen.bars(h, w, a.count, a.min_len, a.max_len, a.seed),
    ),
    MapKind.ROOMS: _KindInfo(
        "a maze of rooms by recursive division, one door in every wall",
        (60, 60),
        _rooms_options,
        lambda a, h, w: mapgen.rooms(
            h,
            w,
            a.seed,
            room_min=a.room_min,
            room_max=a.room_max,
            door_width=a.door_width,
            corridor_width=a.corridor_width,
            corridor_prob=a.corridor_prob,
        ),
    ),
    MapKind.BUILDING: _KindInfo(
        "rooms off a grid of halls, like an office floor (ways near the Manhattan distance)",
        (60, 60),
        _building_options,
        lambda a, h, w: mapgen.building(
            h,
            w,
            a.seed,
            block=a.block,
            hall_width=a.hall_width,
            room_min=a.room_min,
            room_max=a.room_max,
            door_width=a.door_width,
        ),
    ),
    MapKind.CAVES: _KindInfo(
        "cellular-automaton caves",
        (60, 60),
        _caves_options,
        lambda a, h, w: mapgen.caves(h, w, a.seed, fill=a.fill, steps=a.steps),
    ),
    MapKind.BRANCHING: _KindInfo(
        "an indoor area: trunk corridor, branches and wings (like the paper's scenarios)",
        (60, 60),
        _branching_options,
        lambda a, h, w: mapgen.branching(
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
    ),
    MapKind.OPEN: _KindInfo(
        "an open field with scattered small obstacles",
        (60, 60),
        _open_options,
        lambda a, h, w: mapgen.open_field(
            h, w, a.seed, a.density, max_size=a.max_size, clearance=a.clearance
        ),
    ),
}

_DESCRIPTION = """\
Generate a random map and write it as ASCII ('#' obstacle, '.' free, 'C' the
charging pad; the first line is the northern edge). Every map has a one-cell
wall around it, the charging pad in the middle of the bottom wall (the only
entrance) and every free cell reachable from the pad. The same options and
seed always give the same map.
"""


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add ``map`` to the ``gcs`` subcommands."""
    parser = subparsers.add_parser(
        "map",
        help="generate a random map (bars, rooms, caves, branching, open)",
        description=_DESCRIPTION,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    kinds = parser.add_subparsers(dest="kind", metavar="KIND", required=True)
    for kind, info in KINDS.items():
        height, width = info.default_size
        sub = kinds.add_parser(
            kind.value,
            help=info.help,
            description=f"{info.help[0].upper()}{info.help[1:]}.\n\n{_DESCRIPTION}",
            formatter_class=argparse.RawDescriptionHelpFormatter,
        )
        sub.add_argument(
            "--size",
            type=_size,
            default=info.default_size,
            metavar="HxW",
            help=f"height x width in cells, border included (default: {height}x{width})",
        )
        sub.add_argument("--seed", type=int, default=0, help="random seed (default: 0)")
        sub.add_argument(
            "--out",
            type=Path,
            default=None,
            metavar="FILE",
            help="write the map to FILE (.txt or .map) instead of printing it",
        )
        info.add_options(sub)
        sub.set_defaults(func=run, map_kind=kind)


def run(args: argparse.Namespace) -> int:
    """Generate the map described by ``args``; return the exit status."""
    info = KINDS[args.map_kind]
    height, width = args.size
    try:
        grid = info.build(args, height, width)
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
