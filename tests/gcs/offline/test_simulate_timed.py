"""``simulate(timed=True)``: each vehicle at its own speed and charge rate, in mission time."""

from __future__ import annotations

import dataclasses
from itertools import pairwise

from hypothesis import given
from hypothesis import strategies as st

from gcs.offline.simulate import SimOptions, simulate
from sitl_mock.gridmap import GridMap
from sitl_mock.maps import parse_ascii
from tests.checks import check_run, make_mission
from tests.gcs.offline.test_plan_properties import PROPERTY, _energy_for, maps

CORRIDORS = parse_ascii(
    """\
##########
#........#
#.##.###.#
#........#
#.##.###.#
#........#
####C#####
"""
)


def with_paces(mission, speeds: list[float], rates: list[float]):
    fleet = tuple(
        dataclasses.replace(v, speed_m_s=s, charge_rate_pct_s=r)
        for v, s, r in zip(mission.fleet, speeds, rates, strict=True)
    )
    return dataclasses.replace(mission, fleet=fleet)


def test_equal_speeds_and_instant_charging_give_the_lockstep_run() -> None:
    mission = make_mission(CORRIDORS, 3)
    lockstep = simulate(mission)
    timed = simulate(mission, SimOptions(timed=True))
    assert [a.track for a in timed.agents] == [a.track for a in lockstep.agents]
    iterations = timed.extra["total_iterations"]
    assert isinstance(iterations, int)
    assert timed.extra["mission_s"] == iterations * 0.5  # 1 m at 2 m/s


def test_a_faster_vehicle_moves_more_cells_per_tick() -> None:
    mission = with_paces(make_mission(CORRIDORS, 2), [4.0, 1.0], [1.0, 1.0])
    result = simulate(mission, SimOptions(timed=True, max_iterations=8))
    fast, slow = (sum(a != b for a, b in pairwise(t.track)) for t in result.agents)
    assert fast == 8  # a cell every tick of 0.25 s
    assert slow <= 2  # a cell every 4 ticks at most


def test_charging_takes_mission_time_at_the_vehicle_rate() -> None:
    energy = _energy_for(CORRIDORS, 0.0)  # must come back to charge
    mission = with_paces(make_mission(CORRIDORS, 1, energy_per_m_pct=energy), [2.0], [4.0])
    result = simulate(mission, SimOptions(timed=True))
    check_run(result, mission.map, [])
    battery = result.agents[0].battery_pct
    gains = {round(b - a, 6) for a, b in pairwise(battery) if b > a}
    assert result.agents[0].charges >= 1
    assert max(gains) == 2.0  # 4 %/s over one tick of 0.5 s


@PROPERTY
@given(
    grid=maps,
    speeds=st.lists(st.sampled_from([1.0, 1.5, 2.0, 3.0, 4.0]), min_size=1, max_size=5),
    rate=st.sampled_from([0.5, 2.0, 10.0]),
)
def test_timed_runs_are_complete_and_safe(grid: GridMap, speeds: list[float], rate: float) -> None:
    base = make_mission(grid, len(speeds), energy_per_m_pct=_energy_for(grid, 0.5))
    mission = with_paces(base, speeds, [rate] * len(speeds))
    result = simulate(mission, SimOptions(timed=True))
    check_run(result, mission.map, [])
