"""MAVSDK 4 (an independent MAVLink implementation) as the ground station against our mock.

MAVSDK 4 is the native binding (no gRPC server, so no server port to pick):
it listens with ``udpin://127.0.0.1:P`` and the mock sends to P (``udpout``).
"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import AsyncIterator
from typing import TypeVar

import numpy as np
import pytest

pytest.importorskip("mavsdk")

from mavsdk.asyncio.mavsdk import Configuration, Mavsdk
from mavsdk.asyncio.plugins.action import ActionAsync
from mavsdk.asyncio.plugins.mission_raw import MissionRawAsync
from mavsdk.asyncio.plugins.telemetry import TelemetryAsync
from mavsdk.asyncio.system import System
from mavsdk.component_type import ComponentType
from mavsdk.plugins.mission_raw import MissionItem as SdkItem
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from core.clocks import ScaledClock
from core.geo import GeoFrame
from sitl_mock.endpoint import LinkSettings
from sitl_mock.fleet import MockFleet, MockVehicleConfig
from sitl_mock.gridmap import GridMap
from sitl_mock.modes import RoverMode, VehicleKind
from sitl_mock.vehicle import VehicleSettings
from vehicles.endpoints import free_loopback_udp_ports

pytestmark = pytest.mark.timeout(60)

GEO = GeoFrame(47.397742, 8.545594, 488.0, 1.0)


@contextlib.asynccontextmanager
async def mavsdk_against_mock() -> AsyncIterator[tuple[MockFleet, System]]:
    (port,) = free_loopback_udp_ports(1)
    grid = GridMap(obstacle=np.zeros((6, 8), dtype=bool), pads=((0, 0),))
    config = MockVehicleConfig(
        1, VehicleSettings(VehicleKind.ROVER), LinkSettings(f"udpout:127.0.0.1:{port}")
    )
    sdk = Mavsdk(Configuration.create_with_component_type(ComponentType.GROUND_STATION))
    try:
        await sdk.add_any_connection(f"udpin://127.0.0.1:{port}")
        async with MockFleet([config], grid, GEO, ScaledClock(5.0), seed=3) as fleet:
            system = await sdk.first_autopilot(timeout_s=10.0)
            assert system is not None, "MAVSDK did not discover the mock"
            yield fleet, system
    finally:
        sdk.destroy()


def _sdk_items() -> list[SdkItem]:
    items = []
    for seq, cell in enumerate([(0, 0), (0, 4), (3, 4), (3, 1)]):
        lat, lon = GEO.cell_centre(cell)
        items.append(
            SdkItem(
                seq=seq,
                frame=mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
                command=mavlink.MAV_CMD_NAV_WAYPOINT,
                current=1 if seq == 0 else 0,
                autocontinue=1,
                param1=0.0,
                param2=0.0,
                param3=0.0,
                param4=float("nan") if seq == 3 else 0.0,
                x=round(lat * 1e7),
                y=round(lon * 1e7),
                z=0.0,
                mission_type=0,
            )
        )
    return items


def _fields(item: SdkItem) -> tuple[object, ...]:
    values = (
        item.seq,
        item.frame,
        item.command,
        item.autocontinue,
        item.param1,
        item.param2,
        item.param3,
        item.param4,
        item.x,
        item.y,
        item.z,
        item.mission_type,
    )
    return tuple("nan" if isinstance(v, float) and v != v else v for v in values)


T = TypeVar("T")


async def _first(stream: AsyncIterator[T], timeout_s: float = 10.0) -> T:
    async def first() -> T:
        async for value in stream:
            return value
        raise AssertionError("stream ended")

    try:
        return await asyncio.wait_for(first(), timeout_s)
    finally:
        aclose = getattr(stream, "aclose", None)
        if aclose is not None:
            await aclose()


async def test_mavsdk_reads_position_and_battery() -> None:
    async with mavsdk_against_mock() as (_fleet, system):
        telemetry = TelemetryAsync(system)
        position = await _first(telemetry.subscribe_position())
        lat, lon = GEO.cell_centre((0, 0))
        assert position.latitude_deg == pytest.approx(lat, abs=1e-6)
        assert position.longitude_deg == pytest.approx(lon, abs=1e-6)
        assert position.absolute_altitude_m == pytest.approx(488.0, abs=0.01)
        battery = await _first(telemetry.subscribe_battery())
        assert battery.remaining_percent == pytest.approx(100.0, abs=1.0)
        assert battery.voltage_v == pytest.approx(16.8, abs=0.01)


async def test_mavsdk_mission_round_trip_arm_and_rtl() -> None:
    async with mavsdk_against_mock() as (fleet, system):
        mission = MissionRawAsync(system)
        items = _sdk_items()
        await asyncio.wait_for(mission.upload_mission(items), 20)
        assert len(fleet.vehicles[1].mission) == len(items)
        downloaded = await asyncio.wait_for(mission.download_mission(), 20)
        assert [_fields(i) for i in downloaded] == [_fields(i) for i in items]

        action = ActionAsync(system)
        await asyncio.wait_for(action.arm(), 10)
        assert fleet.vehicles[1].armed
        telemetry = TelemetryAsync(system)
        assert await _first(telemetry.subscribe_armed()) is True
        await asyncio.wait_for(action.return_to_launch(), 10)
        assert fleet.vehicles[1].mode == RoverMode.RTL
