"""The planner as a mission asks for it, for the offline and the live run alike: its
settings and, for a fleet that takes the map as known, the prior map."""

from __future__ import annotations

import numpy as np

from core.cells import CellState
from gcs.mission import Mission
from planner.settings import PathPlannerKind, PlannerSettings


def planner_settings(mission: Mission, seed: int = 0, **strategy: object) -> PlannerSettings:
    """The planner settings a mission asks for; ``strategy`` overrides the rest."""
    spec = mission.planner
    settings: dict[str, object] = {
        "cell_size_m": mission.cell_size_m,
        "reserve_pct": spec.reserve_pct,
        "charge_pct_per_step": spec.charge_pct_per_step,
        "charging_slots": spec.charging_slots,
        "path_planner": PathPlannerKind(spec.path_planner),
        "far_transit_recheck": spec.far_transit_recheck or 0,
        "charge_at_end": spec.charge_at_end,
        "seed": seed,
    }
    if spec.top_up_ratio is not None:  # null: the planner's default
        settings["top_up_ratio"] = spec.top_up_ratio
    if spec.rival_pace is not None:
        settings["rival_pace"] = spec.rival_pace
    if spec.pocket_claims is not None:
        settings["pocket_claims"] = spec.pocket_claims
    return PlannerSettings(**(settings | strategy))  # type: ignore[arg-type]


def prior_map(mission: Mission) -> np.ndarray | None:
    """The known map handed to the planner when the fleet takes the map as known."""
    if not mission.fleet or any(v.sensing != "map" for v in mission.fleet):
        return None
    obstacle = mission.map.obstacle
    return (obstacle * int(CellState.OBSTACLE) + (~obstacle) * int(CellState.FREE)).astype("int8")
