"""An aborted mission: the planner brings every agent home (``Coordinator.recall``)."""

from __future__ import annotations

from hypothesis import assume, given, settings
from hypothesis import strategies as st

from planner.agent import ActionKind, AgentMode
from planner.coordinator import Coordinator
from planner.settings import AgentSpec, PlannerSettings
from sitl_mock import mapgen
from sitl_mock.gridmap import GridMap
from sitl_mock.lockstep import Body, LockstepWorld

GENERATORS = (mapgen.rooms, mapgen.caves, mapgen.open_field)
#: Iterations a recalled fleet of a 20x20 map may take to be home: ways home are
#: at most a few dozen moves; the mission itself would take hundreds more.
HOME_WITHIN = 150


@settings(max_examples=40, deadline=None)
@given(
    kind=st.sampled_from(range(len(GENERATORS))),
    seed=st.integers(0, 10_000),
    agents=st.integers(1, 6),
    recall_at=st.integers(0, 200),
)
def test_recalled_agents_all_go_home_apart_and_stop(
    kind: int, seed: int, agents: int, recall_at: int
) -> None:
    """Recalled at any moment before coverage is complete (exploring, in
    transit, returning, charging): every agent reaches the charger soon (by a
    way home, not after the rest of the mission) and is done there, no battery
    runs below the reserve, and the lockstep world, which refuses a move into
    a wall or an occupied cell, never has to refuse one."""
    grid = GENERATORS[kind](20, 20, seed)
    ids = list(range(1, agents + 1))
    reserve = 20.0
    coordinator = Coordinator(
        grid.shape,
        grid.charger,
        [AgentSpec(i, 1.5) for i in ids],
        PlannerSettings(reserve_pct=reserve, charge_pct_per_step=2.0),
    )
    world = LockstepWorld(grid, [Body(i, 1.5) for i in ids], charge_pct_per_step=2.0)
    for i in ids:
        coordinator.observe(i, grid.charger, world.sense(grid.charger), world.battery[i])
    for iteration in range(recall_at + HOME_WITHIN):
        if iteration == recall_at:
            assume(not coordinator.homeward)
            coordinator.recall()
        if coordinator.finished:
            break
        for i in ids:
            action = coordinator.decide(i)
            if action.kind == ActionKind.MOVE:
                assert action.to is not None
                world.move(i, action.to)
                coordinator.observe(i, action.to, world.sense(action.to), world.battery[i])
            elif action.kind == ActionKind.CHARGE:
                assert iteration < recall_at  # recalled, one on the pad is done at once
                world.request_charge(i)
        world.end_iteration()
        for i in ids:
            assert world.battery[i] >= reserve - 1e-6
            coordinator.update_battery(i, world.battery[i])
    assert coordinator.finished
    for i in ids:
        assert coordinator.mode(i) == AgentMode.DONE
        assert world.position[i] == grid.charger


def _fly_to_the_end(grid: GridMap, agents: int, charge_at_end: bool) -> tuple[int, list[float]]:
    """A whole mission with slow charging: the charges asked for once coverage was complete,
    and every agent's battery at the end."""
    ids = list(range(1, agents + 1))
    settings_ = PlannerSettings(
        reserve_pct=20.0, charge_pct_per_step=2.0, charge_at_end=charge_at_end
    )
    coordinator = Coordinator(grid.shape, grid.charger, [AgentSpec(i, 1.5) for i in ids], settings_)
    world = LockstepWorld(grid, [Body(i, 1.5) for i in ids], charge_pct_per_step=2.0)
    for i in ids:
        coordinator.observe(i, grid.charger, world.sense(grid.charger), world.battery[i])
    late_charges = 0
    for _ in range(5000):
        if coordinator.finished:
            break
        complete = coordinator.coverage_complete
        for i in ids:
            action = coordinator.decide(i)
            if action.kind == ActionKind.MOVE:
                assert action.to is not None
                world.move(i, action.to)
                coordinator.observe(i, action.to, world.sense(action.to), world.battery[i])
            elif action.kind == ActionKind.CHARGE:
                late_charges += complete
                world.request_charge(i)
        world.end_iteration()
        for i in ids:
            coordinator.update_battery(i, world.battery[i])
    assert coordinator.finished
    return late_charges, [world.battery[i] for i in ids]


def test_at_the_end_vehicles_park_without_a_full_charge_unless_asked() -> None:
    """Coverage complete: by default an agent at the charger is done at once (the mission
    does not wait on charges nobody needs); with ``charge_at_end`` each charges to full."""
    grid = mapgen.rooms(24, 24, 3)
    late, batteries = _fly_to_the_end(grid, 4, charge_at_end=False)
    assert late == 0 and min(batteries) < 100.0
    late, batteries = _fly_to_the_end(grid, 4, charge_at_end=True)
    assert late > 0 and min(batteries) >= 100.0 - 1e-6
