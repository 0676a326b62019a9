"""``gcs run MISSION.yaml``: the live mission over MAVLink (``--sim``: against the mock fleet).

Ctrl-C aborts safely: the planner brings every vehicle home and parks it, along
the ways that keep vehicles apart (as at the end of a mission); one not home in
time is sent to charge on its own (or held where it is if it cannot be); the
log is closed, and what was done is reported. A second Ctrl-C stops at once.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import dataclasses
import logging
import signal
import sys
from collections.abc import Sequence
from pathlib import Path

from rich.console import Console

from gcs.commands.keys import load_keys
from gcs.commands.plan import LOG_NAME, load, save_outputs
from gcs.commands.web_page import start_web, wants_web, web_view
from gcs.console import output_console
from gcs.errors import EXIT_FAILED, EXIT_INTERRUPTED, EXIT_OK, UsageError
from gcs.live.agent import AgentSettings
from gcs.live.display import LiveDisplay
from gcs.live.mission import run_live
from gcs.live.resume import ResumeError, ResumePoint, load_resume_point
from gcs.live.run import LiveOptions, MissionRefused, SimulatedFleet
from gcs.live.shared import Level
from gcs.log.foxglove_live import LiveView, LiveViewError
from gcs.log.mcap_log import LogSink, McapMissionLog
from gcs.log.mission_log import MissionLog, NullLog
from gcs.log.topics import SCHEMAS
from gcs.mission import Mission, on_one_link, with_connections
from gcs.mock_fleet import MockFleetRehearsal, SimFaults
from gcs.options.run import SIM_SPEEDUP
from gcs.outcome.report import print_summary
from gcs.outcome.result import RunResult
from gcs.preflight import check_range
from gcs.web.feed import LiveFeed
from gcs.web.server import WebView
from sitl_mock.connection import ConnectionStringError, mirror
from vehicles.endpoints import (
    EndpointKind,
    free_loopback_tcp_ports,
    free_loopback_udp_ports,
    parse_endpoint,
)
from vehicles.errors import EndpointError
from vehicles.keyfile import KeyFile

#: Connections ``--sim`` names when it moves them to free ports (the rest are counted).
SHOWN_PORTS = 6


def _numbers(text: str, count: int, option: str) -> tuple[float, ...]:
    parts = text.split(":")
    try:
        values = tuple(float(x) for x in parts)
    except ValueError:
        values = ()
    if len(values) != count:
        shape = {"--sim-sag": "T:PCT", "--sim-cut": "SYSID:T:D", "--sim-die": "SYSID:T"}[option]
        raise UsageError(f"{option}: expected {shape}, got {text!r}")
    return values


def options_from(args: argparse.Namespace, mission: Mission) -> LiveOptions:
    """The live mission's options of ``gcs run``, each checked for a one-line error."""
    speedup = args.speedup if args.speedup is not None else SIM_SPEEDUP if args.sim else 1.0
    if not speedup > 0:
        raise UsageError(f"--speedup must be positive, got {speedup}")
    if args.lost_after <= 0:
        raise UsageError(f"--lost-after must be positive, got {args.lost_after}")
    if args.sim:
        for v in mission.fleet:
            try:
                mirror(v.connection)  # the mock takes the other side of every connection
            except ConnectionStringError as exc:
                raise UsageError(f"--sim: vehicle {v.sysid}: {exc}") from None
    return LiveOptions(
        speedup=speedup,
        seed=args.seed,
        heartbeat_timeout_s=args.heartbeat_timeout,
        time_limit_s=args.time_limit,
        agent=dataclasses.replace(AgentSettings(), lost_after_s=args.lost_after),
        resume=_resume_point(args, mission),
        keys=keys_from(args, mission),
        allow_remote=args.allow_remote,
        follow_address=args.follow_address,
        forwards=tuple(forward_endpoints(args)),
        forward_commands=args.forward_commands,
    )


def sim_faults_from(args: argparse.Namespace, mission: Mission) -> SimFaults:
    """The faults ``--sim-*`` inject into the simulated fleet (none without ``--sim``)."""
    if not 0.0 <= args.sim_loss < 1.0:
        raise UsageError(f"--sim-loss must be in [0, 1), got {args.sim_loss}")
    if not 0.0 <= args.sim_battery_noise < 1.0:
        raise UsageError(f"--sim-battery-noise must be in [0, 1), got {args.sim_battery_noise}")
    sags = tuple(_numbers(s, 2, "--sim-sag") for s in args.sim_sag)
    if args.sim_latency < 0 or args.sim_jitter < 0:
        raise UsageError("--sim-latency and --sim-jitter must not be negative")
    sysids = {v.sysid for v in mission.fleet}
    cuts = []
    for text in args.sim_cut:
        sysid, at, duration = _numbers(text, 3, "--sim-cut")
        if int(sysid) not in sysids:
            raise UsageError(f"--sim-cut: no vehicle {int(sysid)} in the fleet")
        cuts.append((int(sysid), at, duration))
    deaths = []
    for text in args.sim_die:
        sysid, at = _numbers(text, 2, "--sim-die")
        if int(sysid) not in sysids:
            raise UsageError(f"--sim-die: no vehicle {int(sysid)} in the fleet")
        deaths.append((int(sysid), at))
    faults = SimFaults(
        loss=args.sim_loss,
        battery_noise=args.sim_battery_noise,
        sags=sags,  # type: ignore[arg-type]
        cuts=tuple(cuts),
        latency_s=args.sim_latency,
        jitter_s=args.sim_jitter,
        deaths=tuple(deaths),
    )
    if faults != SimFaults() and not args.sim:
        raise UsageError("--sim-* faults need --sim")
    return faults


def _resume_point(args: argparse.Namespace, mission: Mission) -> ResumePoint | None:
    """``--resume LOG``: where that log left the mission (never the log this run writes)."""
    if args.resume is None:
        return None
    if args.out is not None and (args.out / LOG_NAME).resolve() == args.resume.resolve():
        raise UsageError(
            f"--out {args.out} would overwrite the log being resumed: choose another folder"
        )
    try:
        return load_resume_point(args.resume, mission)
    except ResumeError as exc:
        raise UsageError(str(exc)) from exc


def forward_endpoints(args: argparse.Namespace) -> list[str]:
    """The ``--forward`` endpoints, checked now for a one-line error."""
    if args.forward_commands and not args.forward:
        raise UsageError("--forward-commands needs --forward ENDPOINT")
    for text in args.forward:
        try:
            parse_endpoint(text, allow_remote=args.allow_remote)
        except EndpointError as exc:
            raise UsageError(f"--forward: {exc}") from None
    return list(args.forward)


def keys_from(args: argparse.Namespace, mission: Mission) -> KeyFile | None:
    """The fleet's signing keys of ``--keys``: one for each vehicle it names."""
    if args.keys is None:
        return None
    return load_keys(args.keys, "gcs run", (v.sysid for v in mission.fleet))


def on_free_ports(mission: Mission) -> tuple[Mission, str]:
    """``--sim``: each connection of the mission moved to a loopback port of its kind that
    is free now, so that two simulated runs (or a SITL) never fight over a port; shared
    connections stay shared. Returns the mission and a line that names the ports."""
    endpoints = {
        c: parse_endpoint(c, allow_remote=True)
        for c in dict.fromkeys(v.connection for v in mission.fleet)
    }
    udp = [c for c, e in endpoints.items() if e.kind in (EndpointKind.UDP_IN, EndpointKind.UDP_OUT)]
    tcp = [c for c, e in endpoints.items() if e.kind in (EndpointKind.TCP, EndpointKind.TCP_IN)]
    moved = {
        c: f"{endpoints[c].kind.value}:127.0.0.1:{port}"
        for kinds, ports in ((udp, free_loopback_udp_ports), (tcp, free_loopback_tcp_ports))
        for c, port in zip(kinds, ports(len(kinds)), strict=True)
    }
    mission = with_connections(mission, moved)
    shown = list(moved.values())[:SHOWN_PORTS]
    more = f" and {len(moved) - len(shown)} more" if len(moved) > len(shown) else ""
    return mission, f"simulated vehicles on free loopback ports: {', '.join(shown)}{more}"


def open_live(port: int) -> LiveView:
    if not 0 <= port <= 65535:
        raise UsageError(f"--live: port {port} is not in 0-65535")
    try:
        return LiveView(port, SCHEMAS)
    except LiveViewError as exc:
        raise UsageError(f"--live: {exc}") from exc


def run(args: argparse.Namespace) -> int:
    mission = load(args)
    if args.one_link is not None:
        mission = on_one_link(mission, args.one_link)
    faults = sim_faults_from(args, mission)
    options = options_from(args, mission)
    if args.keep_ports and not args.sim:
        raise UsageError("--keep-ports needs --sim")
    ports = None
    if args.sim and not args.keep_ports:
        mission, ports = on_free_ports(mission)
    # The rehearsal's fleet is built here, apart from the mission, which is handed it.
    sim = MockFleetRehearsal(mission, faults, options.keys, options.seed) if args.sim else None
    if not logging.getLogger().handlers:
        # Library warnings (link lost...) reach the operator through the display instead.
        logging.getLogger().addHandler(logging.NullHandler())
    console = output_console(quiet=args.quiet)
    reach = check_range(mission)
    if reach.out_of_range:
        Console(stderr=True).print(f"[yellow]warning:[/] {reach.message()}")
    live, view, mission_log = _outputs(args, mission)
    if ports is not None:
        console.print(ports, markup=False, highlight=False)
    display = LiveDisplay(quiet=args.quiet, console=console)
    if isinstance(mission_log, McapMissionLog):
        mission_log.on_failure = lambda text: display.notify(
            f"{text}; the mission flies on (Ctrl-C brings every vehicle home)", Level.WARNING, None
        )
    try:
        result, interrupted = asyncio.run(_main(mission, options, mission_log, display, view, sim))
    except MissionRefused as exc:
        print(f"gcs run: {exc}", file=sys.stderr)  # one line, never wrapped
        return exc.exit_code
    finally:
        mission_log.close()
        if live is not None:
            live.close()
    return _report(args, result, interrupted, mission_log, console)


def _outputs(
    args: argparse.Namespace, mission: Mission
) -> tuple[LiveView | None, WebView | None, MissionLog]:
    """Where the run is shown and kept: the Foxglove view (``--live``), the map page
    (``--web``), and the log that feeds them (``--out``)."""
    live = open_live(args.live) if args.live is not None else None
    feed = LiveFeed() if wants_web(args) else None
    view = None if feed is None else web_view(args, mission.name, feed=feed)
    sinks: list[LogSink] = [s for s in (live, feed) if s is not None]
    try:
        mission_log: MissionLog = (
            open_log(mission, args.out, sinks) if args.out or sinks else NullLog()
        )
    except UsageError:
        if live is not None:
            live.close()
        raise
    if live is not None:
        # Also with --quiet: the operator asked for it, and needs the address.
        print(f"gcs run: Foxglove live view at {live.url}", file=sys.stderr, flush=True)
    return live, view, mission_log


def _report(
    args: argparse.Namespace,
    result: RunResult,
    interrupted: bool,
    mission_log: MissionLog,
    console: Console,
) -> int:
    """The summary and the outputs of a run that flew; its exit status."""
    console.print()
    print_summary(result, console)
    failure = getattr(mission_log, "failure", None)
    if failure is not None:
        print(f"gcs run: warning: {failure}; the mission flew on", file=sys.stderr)
    if args.out:
        save_outputs(result, args.out, console, "run")
    if interrupted:
        return EXIT_INTERRUPTED
    return EXIT_OK if result.complete else EXIT_FAILED


async def _main(
    mission: Mission,
    options: LiveOptions,
    mission_log: MissionLog,
    display: LiveDisplay,
    view: WebView | None,
    sim: SimulatedFleet | None,
) -> tuple[RunResult, bool]:
    abort = asyncio.Event()
    loop = asyncio.get_running_loop()
    with contextlib.suppress(NotImplementedError, RuntimeError, ValueError):
        # Only in the main thread; the first Ctrl-C aborts safely, a second one kills.
        loop.add_signal_handler(signal.SIGINT, _on_interrupt, loop, abort)
    try:
        async with contextlib.AsyncExitStack() as stack:
            if view is not None:
                await start_web(view, "run")
                stack.push_async_callback(view.close)
            result = await _fly_with_display(mission, options, mission_log, display, abort, sim)
    finally:
        with contextlib.suppress(NotImplementedError, RuntimeError, ValueError):
            loop.remove_signal_handler(signal.SIGINT)
    return result, abort.is_set()


async def _fly_with_display(
    mission: Mission,
    options: LiveOptions,
    mission_log: MissionLog,
    display: LiveDisplay,
    abort: asyncio.Event,
    sim: SimulatedFleet | None,
) -> RunResult:
    with display:
        return await run_live(
            mission, options, mission_log, display.notify, abort, display.attach, sim
        )


def _on_interrupt(loop: asyncio.AbstractEventLoop, abort: asyncio.Event) -> None:
    """First Ctrl-C: abort safely. The default handler is back for a second one."""
    abort.set()
    loop.remove_signal_handler(signal.SIGINT)


def open_log(mission: Mission, out: Path | None, sinks: Sequence[LogSink] = ()) -> McapMissionLog:
    """The live mission's MCAP log in ``out`` (created; None: no file), in this process:
    also handed to the ``sinks`` (live views) as it is written."""
    try:
        if out is not None:
            out.mkdir(parents=True, exist_ok=True)
        return McapMissionLog.for_mission(
            mission,
            None if out is None else out / LOG_NAME,
            free_cells=mission.reachable_cells,
            sinks=sinks,
        )
    except OSError as exc:
        raise UsageError(f"--out: cannot write to {out}: {exc.strerror}") from exc
