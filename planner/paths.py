"""Shortest paths over the known free cells (the paper's Algorithm 3, done exactly).

On a 4-connected grid with unit move costs a breadth-first search is exact,
so one search from the agent ranks every candidate target by true path
length and stops at the first acceptable one. Paths are lists of flat
indices (see ``MapBelief``), the start excluded, the goal included.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Collection

from core.cells import CellState
from planner.belief import MapBelief

_FREE = int(CellState.FREE)
_OBSTACLE = int(CellState.OBSTACLE)


def nearest(
    belief: MapBelief,
    start: int,
    accept: Callable[[int, int], bool],
    blocked: Collection[int] = (),
) -> tuple[int, list[int]] | None:
    """Search outwards from ``start`` for the closest cell ``i`` with ``accept(i, distance)``.

    Returns that cell and its path, or None. ``blocked`` cells (other agents) are
    not entered. Ties are broken by the N, S, E, W expansion order, so runs
    are deterministic.
    """
    state, steps = belief.state, belief.steps
    parent = {start: start}
    frontier = [start]
    distance = 0
    while frontier:
        distance += 1
        nxt: list[int] = []
        for u in frontier:
            for s in steps:
                v = u + s
                if v in parent or state[v] != _FREE or v in blocked:
                    continue
                parent[v] = u
                if accept(v, distance):
                    return v, _unwind(parent, start, v)
                nxt.append(v)
        frontier = nxt
    return None


def shortest_path(
    belief: MapBelief, start: int, goal: int, blocked: Collection[int] = ()
) -> list[int] | None:
    """The shortest path from ``start`` to ``goal`` over known free cells, or None."""
    if start == goal:
        return []
    found = nearest(belief, start, lambda i, _d: i == goal, blocked)
    return None if found is None else found[1]


def path_to_charger(
    belief: MapBelief, start: int, blocked: Collection[int] = ()
) -> list[int] | None:
    """Descend the charger distance field: a shortest path home without a search.

    With ``blocked`` cells to avoid, falls back to a search.
    """
    if blocked:
        return shortest_path(belief, start, belief.charger_index, blocked)
    dist, steps = belief.charger_dist, belief.steps
    if dist[start] >= 1 << 30:
        return None
    path: list[int] = []
    u = start
    while dist[u] > 0:
        u = next(u + s for s in steps if dist[u + s] == dist[u] - 1)
        path.append(u)
    return path


def path_to_known(belief: MapBelief, start: int, blocked: Collection[int] = ()) -> list[int] | None:
    """The shortest way from ``start`` to a cell with a known way home, taking unknown
    cells as free (the free-space assumption), or None if walls close every way.

    For an agent that stands where the map it knows does not join the charger (a
    mission resumed from a log that ends a few moves before the vehicle stopped):
    it follows this path one step at a time, sensing as it goes, and replans when a
    wall turns up; since it came from the known map there is a way back. The first
    step is always a sensed neighbour."""
    state, steps, dist = belief.state, belief.steps, belief.charger_dist
    parent = {start: start}
    queue = deque([start])
    while queue:
        u = queue.popleft()
        for s in steps:
            v = u + s
            if v in parent or state[v] == _OBSTACLE or v in blocked:
                continue
            parent[v] = u
            if dist[v] < 1 << 30:
                return _unwind(parent, start, v)
            queue.append(v)
    return None


def bfs_distances(belief: MapBelief, start: int) -> dict[int, int]:
    """Distances from ``start`` to every reachable known free cell (for tests and checks)."""
    state, steps = belief.state, belief.steps
    dist = {start: 0}
    queue = deque([start])
    while queue:
        u = queue.popleft()
        for s in steps:
            v = u + s
            if state[v] == _FREE and v not in dist:
                dist[v] = dist[u] + 1
                queue.append(v)
    return dist


def _unwind(parent: dict[int, int], start: int, goal: int) -> list[int]:
    path = [goal]
    while parent[path[-1]] != start:
        path.append(parent[path[-1]])
    path.reverse()
    return path
