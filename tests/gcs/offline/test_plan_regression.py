"""The plans do not change by accident: a fixed set of runs against recorded results.

Each case records the run's figures and a digest of every agent's track, so a
change that alters a single move shows. A change that makes plans better is
recorded again on purpose (``python -m tests.gcs.offline.test_plan_regression``) and the
difference is reported with it.
"""

from __future__ import annotations

import hashlib
import json
import sys
from collections.abc import Callable
from pathlib import Path

import pytest

from gcs.mission import load_mission
from gcs.offline.simulate import SimOptions, simulate
from sitl_mock import mapgen
from sitl_mock.gridmap import GridMap
from tests.checks import energy_for_round_trips, make_mission

RECORDED = Path(__file__).parents[2] / "data" / "plan_regression.json"
MISSIONS = Path(__file__).parents[3] / "missions"

#: name -> (mission file or generated map, agents, timed)
CASES: dict[str, tuple[str, int, bool]] = {
    "bob30-4": ("bob30.yaml", 4, False),
    "scenario1-1": ("scenario1.yaml", 1, False),
    "scenario1-5": ("scenario1.yaml", 5, False),
    "scenario1-11": ("scenario1.yaml", 11, False),
    "scenario2-3": ("scenario2.yaml", 3, False),
    "demo-5": ("demo.yaml", 5, False),
    "demo-5-timed": ("demo.yaml", 5, True),
    "rooms60-8": ("rooms:60:3", 8, False),
    "caves50-6": ("caves:50:4", 6, False),
    "open80-10": ("open:80:5", 10, False),
}
GENERATORS: dict[str, Callable[..., GridMap]] = {
    "rooms": mapgen.rooms,
    "caves": mapgen.caves,
    "open": mapgen.open_field,
}


def mission_for(source: str, agents: int):
    if source.endswith(".yaml"):
        return load_mission(MISSIONS / source).with_agents(agents)
    kind, size, seed = source.split(":")
    grid = GENERATORS[kind](int(size), int(size), int(seed))
    # A round trip to the farthest cell costs half of the usable battery.
    return make_mission(grid, agents, energy_per_m_pct=energy_for_round_trips(grid, 2.0))


def figures(name: str) -> dict[str, object]:
    source, agents, timed = CASES[name]
    result = simulate(mission_for(source, agents), SimOptions(timed=timed))
    digest = hashlib.sha256()
    for agent in result.agents:
        digest.update(json.dumps(agent.track).encode())
    return {
        "complete": result.complete,
        "total_path_m": result.total_path_m,
        "homing_m": sum(a.homing_m for a in result.agents),
        "iterations": result.iterations,
        "charges": sum(a.charges for a in result.agents),
        "tracks_sha256": digest.hexdigest(),
    }


@pytest.mark.parametrize("name", sorted(CASES))
def test_plan_is_unchanged(name: str) -> None:
    recorded = json.loads(RECORDED.read_text())
    assert name in recorded, (
        f"{name} was never recorded: python -m tests.gcs.offline.test_plan_regression"
    )
    assert figures(name) == recorded[name]


if __name__ == "__main__":
    names = sys.argv[1:] or sorted(CASES)
    table = json.loads(RECORDED.read_text()) if RECORDED.exists() else {}
    for name in names:
        before, table[name] = table.get(name), figures(name)
        if before != table[name]:
            print(f"{name}: {before} -> {table[name]}")
    RECORDED.write_text(json.dumps(table, indent=1, sort_keys=True) + "\n")
