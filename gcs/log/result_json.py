"""A ``RunResult`` as JSON, as the log's ``/run/result`` holds it, and back exactly."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, NamedTuple

import numpy as np

from core.cells import Cell
from gcs.outcome.result import AgentTrace, BtpRecord, RunResult


def _array_json(array: np.ndarray) -> dict[str, Any]:
    """The array as nested lists once encoded (by orjson, from the array's memory)."""
    return {"dtype": str(array.dtype), "data": np.ascontiguousarray(array)}


def _array_from(value: dict[str, Any]) -> np.ndarray:
    return np.array(value["data"], dtype=value["dtype"])


class AgentSteps(NamedTuple):
    """An agent's cell and battery at every step of the run."""

    track: tuple[Cell, ...]
    battery_pct: tuple[float, ...]


def _cell(value: Sequence[int]) -> Cell:
    return (int(value[0]), int(value[1]))


def result_to_json(result: RunResult, *, traces: bool = True) -> dict[str, Any]:
    """Every field of a RunResult, ready for orjson with ``OPT_SERIALIZE_NUMPY`` (tuples
    and numpy arrays stand for arrays: the encoder takes them as they are, where copying
    each cell of every track or map into a list cost more than encoding it);
    :func:`result_from_json` inverts it exactly. ``traces`` False leaves out each agent's
    track and battery at every step, for a log that holds them already (an offline
    run's ``/fleet/states``): the reader puts them back from there."""
    return {
        "mission": result.mission,
        "shape": list(result.shape),
        "cell_size_m": result.cell_size_m,
        "charger": list(result.charger),
        "reserve_pct": result.reserve_pct,
        "belief": _array_json(result.belief),
        "covered": _array_json(result.covered),
        "agents": [
            {
                "id": a.id,
                **({"track": a.track, "battery_pct": a.battery_pct} if traces else {}),
                "path_m": a.path_m,
                "homing_m": a.homing_m,
                "charges": a.charges,
                "min_battery_pct": a.min_battery_pct,
                "lost": a.lost,
            }
            for a in result.agents
        ],
        "btps": [
            (b.cell, b.detected_by, b.detected_at, b.covered_by, b.covered_at) for b in result.btps
        ],
        "covered_per_iteration": result.covered_per_iteration,
        "iterations": result.iterations,
        "free_cells": result.free_cells,
        "covered_cells": result.covered_cells,
        "out_of_range_cells": result.out_of_range_cells,
        "safety_net_fires": result.safety_net_fires,
        "wall_s": result.wall_s,
        "planner_s": result.planner_s,
        "extra": dict(result.extra),
    }


def result_from_json(
    data: dict[str, Any], traces: Mapping[int, AgentSteps] | None = None
) -> RunResult:
    """The result ``data`` holds; an agent's track and battery, when ``data`` leaves them
    out, from ``traces`` (by agent id)."""
    traces = traces or {}
    agents = tuple(
        AgentTrace(
            id=int(a["id"]),
            track=tuple(_cell(c) for c in a["track"]) if "track" in a else traces[a["id"]].track,
            battery_pct=(
                tuple(float(b) for b in a["battery_pct"])
                if "battery_pct" in a
                else traces[a["id"]].battery_pct
            ),
            path_m=float(a["path_m"]),
            homing_m=float(a["homing_m"]),
            charges=int(a["charges"]),
            min_battery_pct=float(a["min_battery_pct"]),
            lost=bool(a["lost"]),
        )
        for a in data["agents"]
    )
    btps = tuple(
        BtpRecord(_cell(cell), int(by), int(at), cov_by, cov_at)
        for cell, by, at, cov_by, cov_at in data["btps"]
    )
    return RunResult(
        mission=str(data["mission"]),
        shape=_cell(data["shape"]),
        cell_size_m=float(data["cell_size_m"]),
        charger=_cell(data["charger"]),
        reserve_pct=float(data["reserve_pct"]),
        belief=_array_from(data["belief"]),
        covered=_array_from(data["covered"]),
        agents=agents,
        btps=btps,
        covered_per_iteration=tuple(int(c) for c in data["covered_per_iteration"]),
        iterations=int(data["iterations"]),
        free_cells=int(data["free_cells"]),
        covered_cells=int(data["covered_cells"]),
        out_of_range_cells=int(data["out_of_range_cells"]),
        safety_net_fires=int(data["safety_net_fires"]),
        wall_s=float(data["wall_s"]),
        planner_s=float(data["planner_s"]),
        extra=dict(data.get("extra", {})),
    )
