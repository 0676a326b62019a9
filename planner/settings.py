"""Planner settings and the description of each agent the planner is given."""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum


class PathPlannerKind(StrEnum):
    """How paths to targets and to the charger are found."""

    GRID = "grid"  # exact breadth-first search on the grid (default)
    PRM = "prm"  # the paper's probabilistic roadmap, on networkx


class SearchKind(StrEnum):
    """Which implementation of the target search ranks a blocked agent's targets
    (``planner.target_search``): both return the same target and path."""

    COMPILED = "compiled"  # numba kernels and per-agent memories (default)
    REFERENCE = "reference"  # plain Python breadth-first search: the rule as written


@dataclass(frozen=True)
class SearchShortcuts:
    """Which shortcuts the planner takes, most of them in the compiled target search
    (``planner.speed.compiled_search``). Each only spares work: the plans are the
    same without it, which the tests show by switching it off here."""

    #: The horizon pass over the agent's shortlist (``HorizonMemo``), not every cell.
    shortlist: bool = True
    #: The target on the agent's way confirmed without a search (``_confirm``).
    confirm: bool = True
    #: The confirmation's candidates kept along the way (``WayMemo``).
    way_memo: bool = True
    #: A target proved by the last check carried on without one (``SettledTarget``).
    settled: bool = True
    #: Every candidate found left to other agents without a search.
    left_to_others: bool = True
    #: A held agent's distances from its cell kept for its next search (``StillField``).
    still_field: bool = True
    #: A held agent's wait told without the rest of its decision, when nothing it
    #: depends on changed (``Coordinator._still_held``).
    held_wait: bool = True


class TargetPolicy(StrEnum):
    """Which backtracking point a blocked agent takes."""

    OWN_FIRST = "own_first"  # its own stack, then the global one (the paper)
    NEAREST = "nearest"  # the nearest unclaimed BTP of any stack
    FRONTIER = "frontier"  # the nearest uncovered free cell, BTP or not


class BmRule(StrEnum):
    """How the boustrophedon motion picks among several open directions."""

    PAPER = "paper"  # first of N, S, E, W
    TIGHT = "tight"  # fewest onward openings first, then N, S, E, W
    #: Straight on while the way ahead is open, else the first of N, S, E, W: the
    #: paper's "translates forward or backward ... until it reaches a blocked
    #: position" read literally (Section 3.1).
    FORWARD = "forward"


class BtpChoice(StrEnum):
    """Which of the backtracking points in a stack a blocked agent takes (the
    ``own_first`` and ``nearest`` target policies; the safety net and ``frontier``
    always take the nearest along the way)."""

    PATH = "path"  # the nearest along the known free cells (the paper's Algorithm 3)
    LINE = "line"  # the nearest by straight line
    LAST = "last"  # the last found: the top of the stack


@dataclass(frozen=True)
class AgentSpec:
    """What the planner knows of an agent before the mission.

    ``energy_per_m_pct`` is the battery percentage a metre of travel costs
    (the paper's ``e_i``); 0 means no battery limit. Online it is an estimate
    with a safety margin, refreshed from telemetry.
    """

    id: int
    energy_per_m_pct: float


@dataclass(frozen=True)
class PlannerSettings:
    cell_size_m: float = 1.0
    reserve_pct: float = 20.0
    #: Battery percentage at which a charging agent leaves the charger.
    resume_pct: float = 100.0
    #: Percent gained per iteration on the charger; None charges instantly (the paper).
    charge_pct_per_step: float | None = None
    #: How many agents can charge at once; None is unlimited (the paper).
    charging_slots: int | None = None
    path_planner: PathPlannerKind = PathPlannerKind.GRID
    #: The target search's implementation: the same plans, at different speeds.
    search: SearchKind = SearchKind.COMPILED
    #: The compiled search's shortcuts (all taken unless a test switches one off).
    search_shortcuts: SearchShortcuts = SearchShortcuts()
    target_policy: TargetPolicy = TargetPolicy.FRONTIER
    bm_rule: BmRule = BmRule.TIGHT
    #: Among equally tight moves, take the one farthest from the other working
    #: agents (``BmRule.TIGHT`` only).
    bm_spread: bool = True
    #: Prefer targets that no other working agent is closer to.
    spread: bool = True
    #: With ``spread``, when every target is nearer to another working agent:
    #: leave to it those within this many cells of it (it is about to sweep
    #: them, chasing them only walks beside it) and take the nearest other one,
    #: or wait when there is none. 0 takes the nearest target even then.
    hold_radius: int = 5
    #: With ``hold_radius``, when the nearest target is nearer to another working
    #: agent but beyond ``hold_radius`` of it: wait too if that agent, drawing
    #: nearer to it by this many cells per move of the way there, would be within
    #: ``hold_radius`` of it first (it would sweep it before this agent arrived).
    #: In a crowd most walks to such targets ended held back on the way: waiting
    #: shortens paths, most in mazes, but lengthens the mission where agents
    #: outnumber the work (docs/performance.md); 0: take them.
    rival_pace: float = 0.1
    #: Divide a crowd between the parts of the map: N > 0 cuts it into regions of
    #: N cells a side, and an agent looking for a target leaves the regions other
    #: agents sweep in or head for to them, unless nothing else is left
    #: (``planner.regions``). 0: off.
    region_claims: int = 0
    #: Leave whole to another agent the pocket it sweeps beside or chases a target
    #: in: a connected part of at most N cells not known to be covered, enclosed
    #: by walls and covered cells; wait when nothing else is left
    #: (``planner.pockets``). 0: off.
    pocket_claims: int = 0
    #: Longest pause, in decisions, before a held-back agent searches again
    #: (0: search at every decision). Each search of a held agent in a crowd is
    #: a search of the known map that ends held again: with ``rival_pace`` many
    #: agents wait long, and a short pause would spend the planner's time on them.
    held_backoff_max: int = 128
    #: Decide afresh at every step of a transit (sweep from an uncovered cell
    #: passed on the way, or take a target that has become nearer); the paper
    #: travels to the chosen BTP. Only with the exact grid paths.
    replan_transit: bool = True
    #: With ``replan_transit``: N > 0 searches again for a target more than N
    #: moves away only once half the way beyond N is travelled (0: at every
    #: step). Each search covers the known map around the agent out to the
    #: target, so on large maps these searches are most of the planner's time;
    #: the plans change (shorter on some maps, longer on others: docs/performance.md).
    far_transit_recheck: int = 0
    #: An agent that found its next target farther away than the charger goes to
    #: charge first when the way there and back costs at most this share of the
    #: charge it would get (0: only when the battery needs it, as the paper).
    #: Charges taken near the charger early spare trips from the far end of the
    #: map later, and thin a crowd (docs/performance.md).
    top_up_ratio: float = 0.4
    #: When coverage is complete, every agent charges to ``resume_pct`` at home before
    #: it is done; False: it is done once home, and the mission ends without waiting
    #: on charges nobody needs.
    charge_at_end: bool = False
    #: Iterations an agent waits on another before asking it to make way.
    patience: int = 2
    #: Which BTP of a stack a blocked agent takes (other readings of the paper).
    btp_choice: BtpChoice = BtpChoice.PATH
    #: The safety net (an uncovered cell that is no BTP) is taken only when no other
    #: agent is working; before, an agent without a BTP waits, as the paper's "a free
    #: agent is waiting for the first available BTP" reads (``own_first``, ``nearest``).
    net_when_alone: bool = False
    #: The decisions between two agents' first moves from the charger (0: every agent
    #: may leave at once, one after another as the cells ahead free up).
    launch_interval: int = 0
    #: Share of known free cells that are PRM nodes, and the connection radius in
    #: cells (only for ``PathPlannerKind.PRM``).
    prm_node_fraction: float = 0.15
    prm_radius_cells: float = 6.0
    seed: int = 0

    def __post_init__(self) -> None:
        if self.cell_size_m <= 0:
            raise ValueError("cell_size_m must be positive")
        if not 0 <= self.reserve_pct < 100:
            raise ValueError("reserve_pct must be in [0, 100)")
        if not self.reserve_pct < self.resume_pct <= 100:
            raise ValueError("resume_pct must be above the reserve and at most 100")
        if self.charge_pct_per_step is not None and self.charge_pct_per_step <= 0:
            raise ValueError("charge_pct_per_step must be positive")
        if self.charging_slots is not None and self.charging_slots < 1:
            raise ValueError("charging_slots must be at least 1")
        if self.far_transit_recheck < 0:
            raise ValueError("far_transit_recheck must not be negative")
        if not 0 <= self.top_up_ratio <= 1:
            raise ValueError("top_up_ratio must be in [0, 1]")
        if self.rival_pace < 0:
            raise ValueError("rival_pace must not be negative")
        if self.region_claims < 0:
            raise ValueError("region_claims must not be negative")
        if self.pocket_claims < 0:
            raise ValueError("pocket_claims must not be negative")
        if self.launch_interval < 0:
            raise ValueError("launch_interval must not be negative")
