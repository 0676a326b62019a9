"""The machine's pace on the day: a fixed workload, timed before a benchmark.

The machines we measure on are shared, and their speed drifts by a factor of three
from one day to another: open 1000x1000 with 50 agents took 45.7 s on one day and
151 s on another, with the same code and plan (this workload: 0.043 s and 0.142 s).
A benchmark prints this figure beside its own, so that a reader can tell a slower
machine from slower code: figures of two runs compare only at like paces (better
still, side by side in one run).

The workload is what most of a planner step is: pure Python over flat
``bytearray`` cells (a breadth-first search of a grid with walls), no compiled
code, no memory to speak of.
"""

from __future__ import annotations

import time
from array import array
from collections import deque

#: The grid's side, in cells: 0.04 to 0.15 s on the machines we use.
SIDE = 400
REPEATS = 3


def reference_seconds(repeats: int = REPEATS) -> float:
    """The fastest of ``repeats`` runs of the workload, in seconds."""
    best = float("inf")
    for _ in range(repeats):
        start = time.perf_counter()
        _workload()
        best = min(best, time.perf_counter() - start)
    return best


def _workload() -> int:
    """Breadth-first distances from a corner of a grid with every fourth row a wall
    but for one gap (a maze-like detour); returns the farthest distance."""
    stride = SIDE + 2
    free = bytearray(stride * stride)
    for r in range(1, SIDE + 1):
        wall = r % 4 == 0
        gap = 1 if r % 8 == 0 else SIDE
        for c in range(1, SIDE + 1):
            free[r * stride + c] = 0 if wall and c != gap else 1
    dist = array("i", [-1]) * len(free)
    start = stride + 1
    dist[start] = 0
    queue = deque([start])
    steps = (-stride, stride, 1, -1)
    farthest = 0
    while queue:
        u = queue.popleft()
        du = dist[u] + 1
        for s in steps:
            v = u + s
            if free[v] and dist[v] < 0:
                dist[v] = du
                farthest = du
                queue.append(v)
    return farthest
