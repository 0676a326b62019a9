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


@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    slots=st.none() | st.integers(1, 3),
    rate=st.none() | st.floats(1.0, 40.0),
)
def test_the_batteries_that_change_but_by_a_move_are_those_told_charged(
    seed: int, slots: int | None, rate: float | None
) -> None:
    """``end_iteration`` names every agent whose battery it changed (the simulator tells
    only those to the planner), whatever the queue for the pad and its slots."""
    rng = np.random.default_rng(seed)
    free = np.zeros((3, 8), dtype=bool)
    bodies = [Body(i, 2.0) for i in range(1, 6)]
    world = LockstepWorld(
        GridMap(free, ((0, 3),)), bodies, charge_pct_per_step=rate, charging_slots=slots
    )
    for _ in range(40):
        for agent in world.position:
            if agent in world.dead:
                continue
            here = world.position[agent]
            moves = [
                (here[0] + dr, here[1] + dc)
                for dr, dc in ((0, 1), (0, -1), (1, 0), (-1, 0))
                if 0 <= here[0] + dr < 3
                and 0 <= here[1] + dc < 8
                and (here[0] + dr, here[1] + dc) not in world.position.values()
            ]
            if here == (0, 3) and rng.random() < 0.6:
                world.request_charge(agent)
            elif moves and rng.random() < 0.7:
                world.move(agent, moves[rng.integers(len(moves))])
        moved = {a: world.battery[a] for a in world.battery}
        charged = world.end_iteration()
        changed = {a for a in world.battery if world.battery[a] != moved[a]}
        assert changed <= set(charged)
        assert all(world.position[a] == (0, 3) for a in charged)
