"""Compiling the planner's numba kernels before anything waits on it.

numba compiles a kernel at its first call (seconds each after an install,
before its cache exists) and caches it on disk. A live mission must not
take that pause in its first decisions, with links open: it runs this
first. A small planning run on a maze of rooms with a few agents calls
every kernel the planner has; with
the cache filled it takes a fraction of a second.
"""

from __future__ import annotations

from gcs.generated_missions import GENERATORS, MAP_SEED, case_mission
from gcs.offline.simulate import SimOptions, simulate

#: The run that calls every kernel: a maze of rooms this many cells a side, this many agents.
WARM_UP_SIDE = 30
WARM_UP_AGENTS = 6


def warm_up_planner(kind: str = "rooms", side: int = WARM_UP_SIDE) -> None:
    """Plan a small mission offline so that every compiled kernel is compiled (or loaded
    from numba's cache) in this process."""
    grid = GENERATORS[kind](side, side, MAP_SEED)
    simulate(case_mission(grid, WARM_UP_AGENTS, f"warm-up-{kind}"), SimOptions())
