"""Pocket claims (``PlannerSettings.pocket_claims``, ``planner.pockets``): an enclosed
part of the work beside an agent that sweeps is left whole to it."""

from __future__ import annotations

import numpy as np
import pytest

from core.cells import CellState
from planner.agent import AgentMode
from planner.belief import MapBelief
from planner.pocket_fill import fill_pocket
from planner.settings import AgentSpec, PlannerSettings
from sitl_mock import mapgen
from tests.planner.flights import fly
from tests.planner.test_coordinator import _cover_all_but, _known, _readings, _walls

#: A corridor one cell wide and 40 long, the charger at its western end.
CORRIDOR = ["#" * 42, "#C" + "." * 39 + "#", "#" * 42]
#: The corridor's east end, left uncovered: 11 cells, walls and covered cells all round.
EAST_END = {(1, col) for col in range(30, 41)}


def _sweeping_beside_the_east_end(limit: int):
    """Agent 2 sweeping at (1, 29), beside the uncovered east end; agent 1 on the
    charger with nothing else left to sweep."""
    settings = PlannerSettings(pocket_claims=limit, rival_pace=0.0)
    c = _known(CORRIDOR, [AgentSpec(1, 0.0), AgentSpec(2, 0.0)], settings)
    _cover_all_but(c, CORRIDOR, EAST_END)
    walls, _ = _walls(CORRIDOR)
    c.observe(2, (1, 29), _readings(walls, (1, 29)), 100.0)
    assert c.mode(2) == AgentMode.EXPLORE
    return c


@pytest.mark.parametrize(("limit", "waits"), [(0, False), (8, False), (11, True), (128, True)])
def test_an_agent_leaves_the_pocket_another_sweeps_beside(limit: int, waits: bool) -> None:
    """Every cell left is in the east end, which agent 2 is about to sweep: without
    pocket claims (or with a limit below its 11 cells) agent 1 sets out for its
    cells beyond ``hold_radius`` of agent 2 (``rival_pace`` 0: it would not wait
    either way), 34 moves away; with them it waits."""
    c = _sweeping_beside_the_east_end(limit)
    action = c.decide(1)
    assert (action.to is None) == waits
    assert (c.mode(1) == AgentMode.TRANSIT) == (not waits)


def test_the_owner_sweeps_its_own_pocket() -> None:
    c = _sweeping_beside_the_east_end(128)
    assert c.decide(2).to == (1, 30)


def _belief(rows: list[str]) -> MapBelief:
    """``#`` walls, ``.`` uncovered free cells, ``o`` covered ones, ``?`` unknown."""
    belief = MapBelief((len(rows), len(rows[0])), (0, 0))
    for r, row in enumerate(rows):
        for c, ch in enumerate(row):
            i = belief.index((r, c))
            if ch == "#":
                belief.state[i] = int(CellState.OBSTACLE)
            elif ch in ".o":
                belief.mark_free(i)
                if ch == "o":
                    belief.cover((r, c), 1)
    return belief


def _pocket(belief: MapBelief, cell: tuple[int, int], limit: int) -> set[tuple[int, int]]:
    """The cells ``fill_pocket`` lists from ``cell``, empty when over ``limit``."""
    size = len(belief.state)
    grid = (
        np.frombuffer(belief.state, dtype=np.uint8),
        np.frombuffer(belief.covered, dtype=np.uint8),
        belief.stride,
    )
    seen, queue = np.zeros(size, np.int32), np.zeros(size, np.int64)
    count = fill_pocket(belief.index(cell), limit, grid, seen, 1, queue)
    return {belief.cell(int(i)) for i in queue[: max(count, 0)]}


ROOMS = [
    "ooooooooo",
    "o..o#...o",
    "o..o#.?.o",
    "ooooooooo",
]


def test_a_pocket_is_the_part_not_known_covered_joined_to_a_cell_within_the_limit() -> None:
    """West: 4 uncovered cells. East: 5 free cells and an unknown one (it may be
    free: it counts)."""
    belief = _belief(ROOMS)
    assert belief.state[belief.index((2, 6))] == int(CellState.UNKNOWN)
    west = {(1, 1), (1, 2), (2, 1), (2, 2)}
    east = {(1, 5), (1, 6), (1, 7), (2, 5), (2, 6), (2, 7)}
    assert _pocket(belief, (1, 1), 4) == west
    assert _pocket(belief, (2, 2), 3) == set()
    assert _pocket(belief, (2, 7), 6) == east
    assert _pocket(belief, (1, 5), 5) == set()


def test_pocket_claims_must_not_be_negative() -> None:
    with pytest.raises(ValueError, match="pocket_claims"):
        PlannerSettings(pocket_claims=-1)


def test_two_agents_crossing_in_a_narrow_passage_do_not_pace_for_ever() -> None:
    """Found with pocket claims (one map of 2877 bar-map runs): two agents in transit
    met in a passage one cell wide, each bound past the other, and each walked
    round the other into the cell the other had just left, back and forth until
    the iteration limit. An agent that has turned back twice in a row now waits
    instead of walking round (``Traffic._blocked``)."""
    grid = mapgen.bars(30, 30, 13, 4, 9, seed=96)
    settings = PlannerSettings(pocket_claims=128, launch_interval=6)
    flight = fly(grid, 4, settings, energy_per_m_pct=0.0, max_iterations=2000)
    assert flight.complete and flight.finished
