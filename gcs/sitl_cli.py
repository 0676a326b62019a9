"""``sitl-mock MISSION.yaml``: run the mission's fleet as mock MAVLink vehicles on loopback.

The mission names each vehicle's connection from the ground station's side;
the mock takes the mirror side (``sitl_mock.connection.mirror``), so the
ground station connects with exactly what the mission says. With
``--tcp-base-port P`` every vehicle serves TCP instead, ArduPilot SITL
style: vehicle i (0-based) on port P + 10 i; the ground station connects
with ``tcp:127.0.0.1:P+10i``. Each vehicle's ground-station connection is
printed, one line per vehicle, then the fleet runs until Ctrl-C or SIGTERM.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import signal
import sys
from collections.abc import Sequence

from gcs.errors import EXIT_BAD_INPUT, EXIT_OK
from gcs.mission import Mission, MissionError, Sensing, load_mission
from sitl_mock.battery import BatterySettings
from sitl_mock.connection import ConnectionStringError, mirror
from sitl_mock.endpoint import LinkSettings
from sitl_mock.fleet import MockFleet, MockVehicleConfig
from sitl_mock.modes import VehicleKind
from sitl_mock.vehicle import VehicleSettings
from vehicles.clock import ScaledClock

PROG = "sitl-mock"
TCP_PORT_STEP = 10


def mock_fleet_configs(
    mission: Mission, tcp_base_port: int | None = None, startup_delay_s: float = 0.0
) -> list[MockVehicleConfig]:
    """One mock vehicle per vehicle of the mission, on the mirror side of its connection."""
    configs = []
    for i, spec in enumerate(mission.fleet):
        if tcp_base_port is None:
            connection = mirror(spec.connection)
        else:
            connection = f"tcpin:127.0.0.1:{tcp_base_port + TCP_PORT_STEP * i}"
        configs.append(
            MockVehicleConfig(
                sysid=spec.sysid,
                vehicle=VehicleSettings(
                    kind=VehicleKind(spec.type.value),
                    speed_m_s=spec.speed_m_s,
                    startup_delay_s=startup_delay_s,
                    start_cell=mission.charger,
                    range_sensing=spec.sensing is Sensing.RANGE,
                ),
                link=LinkSettings(connection),
                battery=BatterySettings(
                    capacity_mah=spec.battery_capacity_mah,
                    energy_per_m_pct=spec.energy_per_m_pct,
                    charge_rate_pct_s=spec.charge_rate_pct_s,
                ),
            )
        )
    return configs


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
        "--startup-delay",
        type=float,
        default=0.0,
        metavar="S",
        help="seconds after start during which arming and uploads are refused (ArduPilot: ~24)",
    )
    return parser


class _BadInput(ValueError):
    pass


def _prepare(args: argparse.Namespace) -> tuple[Mission, list[MockVehicleConfig]]:
    if not args.speedup > 0:
        raise _BadInput(f"--speedup must be positive, got {args.speedup}")
    if args.startup_delay < 0:
        raise _BadInput(f"--startup-delay must not be negative, got {args.startup_delay}")
    mission = load_mission(args.mission)
    if args.agents is not None:
        mission = mission.with_agents(args.agents)
    if args.tcp_base_port is not None:
        last = args.tcp_base_port + TCP_PORT_STEP * (len(mission.fleet) - 1)
        if not args.tcp_base_port > 0 or last > 65535:
            raise _BadInput(f"--tcp-base-port {args.tcp_base_port} gives ports out of range")
    return mission, mock_fleet_configs(mission, args.tcp_base_port, args.startup_delay)


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
            print(
                f"vehicle {config.sysid} {kind}: {fleet.gcs_connection(config.sysid)}", flush=True
            )
        await stop.wait()


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        mission, configs = _prepare(args)
        asyncio.run(_serve(mission, configs, args))
    except (MissionError, ConnectionStringError, _BadInput) as exc:
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
