"""The run's second count of iterations: a planned path counts once (``PathSteps``)."""

from __future__ import annotations

from gcs.offline.simulate import SimOptions, simulate
from gcs.planning import planner_settings
from planner.settings import BmRule, TargetPolicy
from sitl_mock.maps import parse_ascii
from tests.checks import make_mission

#: Up the stem, east to the dead end, back west along the top to the last cell.
T_SHAPE = parse_ascii(
    """\
#######
#.....#
###.###
###.###
###C###
"""
)


def test_a_path_back_from_a_dead_end_is_one_iteration() -> None:
    mission = make_mission(T_SHAPE, 1)
    settings = planner_settings(
        mission,
        bm_rule=BmRule.PAPER,
        target_policy=TargetPolicy.OWN_FIRST,
        spread=False,
        replan_transit=False,
        top_up_ratio=0.0,
    )
    result = simulate(mission, SimOptions(settings=settings))
    (agent,) = result.agents
    # Sweep: (3,3) (2,3) (1,3) (1,4) (1,5); blocked, the path to the BTP (1,2):
    # (1,4) (1,3) (1,2); sweep on to (1,1), the last cell.
    assert agent.track[1:10] == (
        (3, 3), (2, 3), (1, 3), (1, 4), (1, 5), (1, 4), (1, 3), (1, 2), (1, 1),
    )  # fmt: skip
    assert result.complete
    assert result.iterations == 9  # every move an iteration
    assert result.extra["path_iterations"] == 7  # 6 sweep steps and the path of 3 moves
