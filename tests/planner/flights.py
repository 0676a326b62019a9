"""Whole plans with the planner alone: the coordinator against the lockstep world
(``sitl_mock``'s ground truth), every agent once per iteration, as ``gcs plan``
flies them, without the ground station."""

from __future__ import annotations

import hashlib
import json
from collections.abc import Iterator
from dataclasses import dataclass, field

from core.cells import Cell
from planner.agent import Action, ActionKind
from planner.coordinator import Coordinator
from planner.settings import AgentSpec, PlannerSettings
from planner.target_search import TargetSearch
from planner.turns import acting
from sitl_mock.gridmap import GridMap
from sitl_mock.lockstep import Body, LockstepWorld


@dataclass(frozen=True)
class Flight:
    tracks: tuple[tuple[Cell, ...], ...]
    complete: bool
    finished: bool
    #: The coordinator's target search, as the plan left it (its counts, when compiled).
    search: TargetSearch = field(compare=False, repr=False)
    #: Held waits the coordinator told by its shortcut (``Coordinator._still_held``).
    quick_held_waits: int = 0

    def digest(self) -> str:
        """Equal digests: the same plan, cell for cell."""
        return hashlib.sha256(json.dumps(self.tracks).encode()).hexdigest()


def fly(
    grid: GridMap,
    agents: int,
    settings: PlannerSettings,
    *,
    energy_per_m_pct: float,
    max_iterations: int | None = None,
    batched: bool = False,
    balk_every: int = 0,
) -> Flight:
    """``agents`` identical agents from the charger until the planner has finished
    (or ``max_iterations``, by default 40 per free cell); ``batched``: the waits of
    an iteration decided together (``planner.turns``), as ``gcs plan`` does;
    ``balk_every``: every so many moves decided, one does not happen and the agent
    is seen where it stood, as a live vehicle's move can fail."""
    ids = range(1, agents + 1)
    coordinator = Coordinator(
        grid.shape, grid.charger, [AgentSpec(i, energy_per_m_pct) for i in ids], settings
    )
    world = LockstepWorld(grid, [Body(i, energy_per_m_pct) for i in ids])
    tracks: dict[int, list[Cell]] = {i: [grid.charger] for i in ids}
    for i in ids:
        coordinator.observe(i, grid.charger, world.sense(grid.charger), world.battery[i])
    limit = max_iterations or 40 * grid.free_count + 1000
    moves = 0
    for _ in range(limit):
        if coordinator.finished:
            break
        for i, action in _decisions(coordinator, list(ids), batched):
            if action.kind == ActionKind.MOVE and action.to is not None:
                moves += 1
                if balk_every and moves % balk_every == 0:
                    here = world.position[i]
                    coordinator.observe(i, here, world.sense(here), world.battery[i])
                    continue
                world.move(i, action.to)
                coordinator.observe(i, action.to, world.sense(action.to), world.battery[i])
            elif action.kind == ActionKind.CHARGE:
                world.request_charge(i)
        world.end_iteration()
        for i in ids:
            coordinator.update_battery(i, world.battery[i])
            tracks[i].append(world.position[i])
    return Flight(
        tracks=tuple(tuple(track) for track in tracks.values()),
        complete=coordinator.coverage_complete,
        finished=coordinator.finished,
        search=coordinator._search,
        quick_held_waits=coordinator.quick_held_waits,
    )


def _decisions(
    coordinator: Coordinator, ids: list[int], batched: bool
) -> Iterator[tuple[int, Action]]:
    """An iteration's decisions: each agent's in turn, or (``batched``) those that do
    more than wait. Lazily: each is decided after the one before was carried out."""
    if batched:
        yield from acting(coordinator, ids, ())
        return
    for i in ids:
        yield i, coordinator.decide(i)
