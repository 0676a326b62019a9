"""The target search written plainly: one breadth-first search, no shortcuts.

It answers exactly as the compiled search (``planner.speed.compiled_search``) does, and
is what that one is checked against (``PlannerSettings.search``,
``SearchKind.REFERENCE``). The rule is ``planner.target_search``'s.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Iterable, Iterator

from core.cells import CellState
from planner.belief import UNREACHED, MapBelief
from planner.target_search import HELD_BACK, Found, SearchMemory, SearchRequest, rival_first
from planner.team import Team

_FREE = int(CellState.FREE)


class ReferenceSearch:
    """The plain target search over one belief."""

    def __init__(self, belief: MapBelief) -> None:
        self.belief = belief
        stride = belief.stride
        self._steps = (-stride, stride, 1, -1)  # N, S, E, W

    def memory(self, team: Team, slot: int) -> SearchMemory:
        return SearchMemory()  # nothing is kept

    def run(self, request: SearchRequest, memory: SearchMemory | None = None) -> Found | None:
        belief = self.belief
        pool = belief.uncovered if request.pool is None else set(request.pool)
        candidates = set(pool) - set(request.excluded)
        best: dict[int, int] = {}  # rank -> the first cell of that rank reached
        parent: dict[int, int] = {}
        for cell, moves in self._reached(request.start, parent):
            if cell not in candidates:
                continue
            rank = self._rank(request, cell, moves)
            if rank is None or rank in best:
                continue
            best[rank] = cell
            if rank == 0:
                break
        if not best:
            return None
        rank = min(best)
        if rank == 2 and request.hold > 0:
            return HELD_BACK
        path = self._unwind(parent, request.start, best[rank])
        hint = request.hint
        way = () if hint is None else hint.way
        found = Found(rank, best[rank], path)
        if way and way[-1] == path[-1] and len(way) == len(path):
            found = Found(rank, best[rank], way)
        return HELD_BACK if rival_first(request, found, belief.cell(found.cell)) else found

    def _rank(self, request: SearchRequest, cell: int, moves: int) -> int | None:
        """The rank of a candidate ``moves`` away, or None if not affordable."""
        battery, cost, floor, best_cost, budget = request.energy
        home = self.belief.charger_dist[cell]
        if home >= UNREACHED or 2.0 * home * best_cost > budget:
            return None
        if battery - cost * (moves + home) < floor:
            return None
        rows, cols = request.others
        r, c = self.belief.cell(cell)
        others = zip(rows.tolist(), cols.tolist(), strict=True)
        near = min((abs(r - a) + abs(c - b) for a, b in others), default=None)
        if near is None or near >= moves:
            return 0
        if request.hold > 0 and near >= min(moves, request.hold + 1):
            return 1
        return 2

    def _reached(self, start: int, parent: dict[int, int]) -> Iterator[tuple[int, int]]:
        """The known free cells breadth-first from ``start`` (not itself), with their
        distance; ``parent`` filled in on the way."""
        state = self.belief.state
        parent[start] = start
        queue = deque([(start, 0)])
        while queue:
            u, moves = queue.popleft()
            for step in self._steps:
                v = u + step
                if state[v] == _FREE and v not in parent:
                    parent[v] = u
                    queue.append((v, moves + 1))
                    yield v, moves + 1

    @staticmethod
    def _unwind(parent: dict[int, int], start: int, goal: int) -> list[int]:
        path = [goal]
        while parent[path[-1]] != start:
            path.append(parent[path[-1]])
        return path[::-1]

    def path(
        self, start: int, goal: int, blocked: Iterable[int] = (), longest: int | None = None
    ) -> list[int] | None:
        if start == goal:
            return []
        state, shut = self.belief.state, set(blocked)
        parent = {start: start}
        queue = deque([start])
        while queue:
            u = queue.popleft()
            for step in self._steps:
                v = u + step
                if state[v] != _FREE or v in parent or v in shut:
                    continue
                parent[v] = u
                if v == goal:
                    path = self._unwind(parent, start, goal)
                    return path if longest is None or len(path) <= longest else None
                queue.append(v)
        return None
