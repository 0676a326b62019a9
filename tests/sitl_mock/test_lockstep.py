"""The lockstep world's sensing is the ground truth, whatever it keeps between calls."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from core.cells import NEIGHBOURS, CellState
from sitl_mock.gridmap import GridMap
from sitl_mock.lockstep import Body, LockstepWorld


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), rows=st.integers(1, 12), cols=st.integers(1, 12))
def test_sensing_reads_the_true_neighbours(seed: int, rows: int, cols: int) -> None:
    """Every cell, in any order (readings are kept by the pattern around a cell):
    a neighbour is free exactly when it is on the map and not a wall; a reading
    handed out is shared by the cells around which the walls lie alike, so it is
    read-only."""
    rng = np.random.default_rng(seed)
    walls = rng.random((rows, cols)) < rng.uniform(0.0, 0.6)
    walls[0, 0] = False
    world = LockstepWorld(GridMap(walls, ((0, 0),)), [Body(1, 1.0)])
    cells = [(r, c) for r in range(rows) for c in range(cols)]
    for k in rng.permutation(len(cells)).tolist() * 2:
        r, c = cells[k]
        readings = world.sense((r, c))
        for d in NEIGHBOURS:
            nr, nc = r + d.value[0], c + d.value[1]
            free = 0 <= nr < rows and 0 <= nc < cols and not walls[nr, nc]
            assert readings[d] == (CellState.FREE if free else CellState.OBSTACLE)
        with pytest.raises(TypeError):
            readings[NEIGHBOURS[0]] = CellState.UNKNOWN  # type: ignore[index]
