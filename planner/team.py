"""Where every agent is and which are working, as arrays the searches read."""

from __future__ import annotations

import numpy as np


class Team:
    """Where every agent is and which are working (sweeping or on the way to sweep),
    as arrays the compiled searches read without building lists each decision.
    Agents are numbered by slot."""

    def __init__(self, size: int, at: tuple[int, int]) -> None:
        self.rows = np.full(size, at[0], dtype=np.int64)
        self.cols = np.full(size, at[1], dtype=np.int64)
        self.working = np.ones(size, dtype=np.bool_)
        #: Sweeping (``EXPLORING``): the agents whose pockets are theirs (``planner.pockets``).
        self.sweeping = np.ones(size, dtype=np.bool_)

    def others_mask(self, slot: int) -> np.ndarray:
        """The working agents other than ``slot``."""
        mask = self.working.copy()
        mask[slot] = False
        return mask

    def others(self, slot: int) -> tuple[np.ndarray, np.ndarray]:
        """Rows and columns of the working agents other than ``slot``."""
        mask = self.others_mask(slot)
        return self.rows[mask], self.cols[mask]
