"""The mission's fleet as mock ArduPilot-like vehicles (``sitl_mock``), for
``sitl-mock`` and ``gcs run --sim``: one vehicle configuration per vehicle of the
mission, on the mirror side of its connection, and the faults a rehearsal injects;
``MockFleetRehearsal``: that fleet as the live mission is handed it.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from core.clocks import Clock
from gcs.mission import Charging, Mission, Sensing, VehicleSpec
from sitl_mock.battery import BatterySag, BatterySettings
from sitl_mock.connection import mirror
from sitl_mock.drive import SKID_COAST_M_S2, DriveSettings, Steering
from sitl_mock.endpoint import LinkSettings
from sitl_mock.failsafe import FailsafeAction, GcsFailsafe
from sitl_mock.faults import LinkCut, LinkFaults, VehicleFaults
from sitl_mock.fleet import MockFleet, MockVehicleConfig
from sitl_mock.modes import VehicleKind
from sitl_mock.vehicle import VehicleSettings
from vehicles.keyfile import KeyFile

TCP_PORT_STEP = 10
#: A mission's fleet holds where it is when its ground station falls silent (ArduPilot
#: ships the GCS failsafe off): a restarted ground station finds every vehicle where its
#: log last saw it, in a known mode, and takes over (``gcs run --resume``). A mission in
#: AUTO (the way home) carries on.
FLEET_GCS_FAILSAFE = GcsFailsafe(FailsafeAction.HOLD)


#: Seconds of vehicle time until a mock vehicle's position estimate (ArduPilot SITL: about
#: 40 s; short so that a rehearsal starts at once, but long enough that the ground
#: station's wait for it is always exercised).
STARTUP_DELAY_S = 2.0


def drive_settings(spec: VehicleSpec) -> DriveSettings | None:
    """How the mock drives a rover of the mission: as ArduPilot Rover with that steering."""
    if spec.type.value != "rover":
        return None
    steering = Steering(spec.steering.value)
    if steering is Steering.SKID:
        return DriveSettings(steering=steering, coast_m_s2=SKID_COAST_M_S2)
    return DriveSettings(steering=steering)


def mock_fleet_configs(
    mission: Mission,
    tcp_base_port: int | None = None,
    startup_delay_s: float = 0.0,
    keys: KeyFile | None = None,
    *,
    gcs_failsafe: GcsFailsafe = FLEET_GCS_FAILSAFE,
    one_link: str | None = None,
) -> list[MockVehicleConfig]:
    """One mock vehicle per vehicle of the mission, on the mirror side of its connection
    (or all on ``one_link``, the mock's side); a vehicle with a key in ``keys`` signs
    what it sends and refuses unsigned commands."""
    configs = []
    for i, spec in enumerate(mission.fleet):
        if one_link is not None:
            connection = one_link
        elif tcp_base_port is None:
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
                    gcs_failsafe=gcs_failsafe,
                    drive=drive_settings(spec),
                ),
                link=LinkSettings(
                    connection, signing_key=None if keys is None else keys.keys.get(spec.sysid)
                ),
                battery=BatterySettings(
                    capacity_mah=spec.battery_capacity_mah,
                    energy_per_m_pct=spec.energy_per_m_pct,
                    charge_rate_pct_s=spec.charge_rate_pct_s,
                    # A smart battery reports its own charge; ArduPilot's monitor does not.
                    pad_charging=spec.charging is Charging.TELEMETRY,
                ),
            )
        )
    return configs


@dataclass(frozen=True)
class SimFaults:
    """Faults injected into the mock fleet of a ``--sim`` run (rehearsals and tests)."""

    #: Packet loss in each direction on every link.
    loss: float = 0.0
    latency_s: float = 0.0
    #: Every battery drain is multiplied by 1 + U(-noise, +noise).
    battery_noise: float = 0.0
    #: Sudden drops on every vehicle: (vehicle time s, percent).
    sags: tuple[tuple[float, float], ...] = ()
    #: Link cuts: (sysid, at s, duration s).
    cuts: tuple[tuple[int, float, float], ...] = ()
    #: Extra latency of each packet, uniform in [0, jitter_s].
    jitter_s: float = 0.0
    #: Vehicles that lose all power: (sysid, at s).
    deaths: tuple[tuple[int, float], ...] = ()


def sim_configs(
    mission: Mission, faults: SimFaults, keys: KeyFile | None = None
) -> list[MockVehicleConfig]:
    """The mission's mock fleet with the requested faults (and signing keys)."""
    configs = []
    for config in mock_fleet_configs(mission, keys=keys, startup_delay_s=STARTUP_DELAY_S):
        cuts = tuple(LinkCut(at, d) for sysid, at, d in faults.cuts if sysid == config.sysid)
        link = LinkFaults(
            loss_to_gcs=faults.loss,
            loss_from_gcs=faults.loss,
            latency_s=faults.latency_s,
            jitter_s=faults.jitter_s,
            cuts=cuts,
        )
        # Power lost: the whole charge gone at once (the vehicle dies and falls silent).
        deaths = tuple(BatterySag(at, 100.0) for s, at in faults.deaths if s == config.sysid)
        battery = dataclasses.replace(
            config.battery,
            noise_fraction=faults.battery_noise,
            sags=tuple(BatterySag(at, pct) for at, pct in faults.sags) + deaths,
        )
        configs.append(
            dataclasses.replace(config, battery=battery, faults=VehicleFaults(link=link))
        )
    return configs


class MockFleetRehearsal:
    """The mission's mock fleet with its faults, built by the command and handed to the
    live mission (``run_live(sim=...)``), which starts it on its own clock between the
    links that listen and those that dial, and stops it at the end."""

    def __init__(
        self, mission: Mission, faults: SimFaults, keys: KeyFile | None = None, seed: int = 0
    ) -> None:
        self.configs = sim_configs(mission, faults, keys)
        self.mission = mission
        self.seed = seed
        self._fleet: MockFleet | None = None

    async def start(self, clock: Clock) -> None:
        self._fleet = MockFleet(
            self.configs, self.mission.map, self.mission.geo, clock, seed=self.seed
        )
        await self._fleet.start()

    async def stop(self) -> None:
        if self._fleet is not None:
            await self._fleet.stop()
