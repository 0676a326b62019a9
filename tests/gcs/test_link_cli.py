"""``gcs mission`` and ``gcs status`` end to end against the fake vehicle.

The CLI runs its own event loop, so it runs in a worker thread while the fake
vehicle lives in the test's loop.
"""

from __future__ import annotations

import asyncio
from pathlib import Path

import pytest

from gcs.cli import main
from tests.vehicles.test_link_fake import FakeOptions, FakeVehicle, sample_items
from vehicles.mission_files import read_mission, write_mission

pytestmark = pytest.mark.timeout(30)


async def gcs(*argv: str) -> int:
    return await asyncio.to_thread(main, list(argv))


async def test_upload_then_download(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    items = sample_items(12)
    source = tmp_path / "in.waypoints"
    write_mission(source, items)
    async with FakeVehicle() as fake:
        assert await gcs("mission", "upload", fake.endpoint, str(source), "--timeout", "5") == 0
        assert fake.mission == items
        target = tmp_path / "out.plan"
        assert await gcs("mission", "download", fake.endpoint, str(target)) == 0
        got = read_mission(target)
        assert got[1:] == items[1:]  # a .plan keeps home as a position only
        assert (got[0].x, got[0].y, got[0].z) == (items[0].x, items[0].y, items[0].z)
        assert await gcs("mission", "clear", fake.endpoint) == 0
        assert fake.mission == []
    out = capsys.readouterr().out
    assert "uploaded 12 items to system 1" in out
    assert "downloaded 12 items" in out


async def test_upload_strips_home_for_px4(tmp_path: Path) -> None:
    items = sample_items(5)
    source = tmp_path / "in.plan"
    write_mission(source, items)
    async with FakeVehicle(FakeOptions(autopilot=12)) as fake:
        assert await gcs("mission", "upload", fake.endpoint, str(source)) == 0
        assert [i.x for i in fake.mission] == [i.x for i in items[1:]]
        assert [i.seq for i in fake.mission] == [0, 1, 2, 3]


async def test_refused_upload_exits_1(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    source = tmp_path / "in.waypoints"
    write_mission(source, sample_items(5))
    async with FakeVehicle(FakeOptions(error_ack_at=2)) as fake:
        assert await gcs("mission", "upload", fake.endpoint, str(source)) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "MAV_MISSION_INVALID_PARAM1" in err[0]


async def test_no_vehicle_exits_1(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    target = tmp_path / "out.waypoints"
    code = await gcs("mission", "download", "udpin:127.0.0.1:0", str(target), "--timeout", "0.2")
    assert code == 1
    assert "no heartbeat" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("argv", "why"),
    [
        (["mission", "upload", "tcp:10.1.1.1:5760", "m.waypoints"], "not loopback"),
        (["mission", "upload", "udpin:127.0.0.1:14550", "nope.waypoints"], "nope.waypoints"),
        (["mission", "download", "udpin:127.0.0.1:14550", "out.kml"], "unknown mission file"),
        (["status", "bogus"], "expected KIND:HOST:PORT"),
        (["status", "udpin:127.0.0.1:14550", "--keys", "no-such-keys.yaml"], "cannot read"),
    ],
)
def test_bad_input_exits_2(argv: list[str], why: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and why in err[0]


async def test_status_table(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("COLUMNS", "200")
    async with FakeVehicle() as one, FakeVehicle(FakeOptions(system_id=2, custom_mode=15)) as two:
        code = await gcs("status", one.endpoint, two.endpoint, "--timeout", "5")
    out = capsys.readouterr().out
    assert code == 0
    assert "GROUND_ROVER" in out and "ARDUPILOTMEGA" in out
    assert "MANUAL" in out and "GUIDED" in out
    assert "87" in out and "47.3977420" in out and "8.5455940" in out


async def test_status_silent_endpoint_exits_1(capsys: pytest.CaptureFixture[str]) -> None:
    assert await gcs("status", "udpin:127.0.0.1:0", "--timeout", "0.2") == 1
    assert "no heartbeat within 0.2 s" in capsys.readouterr().err
