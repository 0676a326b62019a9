"""The ground-truth map: which cells are obstacles, where the charging pad is."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from core.cells import Cell


@dataclass(frozen=True)
class GridMap:
    """A rectangular grid of cells; ``obstacle[r, c]`` is True for a wall.

    Row 0 is the northern edge. ``pads`` are the charging pad cells (the
    first one is the charging station and start cell of the fleet).
    """

    obstacle: np.ndarray
    pads: tuple[Cell, ...]

    @property
    def shape(self) -> tuple[int, int]:
        return (int(self.obstacle.shape[0]), int(self.obstacle.shape[1]))

    @property
    def charger(self) -> Cell:
        return self.pads[0]

    def inside(self, cell: Cell) -> bool:
        return 0 <= cell[0] < self.obstacle.shape[0] and 0 <= cell[1] < self.obstacle.shape[1]

    def is_free(self, cell: Cell) -> bool:
        return self.inside(cell) and not bool(self.obstacle[cell])

    @property
    def free_count(self) -> int:
        return int((~self.obstacle).sum())

    def reachable(self, start: Cell | None = None) -> np.ndarray:
        """Boolean mask of the free cells 4-connected to ``start`` (default: the charger)."""
        start = self.charger if start is None else start
        if not self.is_free(start):
            return np.zeros(self.obstacle.shape, dtype=bool)
        # Imported here: scipy takes longer to load than the rest of a command's help.
        from scipy import ndimage

        labels, _ = ndimage.label(~self.obstacle)  # 4-connected by default
        return labels == labels[start]
