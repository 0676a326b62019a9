"""The log's map snapshots: kept as text between snapshots, re-encoded where cells changed."""

from __future__ import annotations

import base64
import json

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from gcs.log.scenes import GridEncoder
from gcs.log.topics import GRID_RGBA, codes_from_grid, grid_codes


@st.composite
def snapshots(draw: st.DrawFn) -> tuple[tuple[int, int], list[tuple[np.ndarray, np.ndarray]]]:
    """A map's shape (any number of cells, whole groups of three or not) and the
    belief and coverage of a few snapshots, each changing some cells of the last."""
    rows, cols = draw(st.integers(1, 9)), draw(st.integers(1, 9))
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    belief = rng.integers(0, 3, (rows, cols)).astype(np.uint8)
    covered = np.zeros((rows, cols), dtype=bool)
    grids = []
    for _ in range(draw(st.integers(1, 5))):
        changed = rng.integers(0, rows * cols, draw(st.integers(0, 4)))
        belief.flat[changed] = rng.integers(0, 3, changed.size)
        covered.flat[rng.integers(0, rows * cols, draw(st.integers(0, 3)))] = True
        grids.append((belief.copy(), covered.copy()))
    return (rows, cols), grids


@settings(max_examples=150, deadline=None)
@given(snapshots())
def test_each_snapshot_is_the_map_as_it_is_then(
    case: tuple[tuple[int, int], list[tuple[np.ndarray, np.ndarray]]],
) -> None:
    """Every message of one encoder decodes to the codes and colours of its own
    snapshot, and equals what a new encoder writes for that snapshot alone."""
    _, grids = case
    encoder = GridEncoder(2.0)
    for belief, covered in grids:
        data = encoder.message(7, belief, covered)
        assert data == GridEncoder(2.0).message(7, belief, covered)
        message = json.loads(data)
        codes = grid_codes(belief, covered)
        np.testing.assert_array_equal(codes_from_grid(message), codes)
        cells = np.frombuffer(base64.b64decode(message["data"]), dtype=np.uint8)
        colours = cells.reshape(-1, message["cell_stride"])[:, 1:]
        np.testing.assert_array_equal(colours, GRID_RGBA[np.flipud(codes).ravel()])
