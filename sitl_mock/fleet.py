"""A fleet of mock vehicles in one asyncio loop, sharing one world and one clock.

Physics advances in fixed steps of simulated time (``step_s``), every
vehicle in system id order, so a run is repeatable from its seed: the only
thing that varies between runs is when the ground station's commands
arrive. A sped-up ``ScaledClock`` makes the physics, the battery and every
telemetry stream run that much faster.

Usage::

    configs = [MockVehicleConfig(1, VehicleSettings(VehicleKind.ROVER),
                                 LinkSettings("udpout:127.0.0.1:14550"))]
    async with MockFleet(configs, grid_map, geo, ScaledClock(10.0), seed=1) as fleet:
        print(fleet.gcs_connection(1))     # "udpin:127.0.0.1:14550"
        await stop_event.wait()
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import random
from collections.abc import Sequence
from dataclasses import dataclass, field
from types import TracebackType

from core.clocks import Clock, ScaledClock
from core.geo import GeoFrame
from sitl_mock.battery import BatterySettings
from sitl_mock.connection import LinkKind
from sitl_mock.endpoint import LinkSettings, VehicleEndpoint
from sitl_mock.faults import VehicleFaults
from sitl_mock.gridmap import GridMap
from sitl_mock.radio import Radio
from sitl_mock.transport import Transport, make_transport
from sitl_mock.vehicle import Vehicle, VehicleSettings
from sitl_mock.world import World

log = logging.getLogger(__name__)

#: The physics loop wakes at most this often in real seconds, whatever the speed-up.
_MIN_REAL_TICK_S = 0.01
#: Never catch up more than this many steps at once (after the process was stalled).
_MAX_CATCH_UP_STEPS = 10_000


@dataclass(frozen=True)
class MockVehicleConfig:
    """Everything about one mock vehicle."""

    sysid: int
    vehicle: VehicleSettings
    link: LinkSettings
    battery: BatterySettings = field(default_factory=BatterySettings)
    faults: VehicleFaults = field(default_factory=VehicleFaults)

    def __post_init__(self) -> None:
        if not 1 <= self.sysid <= 255:
            raise ValueError(f"sysid must be in 1..255, got {self.sysid}")


class MockFleet:
    def __init__(
        self,
        configs: Sequence[MockVehicleConfig],
        grid_map: GridMap,
        geo: GeoFrame,
        clock: Clock | None = None,
        seed: int = 0,
        step_s: float = 0.1,
    ) -> None:
        ids = [c.sysid for c in configs]
        if len(set(ids)) != len(ids):
            raise ValueError(f"system ids must be unique, got {ids}")
        if step_s <= 0:
            raise ValueError(f"step_s must be positive, got {step_s}")
        self.configs = {c.sysid: c for c in sorted(configs, key=lambda c: c.sysid)}
        self.world = World(grid_map, geo)
        self.clock: Clock = clock or ScaledClock(1.0)
        self.seed = seed
        self.step_s = step_s
        self.vehicles: dict[int, Vehicle] = {}
        self.endpoints: dict[int, VehicleEndpoint] = {}
        # Vehicles that name the same connection share one transport, as behind a radio.
        sharing: dict[str, list[int]] = {}
        for sysid, config in self.configs.items():
            sharing.setdefault(config.link.connection, []).append(sysid)
        for sysid, config in self.configs.items():
            vehicle = Vehicle(
                sysid,
                config.vehicle,
                config.battery,
                self.world,
                random.Random(f"{seed}/{sysid}/battery"),
            )
            self.vehicles[sysid] = vehicle
            self.endpoints[sysid] = VehicleEndpoint(
                vehicle,
                config.link,
                self.clock,
                config.faults,
                seed,
                own_transport=len(sharing[config.link.connection]) == 1,
            )
        #: One transport per connection several vehicles share, by system id.
        self._shared: dict[int, Transport] = {}
        for ids in sharing.values():
            if len(ids) > 1:
                first = self.endpoints[ids[0]]
                transport = make_transport(
                    first.endpoint, Radio({i: self.endpoints[i] for i in ids})
                )
                self._shared.update(dict.fromkeys(ids, transport))
        self._physics: asyncio.Task[None] | None = None
        self._started: list[VehicleEndpoint | Transport] = []

    # ------------------------------------------------------------------ lifecycle

    async def __aenter__(self) -> MockFleet:
        await self.start()
        return self

    async def __aexit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        await self.stop()

    async def start(self) -> None:
        try:
            for endpoint in self.endpoints.values():
                await endpoint.start()
                self._started.append(endpoint)
            for transport in dict.fromkeys(self._shared.values()):
                await transport.start()
                self._started.append(transport)
        except BaseException:
            await self.stop()
            raise
        self._physics = asyncio.get_running_loop().create_task(
            self._run_physics(), name="sitl-physics"
        )

    async def stop(self) -> None:
        """Stop the physics and close every socket; safe to call twice."""
        if self._physics is not None:
            self._physics.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._physics
            self._physics = None
        started, self._started = self._started, []
        for opened in reversed(started):
            await opened.close()

    # ------------------------------------------------------------------ physics

    def _tick_s(self) -> float:
        real_per_sim = self.clock.to_real(1.0)
        if real_per_sim <= 0:
            return self.step_s
        return max(self.step_s, _MIN_REAL_TICK_S / real_per_sim)

    async def _run_physics(self) -> None:
        simulated_until = self.clock.now()
        tick = self._tick_s()
        while True:
            await self.clock.sleep(tick)
            steps = int((self.clock.now() - simulated_until) / self.step_s + 1e-9)
            if steps > _MAX_CATCH_UP_STEPS:
                log.warning("physics fell %d steps behind; skipping ahead", steps)
                simulated_until = self.clock.now() - _MAX_CATCH_UP_STEPS * self.step_s
                steps = _MAX_CATCH_UP_STEPS
            for _ in range(steps):
                self.step_all(self.step_s)
            simulated_until += steps * self.step_s

    def step_all(self, dt_s: float) -> None:
        """One physics step of every vehicle, in system id order."""
        for vehicle in self.vehicles.values():
            vehicle.step(dt_s)

    # ------------------------------------------------------------------ addresses

    def connection(self, sysid: int) -> str:
        """The mock's own side of the vehicle's link, with the port actually bound."""
        endpoint = self.endpoints[sysid]
        e = endpoint.endpoint
        if e.kind is LinkKind.SERIAL or e.port or e.kind is LinkKind.UDPOUT:
            return str(e)
        shared = self._shared.get(sysid)
        port = endpoint.local_port if shared is None else shared.local_port
        return f"{e.kind.value}:{e.host}:{port}"

    def gcs_connection(self, sysid: int) -> str:
        """What a ground station should use to reach this vehicle (pymavlink spelling)."""
        e = self.endpoints[sysid].endpoint
        if e.kind is LinkKind.SERIAL:
            return "serial:<the other end of the serial link>"
        kind, host, port = self.connection(sysid).split(":")
        gcs_kind = {"udpout": "udpin", "udpin": "udpout", "tcpin": "tcp"}[kind]
        return f"{gcs_kind}:{host}:{port}"

    def shares_link(self, sysid: int) -> bool:
        """Whether the vehicle shares its connection with others of the fleet."""
        return sysid in self._shared
