"""The target search of a blocked agent: what it is asked, what it answers, and
which implementation answers.

A blocked agent takes the nearest candidate cell (breadth-first over the known
free cells, moves tried N, S, E, W) that it can afford, ranked against the
other working agents (see ``Targets._nearest_affordable`` in ``planner.targets``):

- rank 0, uncontested: no other agent is nearer to it (Manhattan) than the
  agent's way there;
- rank 1, with a ``hold`` radius: some other agent is nearer, but none within
  ``hold`` cells of it (nor as near as the way there);
- rank 2, contested: left to the other agent. With ``hold`` > 0 the agent is
  held back (``HELD_BACK``) when nothing ranks better, and, with a
  ``rival_pace`` too, when the first of rank 1 is one that its nearest other
  agent, drawing nearer by ``rival_pace`` cells a move, would come within
  ``hold`` of before this agent walked there (``rival_first``).

The first rank-0 candidate the search reaches wins; else the first of rank 1,
else the first of rank 2. A candidate is affordable when its range from the
charger is within the budget for the cheapest agent
(``2 * home * best_cost <= budget``) and the way there and home leaves the
reserve: ``battery - cost * (moves + home) >= floor``. The path is the first
shortest way the search found, or the ``hint``'s way when it ends at the
target and is as short.

``planner.reference_search`` is that rule written plainly; ``planner.speed.compiled_search``
gives the same answers with compiled kernels and per-agent memories (the
shortcuts, each of which can be switched off: ``SearchShortcuts``).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from typing import NamedTuple, Protocol

import numpy as np

from planner.belief import MapBelief
from planner.settings import PlannerSettings, SearchKind
from planner.team import Team


class Energy(NamedTuple):
    """What the searching agent can afford: its battery, a move's cost, the reserve
    floor, the cheapest move of any agent and the range budget (percent)."""

    battery: float
    cost: float
    floor: float
    best_cost: float
    budget: float


class Hint(NamedTuple):
    """The target the agent is heading for, its way there, and the
    ``MapBelief.stamp`` when that was last known to be a shortest way, if ever."""

    goal: int
    way: Sequence[int]
    known_at: tuple[int, int] | None


class SearchRequest(NamedTuple):
    """One search: from ``start``, among ``pool`` (None: every uncovered cell),
    ranked against the ``others`` (rows, columns of the other working agents);
    ``excluded`` cells (claimed by other agents) are no candidates. ``hint``: only
    with ``pool`` None."""

    start: int
    energy: Energy
    others: tuple[np.ndarray, np.ndarray]
    hold: int
    excluded: Sequence[int] | np.ndarray = ()
    pool: Iterable[int] | None = None
    hint: Hint | None = None
    rival_pace: float = 0.0


class Found(NamedTuple):
    """The search's answer: the target's rank, the target and the path there (the
    start excluded, the target included)."""

    rank: int
    cell: int
    path: Sequence[int]


#: The answer when, with a ``hold`` radius, every candidate the agent can afford
#: is left to another agent: rank 2 and no target (finding a way would be wasted).
HELD_BACK = Found(2, -1, ())


def nearest_other(rows: np.ndarray, cols: np.ndarray, row: int, col: int) -> int:
    """The Manhattan distance from ``(row, col)`` to the nearest of the other agents'
    cells (``rows``, ``cols``; at least one)."""
    return int(np.min(np.abs(rows - row) + np.abs(cols - col)))


def rival_first(
    request: SearchRequest,
    found: Found,
    cell: tuple[int, int],
    nearest: Callable[[np.ndarray, np.ndarray, int, int], int] = nearest_other,
) -> bool:
    """Is ``found`` (at ``cell``, a row and column) of rank 1 and one that the nearest
    other agent, drawing nearer by ``request.rival_pace`` cells for each move of the
    way, would come within ``hold`` of first (Manhattan, as the ranks)? Then the
    search answers ``HELD_BACK``. ``nearest``: how the nearest is found (the compiled
    search passes its compiled kernel: numpy's five calls on fifty agents cost more
    than the sum)."""
    rows, cols = request.others
    if found.rank != 1 or request.rival_pace <= 0.0 or rows.size == 0:
        return False
    near = nearest(rows, cols, cell[0], cell[1])
    return near - request.hold < request.rival_pace * len(found.path)


class SearchMemory:
    """What a search keeps of one agent from one decision to the next: opaque to
    the caller, which keeps one for each agent (``TargetSearch.memory``)."""


class TargetSearch(Protocol):
    """A blocked agent's target search over one belief, and shortest paths on it."""

    def memory(self, team: Team, slot: int) -> SearchMemory:
        """A fresh memory for the agent in ``slot`` of ``team``."""
        ...

    def run(self, request: SearchRequest, memory: SearchMemory | None = None) -> Found | None:
        """The best target, ``HELD_BACK``, or None when no candidate is affordable.
        ``memory``: the searching agent's, used only when ``request.pool`` is None."""
        ...

    def path(
        self, start: int, goal: int, blocked: Iterable[int] = (), longest: int | None = None
    ) -> list[int] | None:
        """The first shortest path from ``start`` to ``goal`` over known free cells
        (N, S, E, W order), not entering ``blocked``: the start excluded, the goal
        included. None if there is none, or none of at most ``longest`` moves."""
        ...


def target_search(belief: MapBelief, settings: PlannerSettings) -> TargetSearch:
    """The target search ``settings`` choose (``search``, ``search_shortcuts``) over
    ``belief``. Each is imported when first chosen: the reference needs no numba."""
    if settings.search == SearchKind.REFERENCE:
        from planner.reference_search import ReferenceSearch

        return ReferenceSearch(belief)
    from planner.speed.compiled_search import CompiledSearch

    return CompiledSearch(belief, settings.search_shortcuts)
