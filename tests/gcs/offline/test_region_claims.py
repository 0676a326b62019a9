"""Region claims (``PlannerSettings.region_claims``): a crowd divided between the parts
of the map keeps every property of a plan, and the compiled search plans as the
reference one does with them (and with pocket claims, ``planner.pockets``)."""

from __future__ import annotations

import dataclasses

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from gcs.planning import planner_settings
from planner.settings import PlannerSettings, SearchKind
from sitl_mock import mapgen
from tests.checks import energy_for_round_trips, make_mission
from tests.gcs.offline.test_plan_properties import maps, run_checked
from tests.planner.flights import fly


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    grid=maps,
    agents=st.integers(1, 12),
    size=st.sampled_from([2, 4, 8, 16]),
    headroom=st.sampled_from([None, 0.1, 0.5, 2.0]),
    charge=st.sampled_from([None, 25.0]),
)
def test_region_claims_keep_the_invariants(grid, agents, size, headroom, charge) -> None:
    """Complete coverage, none lost, no collisions or swaps, the battery above the
    reserve (``check_run``), on random maps with and without a battery limit."""
    energy = 0.0 if headroom is None else energy_for_round_trips(grid, 1 + headroom)
    mission = make_mission(grid, agents, energy, charge_pct_per_step=charge)
    result = run_checked(mission, planner_settings(mission, region_claims=size))
    assert result.out_of_range_cells == 0


@pytest.mark.parametrize("kind", ["rooms", "caves", "open_field", "bars"])
@pytest.mark.parametrize("agents", [3, 12])
@pytest.mark.parametrize(
    "claims", [PlannerSettings(region_claims=6), PlannerSettings(pocket_claims=64)]
)
def test_the_reference_search_plans_as_the_compiled_one_with_claims(
    kind: str, agents: int, claims: PlannerSettings
) -> None:
    """The cells left to others are excluded from both searches alike."""
    grid = getattr(mapgen, kind)(30, 30, seed=agents)
    energy = 80.0 / (4 * sum(grid.shape))
    digests = []
    for search in (SearchKind.COMPILED, SearchKind.REFERENCE):
        chosen = dataclasses.replace(claims, search=search)
        flight = fly(grid, agents, chosen, energy_per_m_pct=energy)
        assert flight.complete and flight.finished
        digests.append(flight.digest())
    assert digests[0] == digests[1]


def test_region_claims_must_not_be_negative() -> None:
    with pytest.raises(ValueError, match="region_claims"):
        PlannerSettings(region_claims=-1)
