"""``sitl-mock MISSION.yaml``: run the mission's fleet as mock MAVLink vehicles on loopback.

The mission names each vehicle's connection from the ground station's side;
the mock takes the mirror side (``sitl_mock.connection.mirror``), so the
ground station connects with exactly what the mission says. With
``--tcp-base-port P`` every vehicle serves TCP instead, ArduPilot SITL
style: vehicle i (0-based) on port P + 10 i; the ground station connects
with ``tcp:127.0.0.1:P+10i``. Each vehicle's ground-station connection is
printed, one line per vehicle, then the fleet runs until Ctrl-C or SIGTERM.
With ``--keys FILE`` (``vehicles.keyfile``) a vehicle with a key signs what it
sends and refuses unsigned or wrongly signed commands and replays.
An armed vehicle whose ground station falls silent holds where it is
(``--gcs-failsafe``, ``sitl_mock.failsafe``), ready for a restarted one.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import signal
import sys
from collections.abc import Sequence

from core.clocks import ScaledClock
from gcs.commands.keys import load_keys
from gcs.errors import EXIT_BAD_INPUT, EXIT_OK, UsageError
from gcs.mission import Mission, MissionError, load_mission
from gcs.mock_fleet import FLEET_GCS_FAILSAFE, STARTUP_DELAY_S, TCP_PORT_STEP, mock_fleet_configs
from sitl_mock.connection import ConnectionStringError, parse_mock_side
from sitl_mock.failsafe import FailsafeAction, GcsFailsafe
from sitl_mock.fleet import MockFleet, MockVehicleConfig

PROG = "sitl-mock"


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog=PROG,
        description="Run a mission's fleet as mock ArduPilot vehicles over MAVLink on loopback.",
    )
    parser.add_argument("mission", help="mission YAML file")
    parser.add_argument(
        "--speedup", type=float, default=1.0, help="simulated seconds per real second (default 1)"
    )
    parser.add_argument("--agents", type=int, help="override the fleet size of the mission")
    parser.add_argument("--seed", type=int, default=0, help="seed of every random process")
    parser.add_argument(
        "--tcp-base-port",
        type=int,
        metavar="P",
        help="serve TCP like ArduPilot SITL: vehicle i on port P + 10 i",
    )
    parser.add_argument(
        "--one-link",
        metavar="CONNECTION",
        help="serve the whole fleet through this one connection, as behind one radio or "
        "router (the mock's side: udpout:HOST:PORT sends to a ground station listening "
        "there, udpin:/tcpin: listen, serial:DEVICE:BAUD or /dev/ttyX,BAUD is a serial "
        "device); each vehicle answers only what is addressed to it",
    )
    parser.add_argument(
        "--startup-delay",
        type=float,
        default=STARTUP_DELAY_S,
        metavar="S",
        help="seconds of vehicle time until each vehicle's position estimate: before it, it "
        "reports latitude and longitude 0, 0 and no GPS fix, and refuses arming, modes and "
        f"uploads (ArduPilot SITL: about 40; default {STARTUP_DELAY_S:g})",
    )
    parser.add_argument(
        "--gcs-failsafe",
        choices=[a.value for a in FailsafeAction],
        default=FLEET_GCS_FAILSAFE.action.value,
        help="what an armed vehicle does when no ground station heartbeat came for the "
        "timeout: hold where it is, return to launch, or nothing; a mission flown in AUTO "
        f"carries on (default {FLEET_GCS_FAILSAFE.action.value})",
    )
    parser.add_argument(
        "--gcs-failsafe-timeout",
        type=float,
        default=FLEET_GCS_FAILSAFE.timeout_s,
        metavar="S",
        help="seconds of vehicle time without a ground station heartbeat before the "
        f"failsafe (ArduPilot FS_GCS_TIMEOUT; default {FLEET_GCS_FAILSAFE.timeout_s:g})",
    )
    parser.add_argument(
        "--keys",
        metavar="FILE",
        help="MAVLink 2 signing keys by system id (YAML, see README): a vehicle with a key "
        "signs what it sends and refuses unsigned or wrongly signed commands and replays",
    )
    return parser


class _BadInput(ValueError):
    pass


def _prepare(args: argparse.Namespace) -> tuple[Mission, list[MockVehicleConfig]]:
    if not args.speedup > 0:
        raise _BadInput(f"--speedup must be positive, got {args.speedup}")
    if args.startup_delay < 0:
        raise _BadInput(f"--startup-delay must not be negative, got {args.startup_delay}")
    if not args.gcs_failsafe_timeout > 0:
        raise _BadInput(f"--gcs-failsafe-timeout must be positive, got {args.gcs_failsafe_timeout}")
    failsafe = GcsFailsafe(FailsafeAction(args.gcs_failsafe), args.gcs_failsafe_timeout)
    mission = load_mission(args.mission)
    if args.agents is not None:
        mission = mission.with_agents(args.agents)
    if args.tcp_base_port is not None and args.one_link is not None:
        raise _BadInput("--tcp-base-port and --one-link exclude each other")
    if args.one_link is not None:
        parse_mock_side(args.one_link)  # a clear error now, not when the fleet starts
    if args.tcp_base_port is not None:
        last = args.tcp_base_port + TCP_PORT_STEP * (len(mission.fleet) - 1)
        if not args.tcp_base_port > 0 or last > 65535:
            raise _BadInput(f"--tcp-base-port {args.tcp_base_port} gives ports out of range")
    keys = None
    if args.keys is not None:
        keys = load_keys(args.keys, PROG, (v.sysid for v in mission.fleet))
    return mission, mock_fleet_configs(
        mission,
        args.tcp_base_port,
        args.startup_delay,
        keys,
        gcs_failsafe=failsafe,
        one_link=args.one_link,
    )


async def _serve(
    mission: Mission, configs: list[MockVehicleConfig], args: argparse.Namespace
) -> None:
    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    for sig in (signal.SIGINT, signal.SIGTERM):
        with contextlib.suppress(NotImplementedError):
            loop.add_signal_handler(sig, stop.set)
    fleet = MockFleet(configs, mission.map, mission.geo, ScaledClock(args.speedup), seed=args.seed)
    async with fleet:
        print(
            f"{PROG}: {len(configs)} vehicle(s) of {mission.name}, speedup {args.speedup:g}; "
            "Ctrl-C to stop",
            flush=True,
        )
        for config in configs:
            kind = config.vehicle.kind.value
            signed = " (signed)" if config.link.signing_key is not None else ""
            shared = " (shared)" if fleet.shares_link(config.sysid) else ""
            print(
                f"vehicle {config.sysid} {kind}: {fleet.gcs_connection(config.sysid)}"
                f"{shared}{signed}",
                flush=True,
            )
        await stop.wait()


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        mission, configs = _prepare(args)
        asyncio.run(_serve(mission, configs, args))
    except (MissionError, UsageError, ConnectionStringError, _BadInput) as exc:
        print(f"{PROG}: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except OSError as exc:  # a port already in use, for instance
        print(f"{PROG}: cannot open a vehicle's link: {exc.strerror or exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        pass
    return EXIT_OK


if __name__ == "__main__":
    sys.exit(main())
