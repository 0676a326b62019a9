"""``gcs run`` options."""

from __future__ import annotations

import argparse
from pathlib import Path

from gcs.log.foxglove_live import DEFAULT_PORT
from gcs.log.foxglove_live import HOST as LIVE_HOST
from gcs.options import runs
from gcs.options.web import add_web_options

#: Mission seconds a vehicle's link may be down before it is declared lost.
LOST_AFTER_S = 30.0
#: How much faster than real time the mock fleet of ``--sim`` runs, unless ``--speedup``.
SIM_SPEEDUP = 10.0


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    p = sub.add_parser(
        "run",
        help="run the mission live over MAVLink (--sim: against the built-in mock fleet)",
        description=(
            "Connect to every vehicle of the mission, check it is ready on the charger, and "
            "explore and cover the area with the staying alive policy, each vehicle at its own "
            "pace; every vehicle comes back to charge before its battery runs out and goes home "
            "at the end. Ctrl-C brings every vehicle home and parks it (a second Ctrl-C stops "
            "the station at once). Exit status 0 when coverage is complete with no vehicle "
            "lost, 1 otherwise, 2 on bad input, 130 after Ctrl-C."
        ),
    )
    p.add_argument("mission", type=Path, help="mission file (YAML)")
    p.add_argument("--agents", type=int, metavar="N", help="override the fleet size")
    p.add_argument(
        "--sim",
        action="store_true",
        help="start the mission's mock fleet in this process first (loopback MAVLink)",
    )
    p.add_argument(
        "--keep-ports",
        action="store_true",
        help="with --sim: keep the mission's own connections (by default --sim moves them to "
        "loopback ports free at the start, and prints them), e.g. to point another tool at them",
    )
    p.add_argument(
        "--speedup",
        type=float,
        metavar="X",
        help="simulated seconds per real second of the vehicles' clock (a SITL speed-up); "
        f"default {SIM_SPEEDUP:g} with --sim, 1 otherwise",
    )
    p.add_argument(
        "--out", type=Path, help="write report.json, PNG figures and mission.mcap to this folder"
    )
    p.add_argument("--quiet", action="store_true", help="no live display; print only errors")
    p.add_argument(
        "--live",
        type=int,
        nargs="?",
        const=DEFAULT_PORT,
        metavar="PORT",
        help="serve the mission as it happens to Foxglove (open connection: Foxglove "
        f"WebSocket, ws://{LIVE_HOST}:PORT; default port {DEFAULT_PORT}): the map, vehicles, "
        "tracks, backtracking points, batteries and events of the log, on loopback",
    )
    add_web_options(p, "the mission as it happens")
    p.add_argument(
        "--allow-remote",
        action="store_true",
        help="allow vehicle connections to other hosts, or listening on every interface "
        "(udpin:0.0.0.0:P); loopback only by default",
    )
    p.add_argument(
        "--follow-address",
        action="store_true",
        help="on a udpin connection, follow a vehicle that starts speaking from another "
        "address (a router restarted); by default the station stays with the address the "
        "vehicle first spoke from and ignores, counts and shows frames that claim to be it "
        "from elsewhere (an impostor; signing with --keys is the real protection)",
    )
    p.add_argument(
        "--one-link",
        metavar="CONNECTION",
        help="reach the whole fleet through this one connection instead of each vehicle's "
        "own (one radio or router for all: e.g. serial:/dev/ttyUSB0:57600 or "
        "udpin:127.0.0.1:14550); vehicles are told apart by system id",
    )
    p.add_argument(
        "--forward",
        action="append",
        default=[],
        metavar="ENDPOINT",
        help="copy every frame the vehicles send to another ground station, as MAVProxy's "
        "--out does (repeatable): e.g. udpout:127.0.0.1:14550 for QGroundControl on this "
        "machine; signed frames stay signed. What it sends back is dropped unless "
        "--forward-commands",
    )
    p.add_argument(
        "--forward-commands",
        action="store_true",
        help="pass what the --forward stations send on to the vehicles (commands, missions); "
        "by default they only watch",
    )
    p.add_argument(
        "--resume",
        type=Path,
        metavar="LOG.mcap",
        help="carry on a mission whose ground station stopped (crashed, killed, aborted) from "
        "its log: what it mapped and covered is not covered again, and every vehicle is taken "
        "over where it is; write the new log to another --out folder",
    )
    p.add_argument(
        "--keys",
        type=Path,
        metavar="FILE",
        help="MAVLink 2 signing keys by system id (YAML, see README): a vehicle with a key is "
        "signed both ways and its unsigned frames are refused; with --sim its mock too",
    )
    p.add_argument("--seed", type=int, default=0, help="seed for the planner and the mock fleet")
    p.add_argument(
        "--lost-after",
        type=float,
        default=LOST_AFTER_S,
        metavar="S",
        help="declare a vehicle lost after its link has been down this many mission seconds "
        "(default %(default)g)",
    )
    p.add_argument(
        "--time-limit",
        type=float,
        metavar="S",
        help="abort (everyone goes to charge) after this many mission seconds",
    )
    p.add_argument(
        "--heartbeat-timeout",
        type=float,
        default=30.0,
        metavar="S",
        help="real seconds to wait for every vehicle's first heartbeat (default 30)",
    )
    faults = p.add_argument_group("faults injected into the mock fleet (with --sim)")
    faults.add_argument("--sim-loss", type=float, default=0.0, metavar="P", help="packet loss")
    faults.add_argument(
        "--sim-battery-noise",
        type=float,
        default=0.0,
        metavar="F",
        help="every battery drain is multiplied by 1 + U(-F, F)",
    )
    faults.add_argument(
        "--sim-sag",
        action="append",
        default=[],
        metavar="T:PCT",
        help="every vehicle loses PCT %% of charge at T s of its time (repeatable)",
    )
    faults.add_argument(
        "--sim-latency", type=float, default=0.0, metavar="S", help="latency each way (s)"
    )
    faults.add_argument(
        "--sim-jitter",
        type=float,
        default=0.0,
        metavar="S",
        help="extra latency of each packet, uniform in [0, S] s (packets may overtake)",
    )
    faults.add_argument(
        "--sim-die",
        action="append",
        default=[],
        metavar="SYSID:T",
        help="vehicle SYSID loses all power at T s of its time and falls silent (repeatable)",
    )
    faults.add_argument(
        "--sim-cut",
        action="append",
        default=[],
        metavar="SYSID:T:D",
        help="vehicle SYSID's link carries nothing from T s for D s (repeatable)",
    )
    runs(p, "gcs.commands.run:run")
