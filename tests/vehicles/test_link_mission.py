"""Mission upload, download and clear against the fake vehicle, including its bad days."""

from __future__ import annotations

import contextlib
from collections.abc import AsyncIterator

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from tests.vehicles.test_link_fake import FakeOptions, FakeVehicle, sample_items
from vehicles.errors import MissionError, MissionTimeout
from vehicles.link import LinkSettings, VehicleLink
from vehicles.mission_items import MissionItem, same_items
from vehicles.mission_protocol import MissionSettings

pytestmark = pytest.mark.timeout(30)

FAST_MISSION = MissionSettings(
    timeout_s=0.1, item_timeout_s=0.05, retries=5, no_space_retry_s=0.01, no_space_wait_s=2.0
)


@contextlib.asynccontextmanager
async def connected(
    options: FakeOptions | None = None,
    mission: MissionSettings = FAST_MISSION,
    waits: list[str] | None = None,
) -> AsyncIterator[tuple[FakeVehicle, VehicleLink]]:
    settings = LinkSettings(heartbeat_period_s=0.05, mission=mission)
    async with FakeVehicle(options) as fake:
        link = await VehicleLink.connect(
            fake.endpoint, settings=settings, on_wait=None if waits is None else waits.append
        )
        try:
            await link.wait_heartbeat(timeout_s=2.0)
            yield fake, link
        finally:
            await link.close()


@pytest.mark.parametrize("n", [1, 10, 500])
async def test_upload_then_download_identical(n: int) -> None:
    items = sample_items(n)
    async with connected() as (fake, link):
        report = await link.upload_mission(items)
        assert fake.mission == items
        assert report.items == n and report.resends == 0
        assert await link.download_mission() == items
        acks = [m for m in fake.received if m.get_type() == "MISSION_ACK"]
        ack = acks[-1] if acks else await fake.wait_message("MISSION_ACK")
        assert ack.type == mavlink.MAV_MISSION_ACCEPTED


async def test_upload_empty_mission() -> None:
    async with connected() as (fake, link):
        fake.mission = sample_items(3)
        await link.upload_mission([])
        assert await link.download_mission() == []


async def test_item_fields_survive_the_trip() -> None:
    odd = MissionItem(
        seq=1,
        frame=mavlink.MAV_FRAME_MISSION,
        command=mavlink.MAV_CMD_DO_JUMP,
        current=0,
        autocontinue=0,
        param1=1.0,
        param2=3.0,
        param3=float("nan"),
        param4=-0.25,
        x=7,
        y=-8,
        z=1.5,
    )
    items = [sample_items(1)[0], odd]
    async with connected() as (_fake, link):
        await link.upload_mission(items)
        assert same_items(await link.download_mission(), items)


async def test_float_mission_request_answered_with_item_int() -> None:
    items = sample_items(10)
    async with connected(FakeOptions(float_requests=True)) as (fake, link):
        report = await link.upload_mission(items)
        assert fake.mission == items
        assert report.float_requests == 10
        sent = [m for m in fake.received if m.get_type().startswith("MISSION_ITEM")]
        assert {m.get_type() for m in sent} == {"MISSION_ITEM_INT"}


async def test_duplicate_requests_answered_once() -> None:
    """A request already waiting behind another for the same item is dropped and
    counted, not answered. (A request may also arrive only after its twin was
    answered, and the vehicle asks again when an item is slow to come, as on a
    loaded machine: so the counts are bounded, not fixed.)"""
    items = sample_items(20)
    async with connected(FakeOptions(duplicate_requests=True)) as (fake, link):
        report = await link.upload_mission(items)
        assert fake.mission == items
        sent = [m for m in fake.received if m.get_type() == "MISSION_ITEM_INT"]
        requests = len(fake.requests_sent)
        assert report.duplicate_requests >= 1
        # Every request is answered once at most, and those dropped are counted.
        assert len(sent) + report.duplicate_requests <= requests
        assert 20 <= len(sent) < requests


async def test_out_of_sequence_requests() -> None:
    items = sample_items(30)
    async with connected(FakeOptions(out_of_order=True)) as (fake, link):
        await link.upload_mission(items)
        order = [seq for _kind, seq in fake.requests_sent]
        assert order != sorted(order)
        assert fake.mission == items


async def test_error_ack_ends_upload_with_mission_error() -> None:
    options = FakeOptions(error_ack_at=4, error_ack_result=mavlink.MAV_MISSION_UNSUPPORTED_FRAME)
    async with connected(options) as (fake, link):
        with pytest.raises(MissionError) as info:
            await link.upload_mission(sample_items(10))
        err = info.value
        assert err.result == mavlink.MAV_MISSION_UNSUPPORTED_FRAME
        assert err.operation == "upload"
        assert "MAV_MISSION_UNSUPPORTED_FRAME" in str(err)
        assert fake.mission == []


async def test_no_space_after_boot_is_retried_and_reported() -> None:
    waits: list[str] = []
    items = sample_items(5)
    async with connected(FakeOptions(no_space_times=3), waits=waits) as (fake, link):
        report = await link.upload_mission(items)
        assert fake.mission == items
        assert report.no_space_waits == 3
        assert len(waits) == 3 and "MAV_MISSION_NO_SPACE" in waits[0]


async def test_no_space_for_too_long_fails() -> None:
    mission = MissionSettings(
        timeout_s=0.1, item_timeout_s=0.05, no_space_retry_s=0.02, no_space_wait_s=0.1
    )
    async with connected(FakeOptions(no_space_times=100), mission=mission) as (_fake, link):
        with pytest.raises(MissionError) as info:
            await link.upload_mission(sample_items(5))
        assert info.value.result == mavlink.MAV_MISSION_NO_SPACE


async def test_silent_vehicle_times_out() -> None:
    async with connected() as (fake, link):
        fake.o.drop_in = 1.0  # the vehicle hears nothing from now on
        with pytest.raises(MissionTimeout, match="no answer from the vehicle"):
            await link.upload_mission(sample_items(3))
        with pytest.raises(MissionTimeout, match="no MISSION_COUNT"):
            await link.download_mission()


async def test_nack_for_unrequested_item_does_not_end_upload() -> None:
    # ArduPilot answers an item it did not ask for with INVALID_SEQUENCE and goes on.
    options = FakeOptions(drop_out=0.3, nack_unexpected_items=True, seed=3)
    mission = MissionSettings(timeout_s=0.03, item_timeout_s=0.05, retries=10)
    items = sample_items(30)
    async with connected(options, mission=mission) as (fake, link):
        report = await link.upload_mission(items)
        assert fake.mission == items
        assert report.resends > 0


@pytest.mark.parametrize("seed", [1, 2, 3])
async def test_upload_with_30_percent_loss_both_ways(seed: int) -> None:
    items = sample_items(100)
    options = FakeOptions(drop_in=0.3, drop_out=0.3, seed=seed, item_timeout_s=0.01)
    mission = MissionSettings(timeout_s=0.015, item_timeout_s=0.015, retries=10)
    async with connected(options, mission=mission) as (fake, link):
        try:
            await link.upload_mission(items)
        except MissionError as exc:  # allowed, but it must be a clear one
            assert exc.operation == "upload" and exc.reason
        else:
            assert fake.mission == items
            fake.o.drop_in = fake.o.drop_out = 0.3
            try:
                downloaded = await link.download_mission()
            except MissionError as exc:
                assert exc.operation == "download" and exc.reason
            else:
                assert downloaded == items


async def test_clear() -> None:
    async with connected() as (fake, link):
        fake.mission = sample_items(4)
        await link.clear_mission()
        assert fake.mission == []
