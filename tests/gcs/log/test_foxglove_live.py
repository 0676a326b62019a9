"""The live Foxglove view (``gcs run --live``): the log's derived topics served over the
Foxglove WebSocket protocol on loopback, read here by a plain WebSocket client
speaking that protocol (advertise, subscribe, binary message data), as Foxglove
does; and a whole ``gcs run --sim --live`` watched while it flies."""

from __future__ import annotations

import asyncio
import json
import struct
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from mcap.reader import make_reader
from websockets.asyncio.client import ClientConnection, connect
from websockets.typing import Subprotocol

from core.cells import CellState
from gcs.log.foxglove_live import LiveView
from gcs.log.mission_log import GeoFix
from gcs.log.topics import SCHEMAS
from tests.checks import open_mission_log
from tests.gcs.live.test_mission import SMALL, write_mission
from tests.gcs.log.test_mcap_log import _mission

pytestmark = pytest.mark.timeout(60)

SUBPROTOCOL = Subprotocol("foxglove.sdk.v1")  # what the Foxglove SDK server speaks
MESSAGE_DATA = 0x01  # binary opcode of a message on a subscription


async def advertised(ws: ClientConnection, topics: set[str]) -> dict[str, dict[str, Any]]:
    """Read the server's messages until every topic of ``topics`` is advertised; every
    channel advertised by then, by topic."""
    channels: dict[str, dict[str, Any]] = {}
    while not topics <= channels.keys():
        frame = await ws.recv()
        if isinstance(frame, str):
            message = json.loads(frame)
            if message["op"] == "advertise":
                channels.update({c["topic"]: c for c in message["channels"]})
    return channels


async def message_on(
    ws: ClientConnection, subscription: int, wanted: Callable[[dict[str, Any]], bool]
) -> dict[str, Any]:
    """The first JSON message on ``subscription`` that is ``wanted``."""
    while True:
        frame = await ws.recv()
        if isinstance(frame, bytes) and frame[0] == MESSAGE_DATA:
            sub, _log_time = struct.unpack_from("<IQ", frame, 1)
            message = json.loads(frame[13:])
            if sub == subscription and wanted(message):
                return message


async def test_the_logs_topics_are_served_live_with_their_schemas(tmp_path: Path) -> None:
    mission = _mission()
    view = LiveView(0, SCHEMAS)
    log = open_mission_log(tmp_path / "live.mcap", mission, sinks=[view])
    try:
        async with asyncio.timeout(20), connect(view.url, subprotocols=[SUBPROTOCOL]) as ws:
            shape = mission.map.shape
            belief = np.full(shape, int(CellState.UNKNOWN), dtype=np.int8)
            belief[0, 0] = int(CellState.FREE)
            log.raw(1, False, 0.5, b"\xfd\x00")
            log.agent_state(1.0, 1, mission.charger, 90.0, "exploring", GeoFix(47.0, 8.0))
            log.coverage(1.0, belief, np.zeros(shape, dtype=bool))
            log.event(1.0, "first", "info", 1)
            channels = await advertised(ws, {"/map", "/events", "/vehicle/1/fix"})
            assert channels["/map"]["schemaName"] == "foxglove.Grid"
            assert channels["/events"]["schemaName"] == "foxglove.Log"
            assert channels["/vehicle/1/fix"]["schemaName"] == "foxglove.LocationFix"
            assert json.loads(channels["/map"]["schema"]) == SCHEMAS["foxglove.Grid"]
            assert not any(topic.startswith("/mavlink/") for topic in channels)

            subscribe = {"id": 7, "channelId": channels["/events"]["id"]}
            await ws.send(json.dumps({"op": "subscribe", "subscriptions": [subscribe]}))
            # Sent until one arrives: the subscription takes effect a moment later.
            for k in range(200):
                log.event(2.0 + k, f"live {k}", "warning", 1)
                try:
                    async with asyncio.timeout(0.05):
                        got = await message_on(ws, 7, lambda m: m["message"].startswith("live"))
                    break
                except TimeoutError:
                    continue
            else:
                pytest.fail("no event arrived on the subscription")
            assert got["level"] == 3 and got["name"] == "vehicle 1"
    finally:
        log.close()
        view.close()
    with (tmp_path / "live.mcap").open("rb") as stream:
        summary = make_reader(stream).get_summary()
        assert summary is not None
        topics = {c.topic for c in summary.channels.values()}
    assert {"/map", "/events", "/mavlink/1/in"} <= topics  # the file has it all


async def test_gcs_run_live_is_watched_while_it_flies(tmp_path: Path) -> None:
    """The real CLI in a process of its own with ``--sim --live 0`` and no ``--out`` (the
    log then writes no file and only serves): it says where it serves; a client
    connected during the mission sees the map and the vehicle advertised, and the
    vehicle's fixes arrive."""
    mission = write_mission(tmp_path, SMALL, [{"type": "rover"}])
    argv = ["run", str(mission), "--sim", "--live", "0", "--quiet", "--speedup", "20"]
    process = await asyncio.create_subprocess_exec(
        sys.executable,
        "-c",
        "import sys; from gcs.cli import main; sys.exit(main(sys.argv[1:]))",
        *argv,
        stdout=asyncio.subprocess.DEVNULL,
        stderr=asyncio.subprocess.PIPE,
    )
    try:
        async with asyncio.timeout(40):
            assert process.stderr is not None
            url = None
            while url is None:
                line = (await process.stderr.readline()).decode()
                assert line, "gcs run ended without serving"
                if "Foxglove live view at " in line:
                    url = line.split(" at ", 1)[1].strip()
            async with connect(url, subprotocols=[SUBPROTOCOL]) as ws:
                channels = await advertised(ws, {"/map", "/vehicle/1/fix"})
                subscribe = {"id": 1, "channelId": channels["/vehicle/1/fix"]["id"]}
                await ws.send(json.dumps({"op": "subscribe", "subscriptions": [subscribe]}))
                fix = await message_on(ws, 1, lambda m: "latitude" in m)
                assert fix["frame_id"]
            rest = (await process.stderr.read()).decode()
            assert await process.wait() == 0, rest
    finally:
        if process.returncode is None:
            process.kill()
            await process.wait()
