"""Starting from what is already known: a map given in advance, or an earlier run's
log (a ground station restarted mid-mission)."""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from core.cells import Cell, CellState
from planner import btp
from planner.belief import MapBelief, with_unknown_side


def load_prior(belief: MapBelief, prior: np.ndarray) -> None:
    """Enter a known map (``CellState`` values, UNKNOWN where not known) in the belief."""
    if prior.shape != belief.shape:
        raise ValueError(f"prior map shape {prior.shape} != {belief.shape}")
    for r, c in zip(*np.nonzero(prior == CellState.OBSTACLE), strict=True):
        belief.state[belief.index((int(r), int(c)))] = int(CellState.OBSTACLE)
    cr, cc = belief.charger
    free = sorted(
        ((int(r), int(c)) for r, c in zip(*np.nonzero(prior == CellState.FREE), strict=True)),
        key=lambda cell: abs(cell[0] - cr) + abs(cell[1] - cc),
    )
    for cell in free:  # nearest first keeps the incremental distance update cheap
        belief.mark_free(belief.index(cell))


def restore(
    belief: MapBelief,
    stacks: btp.BtpStacks,
    known: np.ndarray,
    covered: np.ndarray,
    btps: Iterable[Cell],
) -> None:
    """Enter an earlier run's map (``CellState`` values), the cells it covered, and its
    BTPs, which go to the global pool since their agents' plans are gone."""
    if known.shape != belief.shape or covered.shape != belief.shape:
        raise ValueError(f"restored map shape {known.shape} != {belief.shape}")
    known = np.where(covered, int(CellState.FREE), known)
    load_prior(belief, known)
    # A covered cell was sensed from: an unknown side means that sensing did not
    # reach the log. Such cells are left to cover again, so that someone senses there.
    for r, c in zip(*np.nonzero(covered & ~with_unknown_side(known)), strict=True):
        belief.cover((int(r), int(c)), btp.BtpStacks.POOL)
    for cell in btps:
        if belief.inside(cell) and belief.index(cell) in belief.uncovered:
            stacks.push(btp.BtpStacks.POOL, belief.index(cell))
