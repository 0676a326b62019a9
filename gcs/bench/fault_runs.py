"""The fault campaign's runs, each in a child process of its own and through the
mission API (``run_live``), as ``gcs run`` flies them: a station with the mock fleet
and its faults in the same process (``--sim``), or a station alone, against a mock
fleet served by another child (the row whose station is killed and resumed from its
log). Each station writes ``mission.mcap`` and ``report.json`` to its folder."""

from __future__ import annotations

import asyncio
import dataclasses
import logging
import multiprocessing
from dataclasses import dataclass
from multiprocessing.connection import Connection
from multiprocessing.process import BaseProcess
from pathlib import Path

from core.clocks import ScaledClock
from gcs.errors import EXIT_BAD_INPUT, EXIT_FAILED, EXIT_OK
from gcs.live.agent import AgentSettings
from gcs.live.mission import run_live
from gcs.live.resume import ResumeError, load_resume_point
from gcs.live.run import LiveOptions, MissionRefused
from gcs.live.shared import Level
from gcs.log.mcap_log import McapMissionLog
from gcs.mission import load_mission
from gcs.mock_fleet import STARTUP_DELAY_S, MockFleetRehearsal, SimFaults, mock_fleet_configs
from gcs.options.run import LOST_AFTER_S
from gcs.outcome.report import write_report
from sitl_mock.fleet import MockFleet

#: The station's log in its folder, as ``gcs run --out`` names it.
LOG_NAME = "mission.mcap"
#: Real seconds a child is given to end once told to.
END_S = 10.0


@dataclass(frozen=True)
class StationRun:
    """One ground station's run: its mission, its output folder, and how it flies."""

    mission: Path
    out: Path
    seed: int
    speedup: float
    #: The mock fleet flown in the station's process with these faults; None: the
    #: vehicles are elsewhere (another process), as a real fleet is.
    faults: SimFaults | None
    #: Carry on from this log of an earlier (killed) station.
    resume: Path | None = None


def _quiet(_text: str, _level: Level, _sysid: int | None) -> None:
    pass


def _fly(run: StationRun, answer: Connection) -> None:
    """In the child: the mission flown, its log and report written; sends the exit
    status ``gcs run`` would give, and a line saying why when it refused to fly."""
    if not logging.getLogger().handlers:
        logging.getLogger().addHandler(logging.NullHandler())
    mission = load_mission(run.mission)
    try:
        resume = None if run.resume is None else load_resume_point(run.resume, mission)
    except ResumeError as exc:
        answer.send((EXIT_BAD_INPUT, str(exc)))
        return
    options = LiveOptions(
        speedup=run.speedup,
        seed=run.seed,
        agent=dataclasses.replace(AgentSettings(), lost_after_s=LOST_AFTER_S),
        resume=resume,
    )
    sim = None if run.faults is None else MockFleetRehearsal(mission, run.faults, seed=run.seed)
    run.out.mkdir(parents=True, exist_ok=True)
    log = McapMissionLog.for_mission(
        mission, run.out / LOG_NAME, free_cells=mission.reachable_cells
    )
    try:
        result = asyncio.run(run_live(mission, options, log, _quiet, asyncio.Event(), sim=sim))
    except MissionRefused as exc:
        answer.send((exc.exit_code, str(exc)))
        return
    finally:
        log.close()
    write_report(result, run.out)
    answer.send((EXIT_OK if result.complete else EXIT_FAILED, ""))


def start_station(run: StationRun) -> tuple[BaseProcess, Connection]:
    """The station's child process, started; the end its answer comes from."""
    context = multiprocessing.get_context("fork")
    answer, sent = context.Pipe(duplex=False)
    process = context.Process(target=_fly, args=(run, sent), daemon=True)
    process.start()
    sent.close()
    return process, answer


def fly_station(run: StationRun, limit_s: float) -> tuple[int | None, str]:
    """Exit status (None when over ``limit_s`` real seconds) and the line saying why."""
    process, answer = start_station(run)
    try:
        if not answer.poll(limit_s):
            return None, f"over {limit_s:g} s"
        try:
            return answer.recv()  # type: ignore[no-any-return]
        except EOFError:
            process.join(END_S)
            return process.exitcode, f"the station ended without a word (exit {process.exitcode})"
    finally:
        answer.close()
        end(process)


def _serve_fleet(mission_path: Path, speedup: float) -> None:
    """In the child: the mission's mock fleet served until the process is ended, holding
    where it is when its ground station falls silent (as ``sitl-mock`` serves it)."""
    mission = load_mission(mission_path)
    configs = mock_fleet_configs(mission, startup_delay_s=STARTUP_DELAY_S)

    async def serve() -> None:
        async with MockFleet(configs, mission.map, mission.geo, ScaledClock(speedup)):
            await asyncio.Event().wait()

    asyncio.run(serve())


def start_fleet(mission: Path, speedup: float) -> BaseProcess:
    """The mission's mock fleet in a child process of its own."""
    context = multiprocessing.get_context("fork")
    process = context.Process(target=_serve_fleet, args=(mission, speedup), daemon=True)
    process.start()
    return process


def end(process: BaseProcess) -> None:
    """End a child process, killing it if it does not end within ``END_S``."""
    if process.is_alive():
        process.terminate()
        process.join(END_S)
    if process.is_alive():
        process.kill()
        process.join(END_S)
