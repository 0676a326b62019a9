"""One connection, many vehicles (``vehicles.network``), against mock vehicles on loopback.

A UDP port every vehicle sends to from its own socket (as behind a router), a
radio that carries the whole fleet through one socket or one serial device,
a stranger on a link, a radio unplugged and plugged back. The mock records
every frame each vehicle heard (``VehicleEndpoint.heard``), so what reached
whom is checked on the vehicles' side.
"""

from __future__ import annotations

import asyncio
import contextlib
import dataclasses
from collections.abc import AsyncIterator
from pathlib import Path

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from core.clocks import ScaledClock
from gcs.mission import Mission, load_mission
from gcs.mock_fleet import mock_fleet_configs
from sitl_mock.fleet import MockFleet, MockVehicleConfig
from sitl_mock.modes import RoverMode
from tests.serial_cable import SerialCable
from vehicles.commands import CommandSettings
from vehicles.endpoints import free_loopback_udp_ports
from vehicles.errors import LinkError
from vehicles.link import LinkEvent, LinkSettings, VehicleLink
from vehicles.modes import FlightMode
from vehicles.network import MavlinkNetwork, SystemPort
from vehicles.signing import SigningConfig, apply_signing
from vehicles.telemetry import Topic

pytestmark = pytest.mark.timeout(40)

BODY_S = 30.0
SETTINGS = LinkSettings(
    heartbeat_period_s=0.1,
    link_lost_after_s=0.5,
    commands=CommandSettings(timeout_s=0.25, retries=6),
)


def _mission(tmp_path: Path, count: int) -> Mission:
    (tmp_path / "m.txt").write_text("C....\n.....\n.....\n")
    text = f"name: net\nmap: m.txt\nfleet: {{count: {count}, defaults: {{type: rover}}}}\n"
    (tmp_path / "m.yaml").write_text(text)
    return load_mission(tmp_path / "m.yaml")


def _configs(mission: Mission, connection: str) -> list[MockVehicleConfig]:
    """The mission's mock vehicles, every one on ``connection`` (the mock's side)."""
    return [
        dataclasses.replace(c, link=dataclasses.replace(c.link, connection=connection))
        for c in mock_fleet_configs(mission)
    ]


@contextlib.asynccontextmanager
async def _fleets(
    mission: Mission, *groups: list[MockVehicleConfig]
) -> AsyncIterator[list[MockFleet]]:
    """One mock fleet per group (each its own sockets), started and stopped."""
    async with contextlib.AsyncExitStack() as stack:
        fleets = []
        for group in groups:
            fleet = MockFleet(group, mission.map, mission.geo, ScaledClock(10.0), seed=1)
            fleets.append(await stack.enter_async_context(fleet))
        yield fleets


def _targets(fleet: MockFleet, sysid: int) -> set[int]:
    """The target systems of every frame vehicle ``sysid`` heard (0: none or broadcast)."""
    return {target for (_kind, target) in fleet.endpoints[sysid].heard}


async def test_commands_for_one_vehicle_never_reach_another_on_a_shared_port(
    tmp_path: Path,
) -> None:
    """Vehicles 2 and 3 each send from their own socket to one station port (as behind
    a router): what the station says to 2 goes to 2's address alone."""
    mission = _mission(tmp_path, 3)
    (port,) = free_loopback_udp_ports(1)
    configs = _configs(mission, f"udpout:127.0.0.1:{port}")
    async with asyncio.timeout(BODY_S), MavlinkNetwork(SETTINGS) as network:
        link2 = await network.link(f"udpin:127.0.0.1:{port}", 2)
        link3 = await network.link(f"udpin:127.0.0.1:{port}", 3)
        async with _fleets(mission, [configs[1]], [configs[2]]) as (fleet2, fleet3):
            await asyncio.gather(link2.wait_heartbeat(10), link3.wait_heartbeat(10))
            await link2.set_mode(FlightMode.GUIDED)
            await link2.request_rates({mavlink.MAVLINK_MSG_ID_GPS_RAW_INT: 2.0})
            assert await link2.read_param("WP_RADIUS") > 0
            await link3.set_mode(FlightMode.HOLD)
            assert fleet2.vehicles[2].mode == RoverMode.GUIDED
            assert fleet3.vehicles[3].mode == RoverMode.HOLD
            assert 2 in _targets(fleet2, 2)
            assert 2 not in _targets(fleet3, 3), fleet3.endpoints[3].heard
            assert 3 not in _targets(fleet2, 2), fleet2.endpoints[2].heard
            connection = network.where(2)
            assert connection is network.where(3)
            assert connection.transport.peers[2] != connection.transport.peers[3]
            assert len(network.connections) == 1


async def test_a_radio_carries_the_fleet_and_each_vehicle_answers_only_its_own(
    tmp_path: Path,
) -> None:
    """Three vehicles behind one radio (one socket): every vehicle hears everything,
    acts only on what is addressed to it; the station hears all three on one port."""
    mission = _mission(tmp_path, 3)
    (port,) = free_loopback_udp_ports(1)
    configs = _configs(mission, f"udpout:127.0.0.1:{port}")
    async with asyncio.timeout(BODY_S), MavlinkNetwork(SETTINGS) as network:
        links = {s: await network.link(f"udpin:127.0.0.1:{port}", s) for s in (1, 2, 3)}
        async with _fleets(mission, configs) as (fleet,):
            assert all(fleet.shares_link(s) for s in (1, 2, 3))
            await asyncio.gather(*(link.wait_heartbeat(10) for link in links.values()))
            await links[2].set_mode(FlightMode.GUIDED)
            modes = {s: fleet.vehicles[s].mode for s in (1, 2, 3)}
            assert modes == {1: RoverMode.HOLD, 2: RoverMode.GUIDED, 3: RoverMode.HOLD}
            assert 2 in _targets(fleet, 3)  # the radio carried it to vehicle 3 too ...
            assert fleet.endpoints[3].foreign_frames > 0  # ... which ignored it
            positions = {s: link.telemetry.position for s, link in links.items()}
            assert all(p is not None for p in positions.values())
            peers = set()
            for link in links.values():
                assert isinstance(link.transport, SystemPort)
                peers.add(link.transport.peer)
            assert len(peers) == 1


async def test_a_system_the_mission_does_not_name_is_reported_once(tmp_path: Path) -> None:
    mission = _mission(tmp_path, 2)
    (port,) = free_loopback_udp_ports(1)
    notices: list[str] = []
    async with (
        asyncio.timeout(BODY_S),
        MavlinkNetwork(SETTINGS, on_notice=notices.append) as network,
        _fleets(mission, _configs(mission, f"udpout:127.0.0.1:{port}")),
    ):
        link = await network.link(f"udpin:127.0.0.1:{port}", 1)
        await link.wait_heartbeat(10)
        await link.wait_for(Topic.POSITION, lambda _p: True, 5)
        await asyncio.sleep(0.5)  # more frames of system 2 arrive
        connection = network.where(1)
        assert connection.stranger_frames > 5
        strangers = [n for n in notices if "system 2" in n]
        assert len(strangers) == 1, notices
        assert "not in the mission" in strangers[0]
        assert network.rejected.foreign_frames == connection.stranger_frames


async def _all_links(links: list[VehicleLink], event: LinkEvent) -> None:
    await asyncio.gather(*(link.wait_for(Topic.LINK, lambda e: e == event, 10) for link in links))


async def test_a_radio_unplugged_and_plugged_back_is_reopened(tmp_path: Path) -> None:
    """The station's serial device vanishes for a second: the link is lost, the device
    reopened when it is back, and the link comes up again, with both told."""
    mission = _mission(tmp_path, 2)
    notices: list[str] = []
    with SerialCable(tmp_path) as cable:
        configs = _configs(mission, f"serial:{cable.vehicle_end}:57600")
        async with (
            asyncio.timeout(BODY_S),
            MavlinkNetwork(SETTINGS, on_notice=notices.append) as network,
            _fleets(mission, configs),
        ):
            station = f"serial:{cable.station_end}:57600"
            links = [await network.link(station, s) for s in (1, 2)]
            await asyncio.gather(*(link.wait_heartbeat(10) for link in links))
            cable.unplug()
            await _all_links(links, LinkEvent.LOST)
            cable.plug()
            await _all_links(links, LinkEvent.UP)
            assert network.where(1).transport.stats.reconnects >= 1
            assert any("device gone" in n for n in notices), notices
            assert any("device back" in n for n in notices), notices
            await links[1].set_mode(FlightMode.GUIDED)  # commands flow again


class _OtherStation(asyncio.DatagramProtocol):
    """A second ground station on a UDP port of its own, as QGroundControl listens."""

    def __init__(self) -> None:
        self.codec = mavlink.MAVLink(None, 200, 190)
        self.codec.robust_parsing = True
        self.frames: list[tuple[bytes, mavlink.MAVLink_message]] = []
        self.heard = asyncio.Event()
        self.transport: asyncio.DatagramTransport | None = None
        self.station: tuple[str, int] | None = None

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        self.transport = transport  # type: ignore[assignment]

    def datagram_received(self, data: bytes, addr: tuple[str, int]) -> None:
        self.station = addr
        for msg in self.codec.parse_buffer(data) or []:
            self.frames.append((data, msg))
        self.heard.set()

    def send(self, msg: mavlink.MAVLink_message) -> None:
        assert self.transport is not None and self.station is not None
        self.transport.sendto(msg.pack(self.codec), self.station)

    def acks(self) -> list[mavlink.MAVLink_message]:
        return [m for _f, m in self.frames if m.get_type() == "COMMAND_ACK"]


@contextlib.asynccontextmanager
async def _other_station() -> AsyncIterator[tuple[_OtherStation, int]]:
    loop = asyncio.get_running_loop()
    transport, station = await loop.create_datagram_endpoint(
        _OtherStation, local_addr=("127.0.0.1", 0)
    )
    try:
        yield station, transport.get_extra_info("sockname")[1]
    finally:
        transport.close()


@pytest.mark.parametrize("commands", [False, True])
async def test_forward_shares_signed_frames_and_passes_commands_only_when_asked(
    tmp_path: Path, commands: bool
) -> None:
    """The other station gets the vehicles' frames as they came, signature and all; its
    command reaches the vehicle (and is acknowledged to it) only with ``commands``."""
    key = bytes(range(32))
    mission = _mission(tmp_path, 2)
    (port,) = free_loopback_udp_ports(1)
    configs = [
        dataclasses.replace(c, link=dataclasses.replace(c.link, signing_key=key))
        for c in _configs(mission, f"udpout:127.0.0.1:{port}")
    ]
    signing = SigningConfig(key)
    async with (
        asyncio.timeout(BODY_S),
        _other_station() as (other, other_port),
        MavlinkNetwork(SETTINGS) as network,
    ):
        apply_signing(other.codec, signing)  # the other station has the fleet's key too
        links = [await network.link(f"udpin:127.0.0.1:{port}", s, signing=signing) for s in (1, 2)]
        await network.forward(f"udpout:127.0.0.1:{other_port}", commands=commands)
        async with _fleets(mission, configs) as (fleet,):
            await asyncio.gather(*(link.wait_heartbeat(10) for link in links))
            await other.heard.wait()
            sources = {m.get_srcSystem() for _f, m in other.frames}
            assert {1, 2} <= sources
            vehicle_frames = [(f, m) for f, m in other.frames if m.get_srcSystem() in (1, 2)]
            assert vehicle_frames and all(m.get_signed() for _f, m in vehicle_frames)
            # A signed command of the other station, to vehicle 2.
            other.send(
                mavlink.MAVLink_command_long_message(
                    2,
                    1,
                    mavlink.MAV_CMD_REQUEST_MESSAGE,
                    0,
                    mavlink.MAVLINK_MSG_ID_HOME_POSITION,
                    0,
                    0,
                    0,
                    0,
                    0,
                    0,
                )
            )
            if commands:
                async with asyncio.timeout(5):
                    while not other.acks():
                        await asyncio.sleep(0.05)
                (ack,) = other.acks()
                assert (ack.get_srcSystem(), ack.target_system) == (2, 200)
                assert ("COMMAND_LONG", 2) in fleet.endpoints[2].heard
            else:
                async with asyncio.timeout(5):
                    while network.forward_refused == 0:
                        await asyncio.sleep(0.05)
                await asyncio.sleep(0.3)  # an acknowledgement would be back by now
                assert other.acks() == []
                assert fleet.endpoints[2].heard["COMMAND_LONG", 2] == 0


async def test_one_connection_carries_one_signing_key() -> None:
    (port,) = free_loopback_udp_ports(1)
    connection = f"udpin:127.0.0.1:{port}"
    async with asyncio.timeout(BODY_S), MavlinkNetwork(SETTINGS) as network:
        await network.link(connection, 1, signing=SigningConfig(bytes(range(32))))
        await network.link(connection, 2, signing=SigningConfig(bytes(range(32))))
        with pytest.raises(LinkError, match="different signing keys"):
            await network.link(connection, 3, signing=SigningConfig(bytes(range(1, 33))))
        with pytest.raises(LinkError, match="has a link already"):
            await network.link(connection, 1, signing=SigningConfig(bytes(range(32))))
        assert len(network.connections) == 1


async def test_a_vehicle_heard_on_another_connection_is_answered_there(tmp_path: Path) -> None:
    """The table of who is where: vehicle 1 named on one port and then heard on a second
    (its radio swapped for another) gets what the station sends on the second; the move
    is told once."""
    mission = _mission(tmp_path, 1)
    first_port, second_port = free_loopback_udp_ports(2)
    notices: list[str] = []
    async with (
        asyncio.timeout(BODY_S),
        MavlinkNetwork(SETTINGS, on_notice=notices.append) as network,
    ):
        second = await network.open(f"udpin:127.0.0.1:{second_port}", None)
        link = await network.link(f"udpin:127.0.0.1:{first_port}", 1)
        async with _fleets(mission, _configs(mission, f"udpout:127.0.0.1:{first_port}")):
            await link.wait_heartbeat(10)
            assert network.where(1) is not second
        async with _fleets(mission, _configs(mission, f"udpout:127.0.0.1:{second_port}")) as (
            fleet,
        ):
            await link.wait_for(Topic.STATUS, lambda _s: network.where(1) is second, 5)
            await link.set_mode(FlightMode.GUIDED)
            assert fleet.vehicles[1].mode == RoverMode.GUIDED
        moved = [n for n in notices if "too" in n]
        assert len(moved) == 1 and f"udpin:127.0.0.1:{second_port}" in moved[0], notices
