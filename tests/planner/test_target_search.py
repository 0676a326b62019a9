"""The target search behind its interface (``planner.target_search``): the plans are
the same cell for cell with the plain reference search, and with each of the
compiled search's shortcuts switched off (``PlannerSettings.search_shortcuts``),
while the shortcuts are taken."""

from __future__ import annotations

from typing import Any

import pytest

from planner.settings import PlannerSettings, SearchKind, SearchShortcuts
from planner.speed.compiled_search import CompiledSearch, SearchCounts
from sitl_mock import mapgen
from tests.planner.flights import Flight, fly


def _flown(
    grid, agents: int, batched: bool = False, balk_every: int = 0, **settings: Any
) -> Flight:
    """Every agent's track over ``grid``, planned with ``settings`` (``fly``'s options)."""
    energy = 80.0 / (4 * (grid.shape[0] + grid.shape[1]))
    plan = PlannerSettings(**settings)
    flight = fly(
        grid, agents, plan, energy_per_m_pct=energy, batched=batched, balk_every=balk_every
    )
    assert flight.complete and flight.finished
    return flight


def _tracks_digest(grid, agents: int, **settings: Any) -> str:
    """A digest of every agent's track over ``grid``, planned with ``settings``."""
    return _flown(grid, agents, **settings).digest()


@pytest.mark.parametrize("kind", ["open_field", "rooms", "building", "caves", "branching"])
@pytest.mark.parametrize("agents", [1, 3, 7, 12])
def test_the_reference_search_plans_as_the_compiled_one(kind: str, agents: int) -> None:
    """Small generated maps of each kind: the same move, cell for cell."""
    grid = getattr(mapgen, kind)(24, 24, agents)
    compiled = _tracks_digest(grid, agents)
    assert _tracks_digest(grid, agents, search=SearchKind.REFERENCE) == compiled


def _counted(grid, agents: int, **settings: Any) -> tuple[str, SearchCounts]:
    """The plan's digest, and how the compiled search of the plan answered."""
    flight = _flown(grid, agents, **settings)
    assert isinstance(flight.search, CompiledSearch)
    return flight.digest(), flight.search.counts


def _without(**off: bool) -> dict[str, Any]:
    return {"search_shortcuts": SearchShortcuts(**off)}


OPEN60_12 = pytest.param(mapgen.open_field(60, 60, 2), 12, id="open60-12")
ROOMS60_9 = pytest.param(mapgen.rooms(60, 60, 5), 9, id="rooms60-9")


@pytest.mark.parametrize(("grid", "agents"), [OPEN60_12, ROOMS60_9])
def test_plans_are_the_same_without_the_shortlist(grid, agents: int) -> None:
    assert _tracks_digest(grid, agents, **_without(shortlist=False)) == _tracks_digest(grid, agents)


@pytest.mark.parametrize(
    ("grid", "agents"),
    [OPEN60_12, ROOMS60_9, pytest.param(mapgen.open_field(80, 80, 3), 1, id="open80-1")],
)
def test_plans_are_the_same_without_confirmations(grid, agents: int) -> None:
    """Skipping the searches that would return the target on the way changes no
    move, and it does skip searches (alone: a settled target spares them too)."""
    confirmed, taken = _counted(grid, agents, **_without(settled=False))
    plain, searched = _counted(grid, agents, **_without(settled=False, confirm=False))
    assert plain == confirmed
    assert taken.confirmed > 0 and searched.confirmed == 0
    assert taken.searches < searched.searches


@pytest.mark.parametrize(("grid", "agents"), [OPEN60_12, ROOMS60_9])
def test_plans_are_the_same_without_the_way_memo(grid, agents: int) -> None:
    """The transit's check passing over the cells kept along its way changes no move,
    and it does pass over them."""
    with_it, taken = _counted(grid, agents)
    assert taken.way_listed > 0
    assert _tracks_digest(grid, agents, **_without(way_memo=False)) == with_it


@pytest.mark.parametrize(
    ("grid", "agents"),
    [
        pytest.param(mapgen.rooms(60, 60, 5), 1, id="rooms60-1"),
        pytest.param(mapgen.open_field(80, 80, 3), 1, id="open80-1"),
        pytest.param(mapgen.rooms(60, 60, 5), 3, id="rooms60-3"),
    ],
)
def test_plans_are_the_same_without_the_settled_target(grid, agents: int) -> None:
    """Carrying a target along its way without a check changes no move, and it
    does spare checks."""
    with_it, taken = _counted(grid, agents)
    assert taken.carried > 0
    assert _tracks_digest(grid, agents, **_without(settled=False)) == with_it


@pytest.mark.parametrize(
    ("grid", "agents"),
    [pytest.param(mapgen.rooms(80, 80, 2), 20, id="rooms80-20")],
)
def test_plans_are_the_same_without_the_still_field(grid, agents: int) -> None:
    """Telling a held agent's answer by its distances from where it stands changes
    no move, and it does spare searches."""
    with_it, taken = _counted(grid, agents)
    plain, searched = _counted(grid, agents, **_without(still_field=False))
    assert plain == with_it
    assert taken.held_still > 0 and searched.held_still == 0
    assert taken.searches < searched.searches


@pytest.mark.parametrize(
    ("grid", "agents"),
    [ROOMS60_9, pytest.param(mapgen.rooms(80, 80, 2), 20, id="rooms80-20")],
)
@pytest.mark.parametrize("balk_every", [0, 5])
def test_plans_are_the_same_without_the_held_wait(grid, agents: int, balk_every: int) -> None:
    """Telling a held agent's wait without the rest of its decision changes no move,
    and it is told so; also where some moves fail, as a live vehicle's can (the
    agent seen where it stood, its reservation released)."""
    with_it = _flown(grid, agents, balk_every=balk_every)
    assert with_it.quick_held_waits > 0
    plain = _flown(grid, agents, balk_every=balk_every, **_without(held_wait=False))
    assert plain.quick_held_waits == 0
    assert plain.digest() == with_it.digest()


@pytest.mark.parametrize(("grid", "agents"), [OPEN60_12, ROOMS60_9])
def test_waits_decided_together_plan_as_each_alone(grid, agents: int) -> None:
    """``planner.turns.acting``, as the offline run drives a fleet: the
    same moves as a decision asked of each agent in turn."""
    assert _tracks_digest(grid, agents, batched=True) == _tracks_digest(grid, agents)
