"""VehicleLink against the fake vehicle: heartbeat, telemetry, commands, modes, go-to."""

from __future__ import annotations

import asyncio
import contextlib
import math
from collections.abc import AsyncIterator

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from tests.vehicles.test_link_fake import FakeOptions, FakeVehicle
from vehicles.commands import CommandSettings
from vehicles.errors import CommandDenied, CommandTimeout, HeartbeatTimeout, ModeNotSupported
from vehicles.link import POSITION_ONLY_MASK, LinkEvent, LinkSettings, VehicleLink
from vehicles.modes import ArduRoverMode, FlightMode, Px4AutoSubMode, Px4MainMode
from vehicles.telemetry import Topic

pytestmark = pytest.mark.timeout(20)

FAST = LinkSettings(
    heartbeat_period_s=0.05,
    link_lost_after_s=0.3,
    not_ready_retry_s=0.05,
    commands=CommandSettings(timeout_s=0.1, retries=2, in_progress_timeout_s=1.0),
)


@contextlib.asynccontextmanager
async def connected(
    options: FakeOptions | None = None,
) -> AsyncIterator[tuple[FakeVehicle, VehicleLink]]:
    async with FakeVehicle(options) as fake:
        link = await VehicleLink.connect(fake.endpoint, settings=FAST)
        try:
            await link.wait_heartbeat(timeout_s=2.0)
            yield fake, link
        finally:
            await link.close()


async def test_heartbeat_identifies_vehicle() -> None:
    async with connected() as (_fake, link):
        status = link.status
        assert status is not None
        assert (status.system_id, link.target_system) == (1, 1)
        assert status.type_name == "GROUND_ROVER"
        assert status.autopilot_name == "ARDUPILOTMEGA"
        assert status.mode_name == "MANUAL" and status.flight_mode is FlightMode.MANUAL
        assert not status.armed
        assert link.profile is not None and link.profile.name == "ardupilot-rover"


async def test_gcs_heartbeat_is_sent() -> None:
    async with connected() as (fake, _link):
        hb = await fake.wait_message("HEARTBEAT")
        assert hb.type == mavlink.MAV_TYPE_GCS
        assert (hb.get_srcSystem(), hb.get_srcComponent()) == (255, 190)


async def test_no_heartbeat_times_out() -> None:
    link = await VehicleLink.connect("udpout:127.0.0.1:9", settings=FAST)
    try:
        with pytest.raises(HeartbeatTimeout, match="no heartbeat from any vehicle"):
            await link.wait_heartbeat(timeout_s=0.2)
    finally:
        await link.close()


async def test_link_lost_and_back() -> None:
    async with connected() as (fake, link):
        events = link.stream(Topic.LINK)
        try:
            heartbeats = next(t for t in fake._tasks if not t.done())
            heartbeats.cancel()
            async with asyncio.timeout(2):
                assert await anext(events) is LinkEvent.LOST
            assert not link.is_up
            fake.send(fake.heartbeat())
            async with asyncio.timeout(2):
                assert await anext(events) is LinkEvent.UP
            assert link.is_up
        finally:
            await events.aclose()
        assert link.streams.subscriber_count(Topic.LINK) == 0


async def test_telemetry_cache_and_stream() -> None:
    async with connected() as (fake, link):
        positions = link.stream(Topic.POSITION)
        try:
            fake.send(
                mavlink.MAVLink_global_position_int_message(
                    1000, 473977420, 85455940, 500_000, 10_000, 100, -50, 0, 9000
                )
            )
            pos = await asyncio.wait_for(anext(positions), 2)
        finally:
            await positions.aclose()
        assert (pos.lat_deg, pos.lon_deg) == (47.397742, 8.545594)
        assert (pos.alt_msl_m, pos.alt_rel_m, pos.heading_deg) == (500.0, 10.0, 90.0)
        assert link.telemetry.position == pos

        fake.send(
            mavlink.MAVLink_sys_status_message(0, 0, 0, 500, 12150, 230, 73, 0, 0, 0, 0, 0, 0)
        )
        voltages = [12150] + [65535] * 9
        fake.send(
            mavlink.MAVLink_battery_status_message(
                0,
                0,
                0,
                32767,
                voltages,
                230,
                1234,
                -1,
                73,
                0,
                mavlink.MAV_BATTERY_CHARGE_STATE_OK,
            )
        )
        for orientation, cm in ((0, 250), (mavlink.MAV_SENSOR_ROTATION_YAW_90, 120)):
            fake.send(mavlink.MAVLink_distance_sensor_message(1, 20, 800, cm, 0, 0, orientation, 0))
        fake.send(mavlink.MAVLink_mission_current_message(3, 10))
        fake.send(mavlink.MAVLink_mission_item_reached_message(2))
        fake.send(mavlink.MAVLink_statustext_message(6, b"Reached waypoint #2"))
        await link.wait_for(Topic.STATUSTEXT, lambda _t: True, timeout_s=2)
        t = link.telemetry
        assert t.battery.remaining_pct == 73.0
        assert t.battery.voltage_v == pytest.approx(12.15)
        assert t.battery.current_a == pytest.approx(2.3)
        assert t.battery.consumed_mah == 1234.0
        assert t.battery.charge_state == mavlink.MAV_BATTERY_CHARGE_STATE_OK
        assert t.ranges[0].distance_m == 2.5
        assert t.ranges[mavlink.MAV_SENSOR_ROTATION_YAW_90].distance_m == 1.2
        assert (t.mission.current_seq, t.mission.total, t.mission.last_reached_seq) == (3, 10, 2)
        assert t.statustext is not None and t.statustext.text == "Reached waypoint #2"


async def test_obstacle_distance() -> None:
    async with connected() as (fake, link):
        distances = [300] * 8 + [65535] * 64
        fake.send(
            mavlink.MAVLink_obstacle_distance_message(5, 0, distances, 45, 20, 1000, 45.0, 0.0)
        )
        obstacles = await link.wait_for(Topic.OBSTACLES, lambda _o: True, timeout_s=2)
        assert obstacles.distances_m[:8] == (3.0,) * 8
        assert obstacles.distances_m[8] is None
        assert obstacles.increment_deg == 45.0


async def test_command_accepted_first_time() -> None:
    async with connected() as (fake, link):
        ack = await link.set_message_interval(mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT, 5)
        assert ack.attempts == 1
        (cmd,) = fake.commands
        assert cmd.command == mavlink.MAV_CMD_SET_MESSAGE_INTERVAL
        assert (cmd.param1, cmd.param2) == (33, 200_000)


async def test_command_retried_with_confirmation() -> None:
    script: dict[int, list[int | None]] = {mavlink.MAV_CMD_COMPONENT_ARM_DISARM: [None, None]}
    async with connected(FakeOptions(command_script=script)) as (fake, link):
        await link.arm()
        assert [c.confirmation for c in fake.commands] == [0, 1, 2]
        assert link.status is not None
        await link.wait_for(Topic.STATUS, lambda s: s.armed, timeout_s=2)


async def test_command_timeout() -> None:
    script: dict[int, list[int | None]] = {mavlink.MAV_CMD_COMPONENT_ARM_DISARM: [None] * 10}
    async with connected(FakeOptions(command_script=script)) as (fake, link):
        with pytest.raises(CommandTimeout) as info:
            await link.arm()
        assert info.value.command == mavlink.MAV_CMD_COMPONENT_ARM_DISARM
        assert info.value.attempts == 3
        assert len(fake.commands) == 3


async def test_command_denied() -> None:
    script = {mavlink.MAV_CMD_COMPONENT_ARM_DISARM: [mavlink.MAV_RESULT_DENIED]}
    async with connected(FakeOptions(command_script=script)) as (_fake, link):
        with pytest.raises(CommandDenied, match="MAV_CMD_COMPONENT_ARM_DISARM refused") as info:
            await link.arm()
        assert info.value.result == mavlink.MAV_RESULT_DENIED


async def test_arm_waits_until_ready() -> None:
    refusals = [mavlink.MAV_RESULT_FAILED, mavlink.MAV_RESULT_TEMPORARILY_REJECTED]
    script = {mavlink.MAV_CMD_COMPONENT_ARM_DISARM: refusals}
    waits: list[str] = []
    async with FakeVehicle(FakeOptions(command_script=script)) as fake:
        link = await VehicleLink.connect(fake.endpoint, settings=FAST, on_wait=waits.append)
        try:
            await link.wait_heartbeat(2)
            fake.send(mavlink.MAVLink_statustext_message(3, b"PreArm: Gyros inconsistent"))
            await link.arm(wait_ready_s=5)
        finally:
            await link.close()
    assert fake.armed
    assert len(waits) == 2 and "Gyros inconsistent" in waits[-1]


async def test_in_progress_then_accepted() -> None:
    script = {mavlink.MAV_CMD_NAV_TAKEOFF: [mavlink.MAV_RESULT_IN_PROGRESS, 0]}
    progress: list[int] = []
    async with connected(FakeOptions(command_script=script)) as (fake, link):
        ack = await link.command_long(
            mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 10, on_progress=progress.append
        )
        assert ack.result == mavlink.MAV_RESULT_ACCEPTED
        assert progress == [50]
        assert len(fake.commands) == 1


async def test_in_progress_without_final_ack_times_out() -> None:
    script = {mavlink.MAV_CMD_NAV_TAKEOFF: [mavlink.MAV_RESULT_IN_PROGRESS]}
    async with connected(FakeOptions(command_script=script)) as (fake, link):
        with pytest.raises(CommandTimeout):
            await link.takeoff(10)
        assert len(fake.commands) == 1  # no resending once IN_PROGRESS


async def test_set_mode_ardupilot_rover() -> None:
    async with connected() as (fake, link):
        await link.set_mode(FlightMode.GUIDED)
        cmd = fake.commands[-1]
        assert cmd.command == mavlink.MAV_CMD_DO_SET_MODE
        assert (cmd.param1, cmd.param2) == (1, ArduRoverMode.GUIDED)
        status = await link.wait_for(Topic.STATUS, lambda s: s.mode_name == "GUIDED", 2)
        assert status.flight_mode is FlightMode.GUIDED
        await link.return_to_launch()
        assert fake.commands[-1].param2 == ArduRoverMode.RTL
        with pytest.raises(ModeNotSupported):
            await link.set_mode(FlightMode.LAND)


async def test_set_mode_px4_encoding() -> None:
    options = FakeOptions(autopilot=mavlink.MAV_AUTOPILOT_PX4, mav_type=mavlink.MAV_TYPE_QUADROTOR)
    async with connected(options) as (fake, link):
        assert link.profile is not None and link.profile.name == "px4-copter"
        await link.set_mode(FlightMode.AUTO)
        cmd = fake.commands[-1]
        assert (cmd.param1, cmd.param2, cmd.param3) == (
            1,
            Px4MainMode.AUTO,
            Px4AutoSubMode.MISSION,
        )


async def test_set_mode_without_ack_confirmed_by_heartbeat() -> None:
    script: dict[int, list[int | None]] = {mavlink.MAV_CMD_DO_SET_MODE: [None, None, None]}
    async with connected(FakeOptions(command_script=script)) as (fake, link):
        fake.o.custom_mode = ArduRoverMode.HOLD  # the vehicle switched, its ACK got lost
        await link.set_mode(FlightMode.HOLD)


async def test_goto_and_reposition() -> None:
    async with connected() as (fake, link):
        await link.goto(47.4, 8.55, 12.5)
        target = await fake.wait_message("SET_POSITION_TARGET_GLOBAL_INT")
        assert (target.lat_int, target.lon_int, target.alt) == (474000000, 85500000, 12.5)
        assert target.type_mask == POSITION_ONLY_MASK == 0x0DF8
        assert target.coordinate_frame == mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
        await link.reposition(47.4, 8.55, 12.5, speed_m_s=2)
        cmd = fake.commands[-1]
        assert cmd.get_type() == "COMMAND_INT"
        assert cmd.command == mavlink.MAV_CMD_DO_REPOSITION
        assert (cmd.x, cmd.y, cmd.param1) == (474000000, 85500000, 2)
        assert math.isnan(cmd.param4)
