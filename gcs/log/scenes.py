"""The log's scene messages, built for Foxglove's well-known schemas: stamps, scene
entities (the vehicles' tracks, the BTPs), and the map as a ``foxglove.Grid``."""

from __future__ import annotations

import base64
import math
from collections.abc import Sequence
from typing import Any

import numpy as np
import orjson

from core.cells import Cell
from core.geo import GeoFrame
from gcs.log.topics import GRID_RGBA, MAP_FRAME, grid_codes


def stamp(ns: int) -> dict[str, int]:
    return {"sec": ns // 1_000_000_000, "nsec": ns % 1_000_000_000}


IDENTITY = {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}


def move_heading(a: Cell, b: Cell) -> float | None:
    """Compass heading of a move between neighbouring cells (rows grow southwards)."""
    if a == b:
        return None
    return math.degrees(math.atan2(b[1] - a[1], a[0] - b[0])) % 360.0


def _entity(ns: int, entity_id: str, **primitives: Any) -> dict[str, Any]:
    entity: dict[str, Any] = {
        "timestamp": stamp(ns),
        "frame_id": MAP_FRAME,
        "id": entity_id,
        "lifetime": {"sec": 0, "nsec": 0},
        "frame_locked": False,
        "metadata": primitives.pop("metadata", []),
    }
    for kind in ("arrows", "cubes", "spheres", "cylinders", "lines", "triangles", "texts"):
        entity[kind] = primitives.pop(kind, [])
    entity["models"] = []
    return entity


def track_entity(
    ns: int, sysid: int, colour: tuple[float, float, float], track: Sequence[str], width: float
) -> str:
    """A vehicle's whole track as a scene entity's JSON text; ``track``: its points as
    JSON ``foxglove.Point3`` text, spliced in rather than encoded again."""
    line = {
        "type": 0,  # LINE_STRIP
        "pose": {"position": {"x": 0.0, "y": 0.0, "z": 0.05}, "orientation": IDENTITY},
        "thickness": width,
        "scale_invariant": False,
        "points": [],
        "color": {"r": colour[0], "g": colour[1], "b": colour[2], "a": 0.9},
        "colors": [],
        "indices": [],
    }
    metadata = [{"key": "sysid", "value": str(sysid)}]
    text = orjson.dumps(_entity(ns, f"track/{sysid}", lines=[line], metadata=metadata)).decode()
    return text.replace('"points":[]', f'"points":[{",".join(track)}]', 1)


def btps_entity(
    ns: int, cells: Sequence[Cell], geo: GeoFrame, cell_size_m: float
) -> dict[str, Any]:
    """The BTPs as red spheres, their cells also in the metadata."""
    size = 0.5 * cell_size_m
    spheres = []
    for cell in cells:
        north, east = geo.cell_centre_local(cell)
        spheres.append(
            {
                "pose": {
                    "position": {"x": east, "y": north, "z": 0.1},
                    "orientation": IDENTITY,
                },
                "size": {"x": size, "y": size, "z": size},
                "color": {"r": 0.9, "g": 0.1, "b": 0.1, "a": 0.9},
            }
        )
    cells_json = orjson.dumps([list(c) for c in cells]).decode()
    return _entity(ns, "btps", spheres=spheres, metadata=[{"key": "cells", "value": cells_json}])


#: Each code's five bytes in the grid: the code, then its colour.
_CODE_AND_RGBA = np.concatenate(
    [np.arange(len(GRID_RGBA), dtype=np.uint8)[:, None], GRID_RGBA], axis=1
)
_STRIDE = _CODE_AND_RGBA.shape[1]
#: Cells in a group whose bytes are a whole number of base64 quanta (3 bytes, 4 letters).
_GROUP = 3
_GROUP_LETTERS = _GROUP * _STRIDE * 4 // 3


class GridEncoder:
    """The map as a ``foxglove.Grid`` in JSON: each cell's code and its colour, base64.

    A snapshot of a million-cell map is 6.7 MB of text, and most of it is as it was in
    the last one: the text is kept, and only the groups of three cells (15 bytes, 20
    letters of base64) holding a changed cell are encoded again. The data is spliced
    into the message, not run through a JSON encoder, which would scan it."""

    def __init__(self, cell_size_m: float) -> None:
        self.cell_size_m = cell_size_m
        #: The last snapshot's codes, south row first, flat; and its text, a group a row.
        self._codes: np.ndarray | None = None
        self._letters = np.zeros((0, _GROUP_LETTERS), dtype=np.uint8)

    def message(self, ns: int, belief: np.ndarray, covered: np.ndarray) -> bytes:
        codes = grid_codes(belief, covered)
        rows, cols = codes.shape
        flat = np.flipud(codes).ravel()  # Foxglove's first row is the southern one
        whole = flat.size // _GROUP * _GROUP
        if self._codes is None or self._codes.shape != flat.shape:
            self._letters = _base64_rows(flat[:whole])
        else:
            groups = np.unique(np.flatnonzero(flat[:whole] != self._codes[:whole]) // _GROUP)
            if groups.size:
                cells = (groups[:, None] * _GROUP + np.arange(_GROUP)).ravel()
                self._letters[groups] = _base64_rows(flat[cells])
        self._codes = flat
        rest = base64.b64encode(_CODE_AND_RGBA[flat[whole:]].tobytes())
        names = ("state", "red", "green", "blue", "alpha")
        message = {
            "timestamp": stamp(ns),
            "frame_id": MAP_FRAME,
            "pose": {
                "position": {"x": 0.0, "y": -rows * self.cell_size_m, "z": 0.0},
                "orientation": IDENTITY,
            },
            "column_count": cols,
            "cell_size": {"x": self.cell_size_m, "y": self.cell_size_m},
            "row_stride": cols * _STRIDE,
            "cell_stride": _STRIDE,
            "fields": [{"name": n, "offset": k, "type": 1} for k, n in enumerate(names)],
            "data": "",
        }
        head, tail = orjson.dumps(message).split(b'"data":""')
        return b"".join((head, b'"data":"', self._letters.data, rest, b'"', tail))


def _base64_rows(codes: np.ndarray) -> np.ndarray:
    """The base64 letters of whole groups of cells' bytes, a group a row."""
    letters = base64.b64encode(_CODE_AND_RGBA[codes].tobytes())
    return np.frombuffer(letters, dtype=np.uint8).reshape(-1, _GROUP_LETTERS).copy()
