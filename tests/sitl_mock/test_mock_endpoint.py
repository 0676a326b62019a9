"""The mock vehicles over real MAVLink on loopback, driven by a small pymavlink-codec client.

The client here is deliberately minimal and independent of ``vehicles/`` (the
ground station's own link): pymavlink as codec, asyncio UDP, futures for the
replies it expects.
"""

from __future__ import annotations

import asyncio
import contextlib
import random
from collections.abc import AsyncIterator, Callable
from typing import Any

import numpy as np
import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from core.clocks import ScaledClock
from core.geo import GeoFrame
from sitl_mock.battery import BatterySettings
from sitl_mock.endpoint import LinkSettings
from sitl_mock.faults import (
    CommandFaults,
    LinkFaults,
    MissionFailure,
    MissionFaults,
    VehicleFaults,
)
from sitl_mock.fleet import MockFleet, MockVehicleConfig
from sitl_mock.gridmap import GridMap
from sitl_mock.mission_server import MissionProtocolSettings, MissionRequestStyle
from sitl_mock.modes import CopterMode, RoverMode, VehicleKind
from sitl_mock.vehicle import VehicleSettings
from vehicles.endpoints import free_loopback_tcp_ports, free_loopback_udp_ports
from vehicles.mission_items import MissionItem

pytestmark = pytest.mark.timeout(60)

GEO = GeoFrame(47.397742, 8.545594, 488.0, 1.0)
KEY = bytes(range(32))
MAP_ROWS = [
    "C.....#...",
    "..........",
    "...##.....",
    "..........",
]


def grid_map() -> GridMap:
    obstacle = np.array([[ch == "#" for ch in row] for row in MAP_ROWS], dtype=bool)
    return GridMap(obstacle=obstacle, pads=((0, 0),))


# ---------------------------------------------------------------------- test client


def with_seq(seq: int) -> Callable[[Any], bool]:
    """Whether a message is the one numbered ``seq`` (bound now, not when a loop moved on)."""
    return lambda m: m.seq == seq


class MiniGcs(asyncio.DatagramProtocol):
    """A tiny ground station: listens on a UDP port (udpin), answers whoever talks."""

    def __init__(self, signing_key: bytes | None = None) -> None:
        self.codec = mavlink.MAVLink(None, 255, mavlink.MAV_COMP_ID_MISSIONPLANNER)
        self.codec.robust_parsing = True
        if signing_key is not None:
            self.codec.signing.secret_key = signing_key
            self.codec.signing.sign_outgoing = True
            self.codec.signing.timestamp = 1
            # The client reads anything (even with a wrong key): the vehicle is under test.
            self.codec.signing.allow_unsigned_callback = lambda codec, msg_id: True
        self.transport: asyncio.DatagramTransport | None = None
        self.vehicle_addr: tuple[str, int] | None = None
        self.heard = asyncio.Event()
        self.received: list[Any] = []
        self._waiters: list[tuple[Callable[[Any], bool], asyncio.Future[Any]]] = []

    @classmethod
    async def listen(cls, signing_key: bytes | None = None) -> tuple[MiniGcs, int]:
        loop = asyncio.get_running_loop()
        transport, gcs = await loop.create_datagram_endpoint(
            lambda: cls(signing_key), local_addr=("127.0.0.1", 0)
        )
        gcs.transport = transport
        return gcs, transport.get_extra_info("sockname")[1]

    def close(self) -> None:
        if self.transport is not None:
            self.transport.close()

    def datagram_received(self, data: bytes, addr: tuple[str, int]) -> None:
        self.vehicle_addr = addr
        for msg in self.codec.parse_buffer(data) or []:
            if msg.get_type() == "BAD_DATA":
                continue
            self.heard.set()
            self.received.append(msg)
            for waiter in list(self._waiters):
                predicate, fut = waiter
                if not fut.done() and predicate(msg):
                    fut.set_result(msg)
                    self._waiters.remove(waiter)

    def send(self, msg: Any) -> None:
        assert self.transport is not None and self.vehicle_addr is not None
        self.transport.sendto(msg.pack(self.codec), self.vehicle_addr)
        self.codec.seq = (self.codec.seq + 1) % 256

    def waiter(self, predicate: Callable[[Any], bool]) -> asyncio.Future[Any]:
        fut: asyncio.Future[Any] = asyncio.get_running_loop().create_future()
        self._waiters.append((predicate, fut))
        return fut

    async def expect(
        self,
        kind: str | tuple[str, ...],
        where: Callable[[Any], bool] = lambda m: True,
        timeout=3.0,
    ) -> Any:
        kinds = (kind,) if isinstance(kind, str) else kind
        fut = self.waiter(lambda m: m.get_type() in kinds and where(m))
        try:
            return await asyncio.wait_for(fut, timeout)
        finally:
            self._waiters = [w for w in self._waiters if w[1] is not fut]

    async def command(self, command: int, *params: float, timeout: float = 3.0) -> int:
        p = [*params] + [0.0] * (7 - len(params))
        ack = self.waiter(lambda m: m.get_type() == "COMMAND_ACK" and m.command == command)
        self.send(self.codec.command_long_encode(1, 1, command, 0, *p))
        return (await asyncio.wait_for(ack, timeout)).result

    async def set_mode(self, mode: int) -> int:
        flag = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
        return await self.command(mavlink.MAV_CMD_DO_SET_MODE, flag, mode)

    async def upload(self, items: list[MissionItem], retry_s: float = 0.3, deadline_s=30.0) -> int:
        """Upload with retries; returns the MISSION_ACK type (or raises TimeoutError)."""
        loop = asyncio.get_running_loop()
        end = loop.time() + deadline_s
        self.send(self.codec.mission_count_encode(1, 1, len(items), 0))
        asked = False
        while loop.time() < end:
            try:
                msg = await self.expect(
                    ("MISSION_REQUEST", "MISSION_REQUEST_INT", "MISSION_ACK"), timeout=retry_s
                )
            except TimeoutError:
                if not asked:
                    self.send(self.codec.mission_count_encode(1, 1, len(items), 0))
                else:  # our last item or its ACK may have been lost: repeat it
                    self.send(items[-1].to_message(1, 1))
                continue
            if msg.get_type() == "MISSION_ACK":
                if msg.type == mavlink.MAV_MISSION_INVALID_SEQUENCE:
                    continue  # a NACK does not end the upload
                return int(msg.type)
            asked = True
            self.send(items[msg.seq].to_message(1, 1))
        raise TimeoutError("upload did not finish")

    async def download(self, retry_s: float = 0.3, deadline_s: float = 30.0) -> list[MissionItem]:
        loop = asyncio.get_running_loop()
        end = loop.time() + deadline_s
        count: int | None = None
        while count is None:
            self.send(self.codec.mission_request_list_encode(1, 1, 0))
            with contextlib.suppress(TimeoutError):
                count = (await self.expect("MISSION_COUNT", timeout=retry_s)).count
            if loop.time() > end:
                raise TimeoutError("no MISSION_COUNT")
        items: list[MissionItem] = []
        while len(items) < count:
            seq = len(items)
            self.send(self.codec.mission_request_int_encode(1, 1, seq, 0))
            with contextlib.suppress(TimeoutError):
                item = await self.expect("MISSION_ITEM_INT", with_seq(seq), timeout=retry_s)
                items.append(MissionItem.from_message(item))
            if loop.time() > end:
                raise TimeoutError("download did not finish")
        self.send(self.codec.mission_ack_encode(1, 1, mavlink.MAV_MISSION_ACCEPTED, 0))
        return items


def sample_mission(n_waypoints: int, seed: int = 0) -> list[MissionItem]:
    """Item 0 (home) and ``n_waypoints`` waypoints over the free cells of the test map."""
    rng = random.Random(seed)
    free = [(r, c) for r, row in enumerate(MAP_ROWS) for c, ch in enumerate(row) if ch != "#"]
    cells = [(0, 0)] + [rng.choice(free) for _ in range(n_waypoints)]
    items = []
    for seq, cell in enumerate(cells):
        lat, lon = GEO.cell_centre(cell)
        items.append(
            MissionItem(
                seq,
                mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
                mavlink.MAV_CMD_NAV_WAYPOINT,
                0,
                1,
                0.0,
                0.0,
                0.0,
                float(seq % 7),
                round(lat * 1e7),
                round(lon * 1e7),
                float(seq % 3),
            )
        )
    return items


@contextlib.asynccontextmanager
async def mock_and_gcs(
    kind: VehicleKind = VehicleKind.ROVER,
    *,
    signing_key: bytes | None = None,
    gcs_key: bytes | None = None,
    vehicle: dict[str, Any] | None = None,
    battery: BatterySettings | None = None,
    faults: VehicleFaults | None = None,
    mission: MissionProtocolSettings | None = None,
    speedup: float = 5.0,
) -> AsyncIterator[tuple[MockFleet, MiniGcs]]:
    gcs, port = await MiniGcs.listen(gcs_key)
    config = MockVehicleConfig(
        1,
        VehicleSettings(kind, **(vehicle or {})),
        LinkSettings(
            f"udpout:127.0.0.1:{port}",
            signing_key=signing_key,
            mission=mission or MissionProtocolSettings(),
        ),
        battery or BatterySettings(),
        faults or VehicleFaults(),
    )
    try:
        async with MockFleet([config], grid_map(), GEO, ScaledClock(speedup), seed=7) as fleet:
            await asyncio.wait_for(gcs.heard.wait(), 5.0)
            yield fleet, gcs
    finally:
        gcs.close()


# ---------------------------------------------------------------------- tests


async def test_heartbeat_and_telemetry_fields_of_a_rover() -> None:
    async with mock_and_gcs() as (fleet, gcs):
        hb = await gcs.expect("HEARTBEAT")
        assert hb.type == mavlink.MAV_TYPE_GROUND_ROVER
        assert hb.autopilot == mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA
        assert hb.base_mode & mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
        assert not hb.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED
        assert hb.custom_mode == RoverMode.HOLD
        assert hb.system_status == mavlink.MAV_STATE_STANDBY
        assert hb.get_srcSystem() == 1 and hb.get_srcComponent() == 1
        pos = await gcs.expect("GLOBAL_POSITION_INT")
        lat, lon = GEO.cell_centre((0, 0))
        assert (pos.lat, pos.lon) == (round(lat * 1e7), round(lon * 1e7))
        assert pos.relative_alt == 0 and pos.alt == 488_000
        sys_status = await gcs.expect("SYS_STATUS")
        assert sys_status.battery_remaining == 100
        assert sys_status.voltage_battery == 16800
        battery = await gcs.expect("BATTERY_STATUS")
        assert battery.voltages[0] == 16800 and battery.current_consumed == 0
        assert battery.time_remaining == 0
        assert battery.charge_state == mavlink.MAV_BATTERY_CHARGE_STATE_OK
        await gcs.expect("DISTANCE_SENSOR", lambda m: m.orientation == 7)  # end of a burst
        burst = [m for m in gcs.received if m.get_type() == "DISTANCE_SENSOR"][-8:]
        sensors = {m.orientation: m.current_distance for m in burst}
        assert sorted(sensors) == list(range(8))
        world = fleet.world
        n, e = GEO.cell_centre_local((0, 0))
        for k in range(8):
            want = world.range_m(n, e, 45.0 * k, 10.0)
            assert sensors[k] == round(want * 100)
        od = await gcs.expect("OBSTACLE_DISTANCE")
        assert od.distances[0] == round(world.range_m(n, e, 0.0, 10.0) * 100)
        assert od.distances[18] == round(world.range_m(n, e, 90.0, 10.0) * 100)


async def test_copter_heartbeat_and_arming_in_guided() -> None:
    async with mock_and_gcs(VehicleKind.COPTER) as (_fleet, gcs):
        hb = await gcs.expect("HEARTBEAT")
        assert hb.type == mavlink.MAV_TYPE_QUADROTOR
        assert hb.custom_mode == CopterMode.STABILIZE
        assert await gcs.set_mode(CopterMode.GUIDED) == mavlink.MAV_RESULT_ACCEPTED
        arm = mavlink.MAV_CMD_COMPONENT_ARM_DISARM
        assert await gcs.command(arm, 1) == mavlink.MAV_RESULT_ACCEPTED
        takeoff = mavlink.MAV_CMD_NAV_TAKEOFF
        assert await gcs.command(takeoff, 0, 0, 0, 0, 0, 0, 3.0) == mavlink.MAV_RESULT_ACCEPTED
        await gcs.expect("GLOBAL_POSITION_INT", lambda m: m.relative_alt >= 2900, timeout=5)
        hb = await gcs.expect("HEARTBEAT", lambda m: m.custom_mode == CopterMode.GUIDED)
        assert hb.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED


async def test_modes_arming_and_command_acks() -> None:
    async with mock_and_gcs() as (_fleet, gcs):
        assert await gcs.set_mode(RoverMode.GUIDED) == mavlink.MAV_RESULT_ACCEPTED
        await gcs.expect("HEARTBEAT", lambda m: m.custom_mode == RoverMode.GUIDED)
        arm = mavlink.MAV_CMD_COMPONENT_ARM_DISARM
        assert await gcs.command(arm, 1) == mavlink.MAV_RESULT_ACCEPTED
        await gcs.expect("HEARTBEAT", lambda m: m.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED)
        rtl = mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH
        assert await gcs.command(rtl) == mavlink.MAV_RESULT_ACCEPTED
        await gcs.expect("HEARTBEAT", lambda m: m.custom_mode == RoverMode.RTL)
        assert await gcs.command(arm, 0) == mavlink.MAV_RESULT_ACCEPTED
        refused = gcs.waiter(lambda m: m.get_type() == "STATUSTEXT" and "armable" in m.text)
        assert await gcs.command(arm, 1) == mavlink.MAV_RESULT_FAILED  # no arming in RTL
        await asyncio.wait_for(refused, 3)
        assert await gcs.set_mode(99) == mavlink.MAV_RESULT_FAILED
        assert await gcs.command(31999) == mavlink.MAV_RESULT_UNSUPPORTED
        assert await gcs.set_mode(RoverMode.HOLD) == mavlink.MAV_RESULT_ACCEPTED
        assert await gcs.command(arm, 1) == mavlink.MAV_RESULT_ACCEPTED


async def test_message_interval_and_request_message() -> None:
    async with mock_and_gcs(speedup=1.0) as (_fleet, gcs):
        interval = mavlink.MAV_CMD_SET_MESSAGE_INTERVAL
        hb_id = mavlink.MAVLINK_MSG_ID_HEARTBEAT
        assert await gcs.command(interval, hb_id, 50_000) == mavlink.MAV_RESULT_ACCEPTED
        start = len([m for m in gcs.received if m.get_type() == "HEARTBEAT"])
        await asyncio.sleep(0.5)  # measuring a rate needs a real stretch of time
        count = len([m for m in gcs.received if m.get_type() == "HEARTBEAT"]) - start
        assert 5 <= count <= 15
        request = mavlink.MAV_CMD_REQUEST_MESSAGE
        home = gcs.waiter(lambda m: m.get_type() == "HOME_POSITION")
        version = mavlink.MAVLINK_MSG_ID_HOME_POSITION
        assert await gcs.command(request, version) == mavlink.MAV_RESULT_ACCEPTED
        assert (await asyncio.wait_for(home, 3)).altitude == 488_000
        assert await gcs.command(interval, 31000, 1000) == mavlink.MAV_RESULT_FAILED
        ask = mavlink.MAV_CMD_GET_MESSAGE_INTERVAL
        answer = gcs.waiter(lambda m: m.get_type() == "MESSAGE_INTERVAL")
        assert await gcs.command(ask, hb_id) == mavlink.MAV_RESULT_ACCEPTED
        assert (await asyncio.wait_for(answer, 3)).interval_us == 50_000
        # An id MESSAGE_INTERVAL cannot carry (a fuzzer's find): refused, not a crash.
        assert await gcs.command(ask, 70_000) == mavlink.MAV_RESULT_DENIED
        assert await gcs.command(ask, float("inf")) == mavlink.MAV_RESULT_DENIED
        assert await gcs.command(ask, float("nan")) == mavlink.MAV_RESULT_DENIED


async def test_startup_delay_refuses_arming_and_mission_upload() -> None:
    async with mock_and_gcs(vehicle={"startup_delay_s": 5.0}, speedup=1.0) as (_fleet, gcs):
        prearm = gcs.waiter(lambda m: m.get_type() == "STATUSTEXT" and m.text.startswith("Arm:"))
        arm = mavlink.MAV_CMD_COMPONENT_ARM_DISARM
        assert await gcs.command(arm, 1) == mavlink.MAV_RESULT_FAILED
        await asyncio.wait_for(prearm, 3)
        ack = gcs.waiter(lambda m: m.get_type() == "MISSION_ACK")
        gcs.send(gcs.codec.mission_count_encode(1, 1, 3, 0))
        assert (await asyncio.wait_for(ack, 3)).type == mavlink.MAV_MISSION_NO_SPACE
        hb = await gcs.expect("HEARTBEAT")
        assert hb.system_status == mavlink.MAV_STATE_BOOT


async def test_signing_rejects_unsigned_commands_and_accepts_signed_ones() -> None:
    async with mock_and_gcs(signing_key=KEY) as (fleet, unsigned):
        hb = await unsigned.expect("HEARTBEAT")  # we can read it, but it is signed
        assert hb.get_signed() is False  # our codec has no key to check it with
        arm = mavlink.MAV_CMD_COMPONENT_ARM_DISARM
        with pytest.raises(TimeoutError):
            await unsigned.command(arm, 1, timeout=1.0)
        assert not fleet.vehicles[1].armed
        assert fleet.endpoints[1].rejected_signatures >= 1
        # Same vehicle, now a ground station with the key.
        signed = MiniGcs(KEY)
        signed.transport, signed.vehicle_addr = unsigned.transport, unsigned.vehicle_addr
        unsigned.codec = signed.codec
        unsigned.codec.signing.timestamp = 10
        hb = await unsigned.expect("HEARTBEAT")
        assert hb.get_signed()
        assert await unsigned.command(arm, 1) == mavlink.MAV_RESULT_ACCEPTED
        assert fleet.vehicles[1].armed


async def test_wrong_key_is_rejected() -> None:
    async with mock_and_gcs(signing_key=KEY, gcs_key=bytes(32)) as (fleet, gcs):
        arm = mavlink.MAV_CMD_COMPONENT_ARM_DISARM
        with pytest.raises(TimeoutError):
            await gcs.command(arm, 1, timeout=1.0)
        assert not fleet.vehicles[1].armed


@pytest.mark.parametrize(
    ("waypoints", "style"),
    [
        (1, MissionRequestStyle.MISSION_REQUEST),
        (10, MissionRequestStyle.MISSION_REQUEST),
        (10, MissionRequestStyle.MISSION_REQUEST_INT),
        (499, MissionRequestStyle.MISSION_REQUEST),
    ],
)
async def test_mission_upload_and_download_round_trip(
    waypoints: int, style: MissionRequestStyle
) -> None:
    items = sample_mission(waypoints)
    settings = MissionProtocolSettings(request_style=style)
    async with mock_and_gcs(mission=settings) as (fleet, gcs):
        request_kind = "MISSION_REQUEST" if style is MissionRequestStyle.MISSION_REQUEST else None
        first = gcs.waiter(lambda m: m.get_type().startswith("MISSION_REQUEST"))
        received = gcs.waiter(
            lambda m: m.get_type() == "STATUSTEXT" and m.text == "Flight plan received"
        )
        assert await gcs.upload(items) == mavlink.MAV_MISSION_ACCEPTED
        assert (await first).get_type() == (request_kind or "MISSION_REQUEST_INT")
        await asyncio.wait_for(received, 3)
        assert list(fleet.vehicles[1].mission) == items
        assert await gcs.download() == items


async def test_mission_clear_and_download_with_the_float_messages() -> None:
    items = sample_mission(3)
    async with mock_and_gcs() as (_fleet, gcs):
        assert await gcs.upload(items) == mavlink.MAV_MISSION_ACCEPTED
        reply = gcs.waiter(lambda m: m.get_type() == "MISSION_ITEM")
        gcs.send(gcs.codec.mission_request_encode(1, 1, 2))
        item = await asyncio.wait_for(reply, 3)
        assert item.x == pytest.approx(items[2].x / 1e7, abs=1e-5)  # float32 degrees
        assert item.seq == 2
        ack = gcs.waiter(lambda m: m.get_type() == "MISSION_ACK")
        gcs.send(gcs.codec.mission_clear_all_encode(1, 1, 0))
        assert (await asyncio.wait_for(ack, 3)).type == mavlink.MAV_MISSION_ACCEPTED
        assert await gcs.download() == []


async def test_upload_under_30_percent_loss_completes_identically_or_fails_cleanly() -> None:
    old = sample_mission(2, seed=1)
    new = sample_mission(40, seed=2)
    lossy = VehicleFaults(link=LinkFaults(loss_to_gcs=0.3, loss_from_gcs=0.3))
    quick = MissionProtocolSettings(retry_s=0.05, timeout_s=3.0)
    async with mock_and_gcs(faults=lossy, mission=quick) as (fleet, gcs):
        vehicle = fleet.vehicles[1]
        vehicle.replace_mission(old)
        try:
            result = await gcs.upload(new, retry_s=0.1, deadline_s=20.0)
        except TimeoutError:
            result = None
        if result == mavlink.MAV_MISSION_ACCEPTED:
            assert list(vehicle.mission) == new
            assert await gcs.download(retry_s=0.1) == new
        else:
            assert list(vehicle.mission) in (old, new)  # never a mixture
            if result is not None:
                assert list(vehicle.mission) == old


async def test_failed_upload_leaves_the_old_mission_in_place() -> None:
    old = sample_mission(2, seed=1)
    failing = VehicleFaults(mission=MissionFaults(MissionFailure.WRITE_REQUEST_ERROR_ACK, at_seq=3))
    async with mock_and_gcs(faults=failing) as (fleet, gcs):
        fleet.vehicles[1].replace_mission(old)
        assert await gcs.upload(sample_mission(6)) == mavlink.MAV_MISSION_ERROR
        assert list(fleet.vehicles[1].mission) == old
        assert await gcs.upload(sample_mission(6)) == mavlink.MAV_MISSION_ACCEPTED  # once only


async def test_lost_final_ack_is_repeated_when_the_last_item_is() -> None:
    lost_ack = VehicleFaults(mission=MissionFaults(MissionFailure.WRITE_FINAL_ACK_NO_RESPONSE))
    items = sample_mission(4)
    async with mock_and_gcs(faults=lost_ack) as (fleet, gcs):
        assert await gcs.upload(items, retry_s=0.2) == mavlink.MAV_MISSION_ACCEPTED
        assert list(fleet.vehicles[1].mission) == items


async def test_commands_answered_with_failure_or_not_at_all() -> None:
    arm = mavlink.MAV_CMD_COMPONENT_ARM_DISARM
    failing = VehicleFaults(commands=CommandFaults(fail_probability=1.0))
    async with mock_and_gcs(faults=failing) as (fleet, gcs):
        assert await gcs.command(arm, 1) == mavlink.MAV_RESULT_FAILED
        assert not fleet.vehicles[1].armed
    silent = VehicleFaults(
        commands=CommandFaults(ignore_probability=1.0, commands=frozenset({arm}))
    )
    async with mock_and_gcs(faults=silent) as (fleet, gcs):
        with pytest.raises(TimeoutError):
            await gcs.command(arm, 1, timeout=0.5)
        assert await gcs.set_mode(RoverMode.GUIDED) == mavlink.MAV_RESULT_ACCEPTED


async def test_auto_mission_reports_progress_over_the_wire() -> None:
    items = sample_mission(0)
    for seq, cell in enumerate([(0, 2), (3, 2)], start=1):
        lat, lon = GEO.cell_centre(cell)
        items.append(
            MissionItem(
                seq,
                mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
                mavlink.MAV_CMD_NAV_WAYPOINT,
                0,
                1,
                0,
                0,
                0,
                0,
                round(lat * 1e7),
                round(lon * 1e7),
                0,
            )
        )
    async with mock_and_gcs(speedup=10.0) as (fleet, gcs):
        assert await gcs.upload(items) == mavlink.MAV_MISSION_ACCEPTED
        reached = gcs.waiter(lambda m: m.get_type() == "MISSION_ITEM_REACHED" and m.seq == 2)
        text = gcs.waiter(lambda m: m.get_type() == "STATUSTEXT" and m.text == "Mission Complete")
        wp1 = gcs.waiter(lambda m: m.get_type() == "STATUSTEXT" and m.text == "Reached waypoint #1")
        current = gcs.waiter(lambda m: m.get_type() == "MISSION_CURRENT" and m.seq == 2)
        assert await gcs.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1) == 0
        assert await gcs.set_mode(RoverMode.AUTO) == mavlink.MAV_RESULT_ACCEPTED
        await asyncio.wait_for(asyncio.gather(reached, text, wp1, current), 10)
        assert fleet.vehicles[1].cell == (3, 2)
        await gcs.expect("HEARTBEAT", lambda m: m.custom_mode == RoverMode.HOLD)


async def test_guided_position_target_drives_the_vehicle() -> None:
    async with mock_and_gcs(speedup=10.0) as (fleet, gcs):
        assert await gcs.set_mode(RoverMode.GUIDED) == 0
        assert await gcs.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1) == 0
        lat, lon = GEO.cell_centre((3, 2))
        mask = 0b0000_1111_1111_1000  # position only
        gcs.send(
            gcs.codec.set_position_target_global_int_encode(
                0,
                1,
                1,
                mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
                mask,
                round(lat * 1e7),
                round(lon * 1e7),
                0,
                0,
                0,
                0,
                0,
                0,
                0,
                0,
                0,
            )
        )
        await gcs.expect(
            "GLOBAL_POSITION_INT",
            lambda m: (m.lat, m.lon) == (round(lat * 1e7), round(lon * 1e7)),
            timeout=10,
        )
        # A wall in the way: DO_REPOSITION into the obstacle cell is refused en route.
        refused = gcs.waiter(lambda m: m.get_type() == "STATUSTEXT" and "Move refused" in m.text)
        lat, lon = GEO.cell_centre((2, 4))
        gcs.send(
            gcs.codec.command_int_encode(
                1,
                1,
                mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
                mavlink.MAV_CMD_DO_REPOSITION,
                0,
                0,
                -1,
                0,
                0,
                0,
                round(lat * 1e7),
                round(lon * 1e7),
                0,
            )
        )
        await asyncio.wait_for(refused, 10)
        assert fleet.vehicles[1].cell == (3, 3) or fleet.vehicles[1].cell[1] <= 3


async def test_dead_vehicle_says_so_then_falls_silent() -> None:
    battery = BatterySettings(start_pct=1.0, energy_per_m_pct=1.0)
    async with mock_and_gcs(battery=battery, speedup=10.0) as (fleet, gcs):
        assert await gcs.set_mode(RoverMode.GUIDED) == 0
        assert await gcs.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1) == 0
        last_words = gcs.waiter(lambda m: m.get_type() == "STATUSTEXT" and "lost" in m.text)
        fleet.vehicles[1].goto(*GEO.cell_centre_local((3, 0)))
        await asyncio.wait_for(last_words, 10)
        with pytest.raises(TimeoutError):
            await gcs.expect("HEARTBEAT", timeout=0.5)
        with pytest.raises(TimeoutError):
            await gcs.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1, timeout=0.3)


async def test_tcp_server_serves_several_clients() -> None:
    (port,) = free_loopback_tcp_ports(1)
    config = MockVehicleConfig(
        3, VehicleSettings(VehicleKind.ROVER), LinkSettings(f"tcpin:127.0.0.1:{port}")
    )
    async with MockFleet([config], grid_map(), GEO, ScaledClock(5.0)) as fleet:
        assert fleet.gcs_connection(3) == f"tcp:127.0.0.1:{port}"
        streams = [await asyncio.open_connection("127.0.0.1", port) for _ in range(2)]
        try:
            for reader, writer in streams:
                codec = mavlink.MAVLink(None, 255, 190)
                codec.robust_parsing = True
                hb = None
                while hb is None:
                    data = await asyncio.wait_for(reader.read(4096), 3)
                    msgs = codec.parse_buffer(data) or []
                    hb = next((m for m in msgs if m.get_type() == "HEARTBEAT"), None)
                assert hb.get_srcSystem() == 3
                writer.write(
                    codec.command_long_encode(3, 1, 31999, 0, 0, 0, 0, 0, 0, 0, 0).pack(codec)
                )
                ack = None
                while ack is None:
                    data = await asyncio.wait_for(reader.read(4096), 3)
                    msgs = codec.parse_buffer(data) or []
                    ack = next((m for m in msgs if m.get_type() == "COMMAND_ACK"), None)
                assert ack.result == mavlink.MAV_RESULT_UNSUPPORTED
        finally:
            for _, writer in streams:
                writer.close()
                with contextlib.suppress(ConnectionError):
                    await writer.wait_closed()


async def test_udpin_mock_is_silent_until_spoken_to() -> None:
    (port,) = free_loopback_udp_ports(1)
    config = MockVehicleConfig(
        2, VehicleSettings(VehicleKind.COPTER), LinkSettings(f"udpin:127.0.0.1:{port}")
    )
    async with MockFleet([config], grid_map(), GEO, ScaledClock(5.0)) as fleet:
        gcs, _ = await MiniGcs.listen()
        try:
            with pytest.raises(TimeoutError):
                await asyncio.wait_for(gcs.heard.wait(), 0.5)
            gcs.vehicle_addr = ("127.0.0.1", port)
            gcs.send(gcs.codec.heartbeat_encode(6, 8, 0, 0, 0))
            hb = await gcs.expect("HEARTBEAT")
            assert hb.get_srcSystem() == 2
            assert fleet.gcs_connection(2) == f"udpout:127.0.0.1:{port}"
        finally:
            gcs.close()
