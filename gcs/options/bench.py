"""``gcs bench`` options: the paper's tables, MAVLink, scaling, planner settings, faults."""

from __future__ import annotations

import argparse
import os
from pathlib import Path

from gcs.bench.common import json_path
from gcs.options import runs
from gcs.options.run import LOST_AFTER_S
from vehicles.keyfile import MAX_SYSID

MISSIONS = Path(__file__).resolve().parents[2] / "missions"
#: The fleet sizes of the paper's Table 1.
PAPER_AGENTS = (1, 3, 5, 7, 9, 11)

#: ``gcs bench mavlink``
MAVLINK_MISSION = MISSIONS / "scenario1.yaml"
MAVLINK_ITEMS = 500
MAVLINK_LOSS_PCT = (0.0, 30.0)
MAVLINK_TIMERS = ("loopback", "spec")
MAVLINK_WINDOW_S = 4.0
#: The physics steps every 0.1 s and catches up by whole steps, so up to two steps
#: (200 ms) behind the clock is its normal state; more means it is late.
MAVLINK_MAX_LAG_MS = 300.0

#: ``gcs bench perf``: the generated map kinds (``gcs.generated_missions.PERF_KINDS``).
PERF_KINDS = ("rooms", "building", "open")
#: How the live runs reach their vehicles: a UDP port each, or one for the fleet.
PERF_LINKS = ("own", "shared")
#: Event-loop lateness (99th percentile) above which a live run fell behind.
LOOP_BEHIND_MS = 100.0
#: Mission seconds after which a live case is stopped (everyone sent home).
LIVE_TIME_LIMIT_S = 3600.0

#: ``gcs bench faults``
FAULTS_MISSION = MISSIONS / "demo.yaml"
#: Mission seconds into the run at which timed faults strike (by default).
STRIKE_S = 60.0
SHORT_CUT_S = 8.0
LONG_CUT_S = 3 * LOST_AFTER_S

PAPER = """\
Run scenario1 with 1, 3, 5, 7, 9 and 11 agents and bob30 with 4 agents (no battery
limit), and print our figures beside the paper's Table 1 and Table 2, with ratios
that let maps of slightly different size compare fairly: total path / (free - 1),
makespan / ceil((free - 1) / agents), iterations x agents / free.
"""

MAVLINK = f"""\
How fast our link and our mock move missions, and how many vehicles one mock
process keeps up with. Both over real MAVLink 2 on loopback.

1. Mission transfer: the station's link uploads a mission of --items items to one
   mock vehicle and downloads it again, once per --loss figure (percent of packets
   dropped each way). It reports the time and what the loss cost in repeats: items
   sent again, requests the vehicle repeated, requests the station repeated. With
   loss, the protocol's timers decide the time: --timers loopback (default) uses
   timers fit for a loopback round trip, --timers spec the MAVLink defaults and
   ArduPilot's 1 s re-request (minutes for 500 items at 30 %).
2. Telemetry capacity: fleets of 1, 2, 4 ... mock vehicles in one process, every
   default stream on, each sending to its own UDP socket here. A fleet keeps up while
   every vehicle achieves at least 90 % of its configured message rate and its
   physics stays within --max-lag-ms of the clock (95th percentile). The ramp stops
   at the first fleet that falls behind, or at {MAX_SYSID} vehicles.
"""

PERF = f"""\
How the planner and the live ground station scale.

1. Offline planner: generated maps of every --sizes side with every --agents count:
   rooms (a maze of rooms, one door in every wall: ways about 7 times the Manhattan
   distance), building (rooms off a grid of halls, like an office floor) and open
   (a field with scattered obstacles). The battery is set so that a round trip to
   the farthest cell costs two thirds of the usable charge. Each case runs in a
   process of its own (its peak memory is that process's), after the planner is
   compiled, and is stopped after --case-limit seconds.
2. Live ground station: 'gcs run --sim' in this process with 1, 16 and 64 vehicles
   on an open map sized to the fleet, each vehicle on a UDP port of its own, or
   (--links shared, both) the whole fleet on one port as behind one radio: decision
   latency (arrival and sensing in, the next target out), event-loop lateness,
   messages read per second, CPU per vehicle. A run falls behind when its event
   loop is more than {LOOP_BEHIND_MS:g} ms late at the 99th percentile.
3. The scaling goals (1000x1000 cells with 50 agents in under 60 s and 2 GB; 64 live
   vehicles under 20 ms decision latency at the 99th percentile), met or not, when
   the cases that measure them ran.

First it times a fixed workload (the machine's pace on the day), as shared machines
drift by a factor of three. Figures only, never pass or fail on time: the exit
status is 1 only when a case did not finish, did not cover its map or lost a vehicle.
"""

PLANS = """\
Run the planner with its default settings (or --base) and with the settings
changed by --set, on every map of --kinds x --sizes x --seeds with every fleet of
--agents, and print each run's path per free cell and its steps, the variant's
ratios to the base, whether the plan is the same cell for cell, and the geometric
mean of the ratios per map kind, size and fleet and over all runs. The battery is
set as in 'gcs bench perf', or unlimited (--battery none).

The paper's Table 2 and maps of its kind (bob30 is seed 9):
  gcs bench plans --kinds bars --sizes 30 --agents 4 --seeds 1-37 --battery none

A crowd's plan is chaotic (one different decision early changes everything after
it), so judge a change on the means of many maps, never on one. The exit status is
1 when a run failed, did not cover its map or lost a vehicle.
"""

FAULTS = """\
The fault campaign: one live mission per fault. Every row runs the real
'gcs run --sim' in a process of its own (seeded, stopped after --case-limit wall
seconds) with one fault injected into the mock fleet, then reads what it left:
the report (coverage, vehicles lost, the lowest battery any vehicle reported on
arrival against the reserve) and the MCAP log (does it rebuild the same report?).
The last row kills the ground station with SIGKILL mid-mission; a second ground
station resumes from the first one's log ('gcs run --resume'), and the row says how
much mission time the log had lost.

A fault that takes a vehicle away for good (a cut longer than the lost-vehicle
timeout, a vehicle dying) must end with that vehicle declared lost and the others
covering its share: such rows expect one vehicle lost (exit status 1 is then the
right answer).
"""


def _raw(
    which: argparse._SubParsersAction, name: str, help: str, text: str
) -> argparse.ArgumentParser:  # type: ignore[type-arg]
    return which.add_parser(  # type: ignore[no-any-return]
        name, help=help, description=text, formatter_class=argparse.RawDescriptionHelpFormatter
    )


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    p = sub.add_parser(
        "bench",
        help="benchmarks: the paper's tables, MAVLink transfer, scaling, settings, faults",
        description="Benchmarks that measure and print figures.",
    )
    which = p.add_subparsers(dest="bench", metavar="BENCH", required=True)
    _paper(
        _raw(
            which,
            "paper",
            "the paper's Table 1 (scenario1, 1-11 agents) and Table 2 (bob30, 4 agents)",
            PAPER,
        )
    )
    _mavlink(
        _raw(
            which,
            "mavlink",
            "mission upload/download over loopback with loss; vehicles one mock process serves",
            MAVLINK,
        )
    )
    _perf(
        _raw(
            which,
            "perf",
            "planner scaling (map size x agents) and live ground-station load (vehicles)",
            PERF,
        )
    )
    _plans(
        _raw(which, "plans", "compare planner settings (path, steps) on many generated maps", PLANS)
    )
    _faults(
        _raw(
            which,
            "faults",
            "the fault campaign: loss, latency, cuts, a vehicle dying, battery, GCS killed",
            FAULTS,
        )
    )


def _paper(p: argparse.ArgumentParser) -> None:
    p.add_argument("--missions", type=Path, default=MISSIONS, help="folder with the missions")
    p.add_argument(
        "--agents", type=int, nargs="+", default=list(PAPER_AGENTS), help="Table 1 fleet sizes"
    )
    _sweep_options(p)
    p.add_argument("--json", type=json_path, help="also write the figures as JSON to this file")
    runs(p, "gcs.bench.paper:run_paper")


def _mavlink(p: argparse.ArgumentParser) -> None:
    p.add_argument("--mission", type=Path, default=MAVLINK_MISSION, help="mission file (map)")
    p.add_argument("--items", type=int, default=MAVLINK_ITEMS, help="mission items (with home)")
    p.add_argument(
        "--loss",
        type=float,
        nargs="+",
        default=list(MAVLINK_LOSS_PCT),
        metavar="PCT",
        help="packet loss in percent, each way (default 0 30)",
    )
    p.add_argument(
        "--max-vehicles",
        type=int,
        default=MAX_SYSID,
        help=f"largest fleet of the ramp (at most {MAX_SYSID}, the MAVLink system ids)",
    )
    p.add_argument("--timers", choices=MAVLINK_TIMERS, default="loopback", help="mission timers")
    p.add_argument(
        "--speedup",
        type=float,
        default=1.0,
        help="speed-up of the fleets' clock: every stream that much faster (default 1)",
    )
    p.add_argument("--window", type=float, default=MAVLINK_WINDOW_S, help="seconds counted")
    p.add_argument(
        "--max-lag-ms",
        type=float,
        metavar="MS",
        default=MAVLINK_MAX_LAG_MS,
        help="physics lag (95th percentile) above which a fleet falls behind",
    )
    p.add_argument("--json", type=json_path, help="also write the figures as JSON to this file")
    runs(p, "gcs.bench.mavlink:run_mavlink_command")


def _perf(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--sizes", default="100,300,1000", help="map sides in cells (default 100,300,1000)"
    )
    p.add_argument(
        "--kinds",
        default=",".join(PERF_KINDS),
        help=f"map kinds (default {','.join(PERF_KINDS)})",
    )
    p.add_argument("--agents", default="1,10,50", help="fleet sizes (default 1,10,50)")
    p.add_argument(
        "--case-limit",
        type=float,
        default=600.0,
        metavar="S",
        help="stop a planner case after S wall seconds (default 600)",
    )
    p.add_argument(
        "--log",
        choices=["off", "on", "both"],
        default="both",
        help="run each planner case without a mission log, with one (as gcs plan --out "
        "writes), or both side by side, and compare (default both)",
    )
    p.add_argument("--vehicles", default="1,16,64", help="live fleet sizes (default 1,16,64)")
    p.add_argument(
        "--live-speedup",
        type=float,
        default=2.0,
        metavar="X",
        help="the mock fleet's speed-up in the live runs (default 2)",
    )
    p.add_argument(
        "--set",
        dest="changes",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="a planner setting for the planner cases, e.g. far_transit_recheck=1 (repeat for "
        "several; default: the planner's defaults)",
    )
    p.add_argument(
        "--links",
        choices=[*PERF_LINKS, "both"],
        default="own",
        help="live runs with each vehicle on a UDP port of its own, the whole fleet on one "
        "port (as behind one radio), or both side by side (default own)",
    )
    p.add_argument(
        "--web-clients",
        type=int,
        default=0,
        metavar="N",
        help="fly each live case a second time with its web page (gcs run --web) read by N "
        "clients in another process, and compare the decision latency (default 0: not)",
    )
    p.add_argument(
        "--live-time-limit",
        type=float,
        default=LIVE_TIME_LIMIT_S,
        metavar="S",
        help="mission seconds after which a live case sends every vehicle home (default "
        f"{LIVE_TIME_LIMIT_S:g})",
    )
    p.add_argument(
        "--repeat",
        type=int,
        default=1,
        metavar="N",
        help="fly each live case N times (with --web-clients: with and without the page, "
        "alternately; the medians are compared) (default 1)",
    )
    p.add_argument("--skip-planner", action="store_true", help="only the live runs")
    p.add_argument("--skip-live", action="store_true", help="only the planner cases")
    p.add_argument("--json", type=json_path, help="also write the figures to this JSON file")
    runs(p, "gcs.bench.perf:run_perf")


def _sweep_options(p: argparse.ArgumentParser) -> None:
    """Where a sweep's runs go (gcs.bench.sweeps)."""
    p.add_argument(
        "--jobs",
        type=int,
        default=os.cpu_count() or 1,
        help="runs at once: worker processes of a local Dask cluster on this machine, "
        "listening on loopback only; 1: one after another in this process "
        "(default: one per core)",
    )
    p.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="run on an existing Dask cluster instead, whose workers run this same project "
        "(its scheduler's address, e.g. tcp://127.0.0.1:8786; --jobs is then ignored)",
    )


def _plans(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--kinds",
        default="rooms,caves,open",
        help="map kinds: rooms, caves, open, bars (the paper's Table 2: 13 bars of 4-9 "
        "cells per 30x30), branching (combs of corridors off a trunk) (default "
        "rooms,caves,open)",
    )
    p.add_argument("--sizes", default="100", help="map sides in cells (default 100)")
    p.add_argument("--agents", default="20,50", help="fleet sizes (default 20,50)")
    p.add_argument(
        "--seeds", default="1,2,3,4", help="map seeds, e.g. 1,2,3 or 1-37 (default 1,2,3,4)"
    )
    p.add_argument(
        "--battery",
        choices=("limited", "none"),
        default="limited",
        help="limited: a round trip to the farthest cell costs two thirds of the usable "
        "charge, as in 'gcs bench perf'; none: no battery limit, as the paper's Table 2 "
        "(default limited)",
    )
    p.add_argument(
        "--set",
        dest="changes",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="a planner setting of the variant (repeat for several); none: the base alone",
    )
    p.add_argument(
        "--base",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="a planner setting of the base (default: the planner's defaults)",
    )
    _sweep_options(p)
    p.add_argument(
        "--json", type=json_path, help="also write every run's figures to this JSON file"
    )
    runs(p, "gcs.bench.plans:run_plans")


def _faults(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--mission",
        type=Path,
        default=FAULTS_MISSION,
        help="the mission (default missions/demo.yaml)",
    )
    p.add_argument("--seed", type=int, default=1, help="seed of the faults and the planner")
    p.add_argument(
        "--strike",
        type=float,
        default=STRIKE_S,
        metavar="S",
        help=f"mission seconds at which cuts and the death strike (default {STRIKE_S:g})",
    )
    p.add_argument(
        "--speedup", type=float, default=10.0, help="the mock fleet's speed-up (default 10)"
    )
    p.add_argument(
        "--case-limit",
        type=float,
        default=300.0,
        metavar="S",
        help="stop a row after S wall seconds (default 300)",
    )
    p.add_argument(
        "--only", metavar="N,...", help="run only these rows (1-based numbers of the table)"
    )
    p.add_argument("--json", type=json_path, help="also write the table to this JSON file")
    runs(p, "gcs.bench.faults:run_faults")
