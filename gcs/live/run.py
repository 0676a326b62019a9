"""What a live mission is given and what it shows while it runs: its options, the
simulated fleet a rehearsal hands in, the run's state for the display, and the
refusal that stops a mission before it starts."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol

from core.clocks import Clock
from gcs.errors import EXIT_FAILED
from gcs.live.agent import AgentSettings
from gcs.live.energy import EnergySettings
from gcs.live.resume import ResumePoint
from gcs.live.shared import SharedPlanner, VehicleView
from gcs.mission import Mission
from vehicles.keyfile import KeyFile
from vehicles.link import RejectedFrames, VehicleLink, rejected_frames
from vehicles.network import MavlinkNetwork


class MissionRefused(Exception):
    """The fleet is not fit to start; ``exit_code`` says whose fault (input or vehicles)."""

    def __init__(self, message: str, exit_code: int = EXIT_FAILED) -> None:
        super().__init__(message)
        self.exit_code = exit_code


class SimulatedFleet(Protocol):
    """Vehicles simulated in this process for a rehearsal (``gcs run --sim``): built with
    their faults by the caller (``gcs.mock_fleet.MockFleetRehearsal``), started by the
    mission on its own clock once the links that listen are open, stopped at its end."""

    async def start(self, clock: Clock) -> None: ...

    async def stop(self) -> None: ...


@dataclass(frozen=True)
class LiveOptions:
    """How the live mission runs: its timing, what the operator asked for, and how
    each vehicle is flown and its energy estimated."""

    #: Simulated seconds per real second of the vehicles' clock (the mock's, or a SITL's).
    speedup: float = 1.0
    seed: int = 0
    #: Real seconds to wait for every vehicle's first heartbeat.
    heartbeat_timeout_s: float = 30.0
    #: Mission seconds to wait for position, battery and range telemetry at the start.
    telemetry_timeout_s: float = 10.0
    #: Mission seconds a vehicle may take to be ready (GPS fix, position estimate, modes):
    #: ArduPilot SITL takes about 40 s after boot.
    ready_timeout_s: float = 180.0
    #: A link is "lost" after this many mission seconds without a heartbeat.
    link_lost_after_s: float = 3.0
    #: Stop (and send everyone home) after this many mission seconds; None: no limit.
    time_limit_s: float | None = None
    #: Mission seconds given to the fleet to get home under the planner after an
    #: abort (then as much again to a vehicle sent home on its own).
    abort_return_s: float = 300.0
    agent: AgentSettings = field(default_factory=AgentSettings)
    #: Carry on from an earlier run's log: its map, coverage and BTPs, the vehicles
    #: taken over wherever they are (``gcs run --resume``).
    resume: ResumePoint | None = None
    #: Connections to hosts other than this machine (loopback only by default).
    allow_remote: bool = False
    #: ``udpin``: follow a vehicle whose address changes, instead of staying with the
    #: address it first spoke from (``--follow-address``).
    follow_address: bool = False
    #: MAVLink 2 signing keys (``gcs run --keys``): a vehicle with a key is signed both
    #: ways and its unsigned frames are refused.
    keys: KeyFile | None = field(default=None, repr=False)
    #: Other ground stations that get a copy of every vehicle frame (``--forward``).
    forwards: tuple[str, ...] = ()
    #: Pass what those stations send on to the vehicles (``--forward-commands``).
    forward_commands: bool = False
    energy: EnergySettings = field(default_factory=EnergySettings)


@dataclass
class LiveRun:
    """What the display and the command look at while the mission runs."""

    mission: Mission
    clock: Clock
    views: dict[int, VehicleView]
    planner: SharedPlanner | None = None
    started_at: float | None = None
    aborted: bool = False
    #: The open links (the display shows what each one rejected).
    links: dict[int, VehicleLink] = field(default_factory=dict)
    #: The connections the links share (what each threw away is shown too).
    network: MavlinkNetwork | None = None
    #: The vehicles are the rehearsal's, simulated in this process on loopback.
    simulated: bool = False

    @property
    def elapsed_s(self) -> float:
        return 0.0 if self.started_at is None else self.clock.now() - self.started_at

    @property
    def rejected(self) -> RejectedFrames:
        """Every frame thrown away: by the links, and by the connections they share."""
        total = rejected_frames(self.links.values())
        return total if self.network is None else total + self.network.rejected
