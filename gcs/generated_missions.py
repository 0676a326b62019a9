"""Missions on generated maps, for benchmarks, comparisons and the planner's warm-up.

A fleet of rovers (every fourth a copter) that sense with range sensors, with
a battery that makes a round trip to the farthest cell cost two thirds of the
usable charge, so that every vehicle has to come back to charge.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from gcs.mission import (
    Mission,
    Origin,
    PlannerSpec,
    Sensing,
    VehicleSpec,
    VehicleType,
    default_connection,
)
from gcs.preflight import charger_distances
from sitl_mock import mapgen
from sitl_mock.gridmap import GridMap

#: A map of a kind: (height, width, seed) -> map.
MapMaker = Callable[[int, int, int], GridMap]
GENERATORS: dict[str, MapMaker] = {
    "rooms": mapgen.rooms,
    "building": mapgen.building,
    "open": mapgen.open_field,
}
MAP_SEED = 1
RESERVE_PCT = 20.0
#: A round trip to the farthest cell costs this share of the usable charge.
FARTHEST_TRIP_SHARE = 2 / 3


def case_mission(
    grid: GridMap,
    agents: int,
    name: str,
    connections: list[str] | None = None,
    *,
    battery: bool = True,
) -> Mission:
    """A mission of ``agents`` vehicles on ``grid`` (rovers, every fourth a copter), the
    battery set as the module says, or (``battery=False``) without a battery limit, as
    the paper's Table 2; ``connections`` default to the mission defaults."""
    if not battery:
        return _mission(grid, agents, 0.0, name, connections)
    probe = _mission(grid, 1, 0.0, name, None)
    far = int(charger_distances(probe).max())
    energy = (100.0 - RESERVE_PCT) * FARTHEST_TRIP_SHARE / (2 * max(far, 1))
    return _mission(grid, agents, energy, name, connections)


def _mission(
    grid: GridMap, agents: int, energy: float, name: str, connections: list[str] | None
) -> Mission:
    fleet = tuple(
        VehicleSpec(
            sysid=i + 1,
            type=VehicleType.COPTER if i % 4 == 3 else VehicleType.ROVER,
            sensing=Sensing.RANGE,
            connection=connections[i] if connections else default_connection(i + 1),
            energy_per_m_pct=energy,
            battery_capacity_mah=5000.0,
            speed_m_s=2.0,
            charge_rate_pct_s=2.0,
        )
        for i in range(agents)
    )
    return Mission(
        name=name,
        source=Path(f"{name}.yaml"),
        map=grid,
        charger=grid.charger,
        cell_size_m=1.0,
        origin=Origin(),
        fleet=fleet,
        planner=PlannerSpec(reserve_pct=RESERVE_PCT),
    )
