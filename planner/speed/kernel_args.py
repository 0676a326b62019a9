"""The argument bundles the numba kernels take, each a plain tuple.

A kernel reads the known map, the other agents and its scratch arrays in
several places; a bundle keeps each such group one argument. They are plain
tuples, not NamedTuples: numba types a plain tuple of arrays from its C fast
path on each call from Python, a NamedTuple through Python (several times
slower per call, on calls made thousands of times a second). Each kernel
unpacks the bundles it takes in its first lines, by these orders.
"""

from __future__ import annotations

import numpy as np

#: The known map: the cells' ``CellState`` (flat, with a border), the row stride,
#: and the distances from the landmarks (``Landmarks.lands``).
Grid = tuple[np.ndarray, int, np.ndarray]
#: The other working agents a candidate is ranked against: their rows and columns,
#: and the hold radius (``planner.target_search``).
Rivals = tuple[np.ndarray, np.ndarray, int]
#: The agent's battery, a move's cost, the reserve floor, the cheapest move of any
#: agent and the range budget (``planner.target_search.Energy``'s order).
EnergyTerms = tuple[float, float, float, float, float]
#: A breadth-first search's scratch: ``seen`` marks, ``parent`` and ``queue``.
Scratch = tuple[np.ndarray, np.ndarray, np.ndarray]
#: A bounded walk: its start, the bound of its ways, the worst rank it takes, and
#: the first mark of ``seen`` it may use.
Walk = tuple[int, int, int, int]
#: The shortcuts' scratch in a search: a list of candidates, a second ``Scratch``
#: (``seen``, ``queue``, ``parent``: this order) and the first mark it may use.
Aside = tuple[np.ndarray, tuple[np.ndarray, np.ndarray, np.ndarray], int]
#: A target search's candidates: their mask, the cells the horizon pass reads (perhaps
#: a shortlist) and every candidate.
Pool = tuple[np.ndarray, np.ndarray, np.ndarray]
#: A target search's part for its shortcuts: the horizon pass's ``margin`` and
#: ``kept`` (``HorizonMemo``), a list and a second ``Scratch`` (``Aside``'s).
SearchAside = tuple[int, np.ndarray, np.ndarray, tuple[np.ndarray, np.ndarray, np.ndarray]]
