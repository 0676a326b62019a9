"""Our link against MAVSDK 4 acting as the vehicle (an independent MAVLink implementation).

MAVSDK's autopilot side sends to our ``udpin`` port (``udpout://``); we upload a
mission to its MissionRawServer and read the battery and position that its
TelemetryServer publishes.
"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import AsyncIterator

import pytest

mavsdk = pytest.importorskip("mavsdk")

from mavsdk.asyncio.mavsdk import Configuration, Mavsdk  # noqa: E402
from mavsdk.asyncio.plugins.mission_raw_server import MissionRawServerAsync  # noqa: E402
from mavsdk.asyncio.plugins.telemetry_server import (  # noqa: E402
    Battery,
    Heading,
    Position,
    TelemetryServerAsync,
    VelocityNed,
)
from mavsdk.component_type import ComponentType  # noqa: E402

from tests.vehicles.test_link_fake import sample_items  # noqa: E402
from vehicles.endpoints import free_loopback_udp_ports  # noqa: E402
from vehicles.link import LinkSettings, VehicleLink  # noqa: E402
from vehicles.mission_items import MissionItem  # noqa: E402
from vehicles.telemetry import Topic  # noqa: E402

pytestmark = pytest.mark.timeout(30)


@contextlib.asynccontextmanager
async def mavsdk_vehicle() -> AsyncIterator[tuple[Mavsdk, VehicleLink]]:
    (port,) = free_loopback_udp_ports(1)
    link = await VehicleLink.connect(
        f"udpin:127.0.0.1:{port}", settings=LinkSettings(heartbeat_period_s=0.2)
    )
    sdk = Mavsdk(Configuration.create_with_component_type(ComponentType.AUTOPILOT))
    try:
        await sdk.add_any_connection(f"udpout://127.0.0.1:{port}")
        await link.wait_heartbeat(timeout_s=10)
        yield sdk, link
    finally:
        await link.close()
        sdk.destroy()


async def test_mission_upload_to_mavsdk_arrives_intact() -> None:
    items = sample_items(10)
    async with mavsdk_vehicle() as (sdk, link):
        server = MissionRawServerAsync(await sdk.server_component())
        incoming = server.subscribe_incoming_mission()
        try:
            receiving = asyncio.ensure_future(anext(incoming))
            await asyncio.sleep(0)  # let the subscription register
            await link.upload_mission(items)
            _result, plan = await asyncio.wait_for(receiving, 10)
        finally:
            await incoming.aclose()
        got = [
            MissionItem(
                seq=i.seq,
                frame=i.frame,
                command=i.command,
                current=i.current,
                autocontinue=i.autocontinue,
                param1=i.param1,
                param2=i.param2,
                param3=i.param3,
                param4=i.param4,
                x=i.x,
                y=i.y,
                z=i.z,
                mission_type=i.mission_type,
            )
            for i in plan.mission_items
        ]
        assert got == items


async def test_battery_and_position_from_mavsdk() -> None:
    async with mavsdk_vehicle() as (sdk, link):
        telemetry = TelemetryServerAsync(await sdk.server_component())

        async def publish() -> None:
            while True:
                await telemetry.publish_position(
                    Position(47.397742, 8.545594, 500.0, 10.0),
                    VelocityNed(0.0, 0.0, 0.0),
                    Heading(90.0),
                )
                await telemetry.publish_battery(Battery(12.1, 0.55))  # a 0..1 fraction
                await asyncio.sleep(0.05)

        publisher = asyncio.ensure_future(publish())
        try:
            battery = await link.wait_for(
                Topic.BATTERY, lambda b: b.remaining_pct is not None, timeout_s=10
            )
            position = await link.wait_for(Topic.POSITION, lambda _p: True, timeout_s=10)
        finally:
            publisher.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await publisher
        assert battery.remaining_pct == 55.0
        assert battery.voltage_v == pytest.approx(12.1)
        assert position.lat_deg == pytest.approx(47.397742)
        assert position.lon_deg == pytest.approx(8.545594)
        assert position.alt_rel_m == pytest.approx(10.0)
        assert position.heading_deg == pytest.approx(90.0)
