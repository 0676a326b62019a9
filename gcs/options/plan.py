"""``gcs plan`` options."""

from __future__ import annotations

import argparse
from pathlib import Path

from gcs.options import runs
from planner.settings import BmRule, PathPlannerKind, TargetPolicy


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    p = sub.add_parser(
        "plan",
        help="run the planner offline against the mission's map (no MAVLink)",
        description=(
            "Run the planner against a simulated world built from the mission's map, in "
            "lockstep steps (every vehicle moves at most one cell per step; report.json also "
            "counts a planned path as one iteration, as the paper counts them). Prints a "
            "summary; with --out writes report.json, figures and the MCAP log."
        ),
    )
    add_mission_arguments(p)
    p.add_argument(
        "--out",
        type=Path,
        help="write report.json, PNG figures and the MCAP log (mission.mcap) to this folder",
    )
    p.add_argument("--seed", type=int, default=0, help="seed for the planner's random choices")
    p.add_argument(
        "--timed",
        action="store_true",
        help="predict a live run: each vehicle moves at its own speed_m_s and charges at its "
        "own charge_rate_pct_s, in ticks of mission time, instead of lockstep steps",
    )
    p.add_argument("--quiet", action="store_true", help="print nothing but errors")
    runs(p, "gcs.commands.plan:run")


def add_mission_arguments(p: argparse.ArgumentParser) -> None:
    """The mission and the planner-strategy options."""
    p.add_argument("mission", type=Path, help="mission file (YAML)")
    p.add_argument("--agents", type=int, metavar="N", help="override the fleet size")
    strategy = p.add_argument_group("planner strategy (defaults: our best)")
    strategy.add_argument(
        "--bm",
        choices=[r.value for r in BmRule],
        help="boustrophedon rule: 'paper' takes the first of N,S,E,W; 'tight' (default) "
        "sweeps dead ends and strips first",
    )
    strategy.add_argument(
        "--targets",
        choices=[t.value for t in TargetPolicy],
        help="what a blocked vehicle goes to: 'own_first' (the paper: its own stack of "
        "backtracking points, then the shared one, then the safety net), 'nearest' "
        "backtracking point, or 'frontier' (default: the nearest uncovered cell)",
    )
    strategy.add_argument(
        "--no-spread",
        action="store_true",
        help="do not prefer targets that no other working vehicle is closer to",
    )
    strategy.add_argument(
        "--no-top-up",
        action="store_true",
        help="charge only when the battery needs it, as the paper (default: also charge "
        "on the way when the charger is near and the next target far: planner.top_up_ratio)",
    )
    strategy.add_argument(
        "--path-planner",
        choices=[k.value for k in PathPlannerKind],
        help="exact grid search (default) or the paper's PRM",
    )
