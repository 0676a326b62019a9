"""What the web page costs a live mission (``gcs bench perf --web-clients N``).

The page is served as ``gcs run --web`` serves it (the log's stream into a
``LiveFeed``, no file), to N WebSocket clients in a process of their own that read
every update as a browser does; the bench flies the same mission with and without
them, side by side, and compares the decision latency.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import multiprocessing
import resource
from collections.abc import AsyncIterator
from dataclasses import dataclass
from multiprocessing.connection import Connection

import aiohttp

from gcs.log.mcap_log import McapMissionLog
from gcs.mission import Mission
from gcs.web.feed import LiveFeed
from gcs.web.server import PageConfig, WebView

#: Real seconds the clients have to connect before the mission starts.
CONNECT_S = 30.0


@dataclass
class Watchers:
    """What the clients received, once they are done."""

    clients: int
    updates: int = 0
    records: int = 0
    megabytes: float = 0.0
    dropped: int = 0
    #: CPU seconds the clients' process used (on this machine, beside the mission).
    cpu_s: float = 0.0


def _read_all(url: str, clients: int, out: Connection) -> None:
    """The clients' process: ``clients`` connections reading every update until the
    server closes them; what they got is sent back on ``out``."""

    async def one(session: aiohttp.ClientSession, counts: list[int]) -> None:
        async with session.ws_connect(url, max_msg_size=0) as ws:
            counts[3] += 1
            async for msg in ws:
                if msg.type == aiohttp.WSMsgType.BINARY:
                    counts[0] += 1
                    counts[1] += len(json.loads(msg.data)["records"])
                    counts[2] += len(msg.data)

    async def main() -> list[int]:
        counts = [0, 0, 0, 0]  # updates, records, bytes, connected
        async with aiohttp.ClientSession() as session:
            readers = [asyncio.ensure_future(one(session, counts)) for _ in range(clients)]
            while counts[3] < clients and not all(r.done() for r in readers):
                await asyncio.sleep(0.05)
            out.send(("connected", counts[3]))
            await asyncio.gather(*readers, return_exceptions=True)
        return counts

    counts = asyncio.run(main())
    usage = resource.getrusage(resource.RUSAGE_SELF)
    out.send(("done", [*counts, usage.ru_utime + usage.ru_stime]))


@contextlib.asynccontextmanager
async def watched(mission: Mission, clients: int) -> AsyncIterator[tuple[McapMissionLog, Watchers]]:
    """A log with no file whose stream the page serves to ``clients`` readers, connected
    before this yields; their counts are filled in once the page has closed."""
    feed = LiveFeed()
    log = McapMissionLog.for_mission(mission, None, sinks=[feed])
    view = WebView(PageConfig(mode="live", title=mission.name), feed=feed, port=0)
    watchers = Watchers(clients)
    receive, send = multiprocessing.Pipe(duplex=False)
    loop = asyncio.get_running_loop()
    await view.start()
    process = multiprocessing.get_context("spawn").Process(
        target=_read_all,
        args=(f"http://127.0.0.1:{view.port}/ws", clients, send),
        daemon=True,
    )
    process.start()
    try:
        ready = await loop.run_in_executor(None, receive.poll, CONNECT_S)
        if not ready:
            raise RuntimeError(f"the web clients did not connect within {CONNECT_S:g} s")
        receive.recv()
        yield log, watchers
    finally:
        await view.close()
        log.close()
        if await loop.run_in_executor(None, receive.poll, CONNECT_S):
            _, counts = receive.recv()
            watchers.updates, watchers.records = counts[0], counts[1]
            watchers.megabytes = round(counts[2] / 1e6, 1)
            watchers.cpu_s = round(counts[4], 1)
        watchers.dropped = view.dropped
        process.join(timeout=5)
        if process.is_alive():
            process.kill()
