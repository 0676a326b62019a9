"""``gcs map`` options: the map kinds and their generators' settings."""

from __future__ import annotations

import argparse
import re
from collections.abc import Callable
from dataclasses import dataclass
from enum import StrEnum
from pathlib import Path

from gcs.options import runs


class MapKind(StrEnum):
    BARS = "bars"
    ROOMS = "rooms"
    BUILDING = "building"
    CAVES = "caves"
    BRANCHING = "branching"
    OPEN = "open"


@dataclass(frozen=True)
class KindOptions:
    help: str
    default_size: tuple[int, int]
    add_options: Callable[[argparse.ArgumentParser], None]


def _size(text: str) -> tuple[int, int]:
    match = re.fullmatch(r"\s*(\d+)\s*[xX]\s*(\d+)\s*", text)
    if not match:
        raise argparse.ArgumentTypeError(f"expected HEIGHTxWIDTH such as 30x30, got {text!r}")
    return int(match[1]), int(match[2])


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


KINDS: dict[MapKind, KindOptions] = {
    MapKind.BARS: KindOptions(
        "one-cell-wide straight bars (the paper's 30x30 benchmark)", (30, 30), _bars_options
    ),
    MapKind.ROOMS: KindOptions(
        "a maze of rooms by recursive division, one door in every wall", (60, 60), _rooms_options
    ),
    MapKind.BUILDING: KindOptions(
        "rooms off a grid of halls, like an office floor (ways near the Manhattan distance)",
        (60, 60),
        _building_options,
    ),
    MapKind.CAVES: KindOptions("cellular-automaton caves", (60, 60), _caves_options),
    MapKind.BRANCHING: KindOptions(
        "an indoor area: trunk corridor, branches and wings (like the paper's scenarios)",
        (60, 60),
        _branching_options,
    ),
    MapKind.OPEN: KindOptions(
        "an open field with scattered small obstacles", (60, 60), _open_options
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
        help=f"generate a random map ({', '.join(k.value for k in MapKind)})",
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
        sub.set_defaults(map_kind=kind)
        runs(sub, "gcs.commands.map:run")
