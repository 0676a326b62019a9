"""What the operator sees of the mission, as values: each vehicle's status and the progress.

The terminal display draws them, and the status task writes them to the mission
log a few times a second, where the web page (``gcs.web``) and a replay read
them: one account of the mission for every view.
"""

from __future__ import annotations

import asyncio
import logging
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from core.cells import Cell
from gcs.live.shared import Phase, SharedPlanner, VehicleView
from gcs.log.mission_log import WAY_CELLS, MissionLog, MissionProgress, VehicleStatus
from planner.agent import AgentMode
from planner.belief import UNREACHED

if TYPE_CHECKING:
    from gcs.live.run import LiveRun

#: A vehicle's way ahead and the length of its way home (None: no known way).
Planned = tuple[tuple[Cell, ...], float | None]

#: What a rover does where a copter flies.
_ROVER_PHASE = {Phase.FLYING_HOME: "driving home (AUTO)", Phase.TAKING_OFF: "arming"}

#: The planner's modes in which a vehicle follows a planned way (an exploring one sweeps
#: cell by cell: what its way still holds is not where it goes).
_TRAVELLING = frozenset({AgentMode.TRANSIT, AgentMode.RETURN, AgentMode.HOMING})

#: Real seconds between two looks at the mission by the status task.
STATUS_PERIOD_S = 0.25


def activity(view: VehicleView) -> str:
    """The phase, in a rover's words for a rover, and what the vehicle waits for in it
    (``connecting: GPS fix``)."""
    phase = view.phase.value
    if view.kind == "rover":
        phase = _ROVER_PHASE.get(view.phase, phase)
    return f"{phase}: {view.detail}" if view.detail else phase


def mission_progress(run: LiveRun) -> MissionProgress | None:
    """The mission's coverage, what it is doing and the time left (None before the
    planner starts)."""
    planner = run.planner
    if planner is None:
        return None
    record = planner.record
    covered = planner.coordinator.belief.covered_count
    free = max(1, record.free_cells)
    views = run.views.values()
    parked = bool(views) and all(v.phase in (Phase.DONE, Phase.LOST) for v in views)
    left_s = None
    if run.aborted:
        state = "aborted, every vehicle parked" if parked else "aborted, going home"
    elif planner.coordinator.coverage_complete:
        state = (
            "coverage complete, every vehicle parked" if parked else "coverage complete, going home"
        )
    else:
        state = "covering"
        # At this run's pace (a resumed mission's cells covered before do not count).
        done = covered - record.covered_at_start
        elapsed = run.elapsed_s
        if done > 1 and elapsed > 0 and free > covered:
            left_s = (free - covered) * elapsed / done
    return MissionProgress(
        covered=covered,
        free=free,
        state=state,
        time_left_s=left_s,
        speedup=getattr(run.clock, "speedup", None),
    )


def _planned(planner: SharedPlanner, sysid: int, cell_size_m: float) -> Planned:
    """The way ahead of a vehicle on its way somewhere (to a new area, to charge, home):
    the cell it was sent to, then the planner's path; and the length of its way home."""
    coordinator = planner.coordinator
    way: tuple[Cell, ...] = ()
    if coordinator.mode(sysid) in _TRAVELLING:
        target = planner.heading_for(sysid)
        path = coordinator.planned_path(sysid)[:WAY_CELLS]
        way = tuple(path if target is None else [target, *path])
    steps = coordinator.belief.distance_to_charger(coordinator.cell_of(sysid))
    return way, None if steps >= UNREACHED else steps * cell_size_m


@dataclass
class _Heard:
    """When a vehicle was last heard: its link's message count, and the mission time at
    which the count last grew."""

    count: int = -1
    at_s: float | None = None


@dataclass
class StatusWatch:
    """Turns a running mission into statuses, remembering when each link was last heard."""

    run: LiveRun
    heard: dict[int, _Heard] = field(default_factory=dict)

    def vehicles(self, ways: dict[int, Planned]) -> list[VehicleStatus]:
        run = self.run
        now = run.clock.now()
        reserve = run.mission.planner.reserve_pct
        statuses = []
        for sysid, view in run.views.items():
            link = run.links.get(sysid)
            heard = self.heard.setdefault(sysid, _Heard())
            if link is not None and link.messages_in != heard.count:
                heard.count, heard.at_s = link.messages_in, now
            way, home_m = ways.get(sysid, ((), None))
            energy = view.energy_pct_per_m
            battery = view.battery_pct
            range_m = None
            if energy and battery is not None:
                range_m = round(max(0.0, battery - reserve) / energy, 1)
            statuses.append(
                VehicleStatus(
                    sysid=sysid,
                    kind=view.kind,
                    activity=activity(view),
                    phase=view.phase.value,
                    task=view.mode,
                    cell=view.cell,
                    battery_pct=None if battery is None else round(battery, 1),
                    energy_pct_per_m=energy,
                    range_m=range_m,
                    home_m=home_m,
                    charges=view.charges,
                    way=way,
                    link_up=link is not None and link.is_up,
                    heard_s_ago=None if heard.at_s is None else round(now - heard.at_s, 1),
                    rejected_frames=0 if link is None else link.rejected.total,
                )
            )
        return statuses

    async def write(self, log: MissionLog) -> None:
        """One look at the mission, written to ``log`` (which keeps only what changed)."""
        planner = self.run.planner
        progress = mission_progress(self.run)
        if planner is None or progress is None:
            return
        cell_size_m = self.run.mission.cell_size_m
        async with planner.reading():
            ways = {sysid: _planned(planner, sysid, cell_size_m) for sysid in self.run.views}
        log.status(planner.t_s, self.vehicles(ways), progress)

    async def keep_writing(self, log: MissionLog, period_s: float = STATUS_PERIOD_S) -> None:
        """``write`` every ``period_s`` real seconds until cancelled. A failure here ends
        the statuses, never the mission."""
        try:
            while True:
                await self.write(log)
                await asyncio.sleep(period_s)  # a pace, not a wait for something
        except Exception:
            logging.getLogger(__name__).exception("the vehicle statuses stopped")
