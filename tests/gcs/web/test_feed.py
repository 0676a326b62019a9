"""The web page's records: which topics the page reads and how, the live feed's
coalescing per client, and a replay read back from a log as the live clients got it."""

from __future__ import annotations

import asyncio
import json
from pathlib import Path
from typing import Any

import pytest

from gcs.log.mcap_log import LogSink
from gcs.log.mission_log import MissionProgress, VehicleStatus
from gcs.log.reader import LogError
from gcs.web.feed import Cursor, Kind, LiveFeed, kind_of
from gcs.web.replay import load_replay
from tests.checks import open_mission_log
from tests.gcs.log.test_mcap_log import _mission

pytestmark = pytest.mark.timeout(30)


def records(data: bytes | None) -> list[dict[str, Any]]:
    assert data is not None
    return json.loads(data)["records"]


def status(sysid: int, battery: float, cell: tuple[int, int] = (1, 1)) -> VehicleStatus:
    return VehicleStatus(
        sysid=sysid,
        kind="rover",
        activity="moving",
        phase="moving",
        task="exploring",
        cell=cell,
        battery_pct=battery,
        energy_pct_per_m=0.5,
        range_m=100.0,
        home_m=12.0,
        charges=0,
        way=((1, 2), (1, 3)),
        link_up=True,
        heard_s_ago=0.2,
        rejected_frames=0,
    )


def progress(covered: int) -> MissionProgress:
    return MissionProgress(
        covered=covered, free=100, state="covering", time_left_s=None, speedup=10.0
    )


def test_topics_the_page_reads() -> None:
    assert kind_of("/events") is Kind.HISTORY
    assert kind_of("/vehicle/12/pose") is Kind.HISTORY  # the tracks are drawn from them
    for topic in ("/run/meta", "/map", "/scene/btps", "/run/progress"):
        assert kind_of(topic) is Kind.LATEST
    for topic in ("/vehicle/3/status", "/vehicle/3/battery"):
        assert kind_of(topic) is Kind.LATEST
    for topic in ("/mavlink/1/in", "/vehicle/1/fix", "/scene/tracks", "/tf", "/run/result"):
        assert kind_of(topic) is None


def test_a_client_gets_the_whole_history_and_only_the_latest_of_the_rest() -> None:
    feed: LogSink = LiveFeed()
    assert isinstance(feed, LiveFeed)
    for k in range(5):
        feed.publish("/map", "foxglove.Grid", float(k), b'{"n":%d}' % k)
        feed.publish("/events", "foxglove.Log", float(k), b'{"message":"e%d"}' % k)
    feed.publish("/mavlink/1/in", "x", 5.0, b"\xfd")  # not the page's
    first, cursor = feed.since(Cursor())
    got = records(first)
    assert [r["data"]["message"] for r in got if r["topic"] == "/events"] == [
        f"e{k}" for k in range(5)
    ]
    assert [r["data"] for r in got if r["topic"] == "/map"] == [{"n": 4}]
    assert [r["t"] for r in got] == sorted(r["t"] for r in got)  # in the order written
    assert feed.since(cursor) == (None, cursor)  # nothing new: nothing sent
    feed.publish("/events", "foxglove.Log", 6.0, b'{"message":"e6"}')
    again, _ = feed.since(cursor)
    assert [r["data"] for r in records(again)] == [{"message": "e6"}]  # no map again


async def test_a_waiting_client_wakes_on_the_next_message_and_not_before() -> None:
    feed = LiveFeed()
    _, cursor = feed.since(Cursor())
    waiter = asyncio.ensure_future(feed.wait(cursor, timeout_s=10.0))
    await asyncio.sleep(0)
    assert not waiter.done()
    feed.publish("/run/progress", "p", 1.0, b"{}")
    async with asyncio.timeout(2.0):
        await waiter
    # With nothing new, the wait ends at its timeout.
    _, cursor = feed.since(cursor)
    async with asyncio.timeout(2.0):
        await feed.wait(cursor, timeout_s=0.05)


def test_a_replay_holds_the_statuses_and_progress_the_log_wrote(tmp_path: Path) -> None:
    mission = _mission()
    path = tmp_path / "mission.mcap"
    log = open_mission_log(path, mission)
    log.start(1_700_000_000.0)
    log.agent_state(1.0, 1, (1, 1), 90.0, "exploring")
    log.status(1.5, [status(1, 90.0)], progress(10))
    log.status(2.0, [status(1, 90.0)], progress(10))  # unchanged: not written again
    log.status(2.5, [status(1, 80.0, (1, 2))], progress(11))
    log.event(3.0, "vehicle 1 returns to charge", sysid=1)
    log.close()
    replay = load_replay(path)
    got = json.loads(replay.data)
    assert got["complete"] is True and not replay.truncated
    statuses = [r for r in got["records"] if r["topic"] == "/vehicle/1/status"]
    assert [(r["t"], r["data"]["battery_pct"], r["data"]["cell"]) for r in statuses] == [
        (1.5, 90.0, [1, 1]),
        (2.5, 80.0, [1, 2]),
    ]
    assert statuses[0]["data"]["way"] == [[1, 2], [1, 3]]
    assert [r["data"]["covered"] for r in got["records"] if r["topic"] == "/run/progress"] == [
        10,
        11,
    ]
    events = [r for r in got["records"] if r["topic"] == "/events"]
    assert [(r["t"], r["data"]["message"]) for r in events] == [
        (3.0, "vehicle 1 returns to charge")
    ]
    assert replay.end_s == 3.0


def test_a_cut_log_replays_up_to_its_cut_and_garbage_is_refused(tmp_path: Path) -> None:
    mission = _mission()
    path = tmp_path / "mission.mcap"
    log = open_mission_log(path, mission, chunk_size=512)
    log.start(1_700_000_000.0)
    for k in range(200):
        log.agent_state(float(k), 1, (1, 1 + k % 5), 90.0 - k * 0.1, "exploring")
        log.flush()
    size = path.stat().st_size
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(path.read_bytes()[: size * 2 // 3])  # the station died mid-write
    replay = load_replay(cut)
    assert replay.truncated
    assert 0 < replay.end_s < 199
    junk = tmp_path / "junk.mcap"
    junk.write_text("not a log")
    with pytest.raises(LogError, match="not an MCAP file"):
        load_replay(junk)
    with pytest.raises(LogError, match="no such file"):
        load_replay(tmp_path / "missing.mcap")
