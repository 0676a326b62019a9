"""A probabilistic roadmap over the known map, as in the paper's path planner.

Kept as an option to reproduce the paper's behaviour (its paths are not
always shortest); the exact grid search is the default. Nodes are a fixed
pseudo-random share of the known free cells (chosen by a hash of the cell
and the seed, so the roadmap does not depend on discovery order). Two nodes
within ``prm_radius_cells`` are joined when the 4-connected line between them
crosses known free cells only. The roadmap is rebuilt lazily, when it is
queried after the map has grown (the learning phase); a query joins the start
and the goals to it and runs one Dijkstra search. Edges expand into grid
moves, so a PRM path is a sequence of adjacent cells like any other.
"""

from __future__ import annotations

import hashlib
import itertools
import math
from collections.abc import Callable, Iterable

import networkx as nx

from core.cells import CellState
from planner.belief import MapBelief
from planner.paths import nearest, shortest_path
from planner.settings import PlannerSettings

_FREE = int(CellState.FREE)


def line_cells(belief: MapBelief, a: int, b: int) -> list[int] | None:
    """The 4-connected cells from ``a`` to ``b`` (excluding ``a``), or None if one is not free."""
    (r0, c0), (r1, c1) = belief.cell(a), belief.cell(b)
    dr, dc = r1 - r0, c1 - c0
    sr, sc = (1 if dr > 0 else -1), (1 if dc > 0 else -1)
    nr, nc = abs(dr), abs(dc)
    out: list[int] = []
    r, c, ir, ic = r0, c0, 0, 0
    while ir < nr or ic < nc:
        # Step along the axis whose next boundary crossing comes first.
        if (2 * ir + 1) * nc < (2 * ic + 1) * nr or ic == nc:
            r += sr
            ir += 1
        else:
            c += sc
            ic += 1
        i = belief.index((r, c))
        if belief.state[i] != _FREE:
            return None
        out.append(i)
    return out


class Roadmap:
    def __init__(self, settings: PlannerSettings) -> None:
        self.settings = settings
        self.graph: nx.Graph = nx.Graph()
        self._built_for = -1
        self._nodes: set[int] = set()
        self.fallbacks = 0

    def _is_node(self, belief: MapBelief, index: int) -> bool:
        digest = hashlib.blake2b(f"{self.settings.seed}:{index}".encode(), digest_size=4).digest()
        return int.from_bytes(digest) < self.settings.prm_node_fraction * 2**32

    def grow(self, belief: MapBelief, newly_free: Iterable[int]) -> None:
        for i in newly_free:
            if self._is_node(belief, i):
                self._nodes.add(i)

    def _rebuild(self, belief: MapBelief) -> None:
        if self._built_for == belief.free_count:
            return
        self._built_for = belief.free_count
        graph: nx.Graph = nx.Graph()
        graph.add_nodes_from(self._nodes)
        nodes = sorted(self._nodes)
        for i in nodes:
            for j, cells in self._neighbours(belief, i, nodes):
                if j > i:
                    graph.add_edge(i, j, weight=len(cells))
        self.graph = graph

    def _neighbours(
        self, belief: MapBelief, i: int, nodes: Iterable[int]
    ) -> Iterable[tuple[int, list[int]]]:
        radius = self.settings.prm_radius_cells
        (ri, ci) = belief.cell(i)
        for j in nodes:
            if j == i:
                continue
            rj, cj = belief.cell(j)
            if math.hypot(rj - ri, cj - ci) > radius:
                continue
            cells = line_cells(belief, i, j)
            if cells is not None:
                yield j, cells

    def _query_graph(self, belief: MapBelief, extra: Iterable[int]) -> nx.Graph:
        self._rebuild(belief)
        graph = self.graph.copy()
        nodes = sorted(self._nodes)
        for x in extra:
            if x in graph:
                continue
            for j, cells in self._neighbours(belief, x, nodes):
                graph.add_edge(x, j, weight=len(cells))
            graph.add_node(x)
        return graph

    def _expand(self, belief: MapBelief, route: list[int]) -> list[int]:
        path: list[int] = []
        for a, b in itertools.pairwise(route):
            cells = line_cells(belief, a, b)
            if cells is None:  # the edge was checked from the other end
                back = line_cells(belief, b, a)
                assert back is not None
                cells = [*back[-2::-1], b]
            path.extend(cells)
        return path

    def nearest(
        self,
        belief: MapBelief,
        start: int,
        candidates: set[int],
        accept: Callable[[int, int], bool],
    ) -> tuple[int, list[int]] | None:
        """The candidate with the shortest roadmap path that ``accept(goal, moves)`` takes.

        When it takes none, the exact search decides: some candidates may be off
        the roadmap, or its detours may make every one on it too costly where a
        shortest way is not (refusing then would leave a fully charged agent at
        the charger for ever, with cells in range left uncovered)."""
        graph = self._query_graph(belief, [start, *candidates])
        lengths, routes = nx.single_source_dijkstra(graph, start, weight="weight")
        ranked = sorted((int(lengths[g]), g) for g in candidates if g in lengths)
        for moves, goal in ranked:
            if accept(goal, moves):
                return goal, self._expand(belief, routes[goal])
        self.fallbacks += 1
        return nearest(belief, start, lambda i, d: i in candidates and accept(i, d))

    def path(self, belief: MapBelief, start: int, goal: int) -> list[int] | None:
        if start == goal:
            return []
        graph = self._query_graph(belief, [start, goal])
        try:
            route = nx.dijkstra_path(graph, start, goal, weight="weight")
        except nx.NetworkXNoPath:
            self.fallbacks += 1
            return shortest_path(belief, start, goal)
        return self._expand(belief, route)
