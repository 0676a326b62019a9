"""The web page's server on loopback: the page and its files, the records over a
WebSocket (read with the ``websockets`` library, not the server's own), the access
rule (a token off loopback, no other site's pages), and a stuck client dropped while
the others and the feed carry on."""

from __future__ import annotations

import asyncio
import json
import socket
import subprocess
import sys
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from pathlib import Path
from typing import Any

import aiohttp
import pytest
from websockets.asyncio.client import connect
from websockets.exceptions import InvalidStatus

from gcs.cli import main
from gcs.web.feed import LiveFeed
from gcs.web.server import ClientPace, PageConfig, WebView, WebViewError, needs_token

pytestmark = pytest.mark.timeout(30)

LIVE = PageConfig(mode="live", title="test")
FAST = ClientPace(update_period_s=0.02, send_timeout_s=1.0, max_buffered_bytes=1 << 20)


@asynccontextmanager
async def serving(view: WebView) -> AsyncIterator[WebView]:
    async with view:
        yield view


async def get(url: str, **options: Any) -> tuple[int, str, aiohttp.ClientResponse]:
    async with aiohttp.ClientSession() as session, session.get(url, **options) as response:
        return response.status, await response.text(), response


def ws_url(view: WebView, token: str = "") -> str:
    return f"ws://127.0.0.1:{view.port}/ws" + (f"?token={token}" if token else "")


def test_a_token_is_needed_off_loopback_only() -> None:
    for host in ("127.0.0.1", "::1", "localhost", "127.0.0.2"):
        assert not needs_token(host)
    for host in ("0.0.0.0", "::", "192.168.1.20", "gcs.example"):
        assert needs_token(host)
    off = WebView(LIVE, feed=LiveFeed(), host="0.0.0.0", port=0)
    assert len(off.token) >= 20 and f"?token={off.token}" in off.url
    assert WebView(LIVE, feed=LiveFeed(), port=0).token == ""


async def test_the_page_its_files_and_the_records_are_served() -> None:
    feed = LiveFeed()
    feed.publish("/run/meta", "m", 0.0, b'{"mission":"demo"}')
    feed.publish("/events", "foxglove.Log", 1.0, b'{"message":"hello"}')
    async with serving(WebView(LIVE, feed=feed, port=0, pace=FAST)) as view:
        base = f"http://127.0.0.1:{view.port}"
        status, page, _ = await get(base + "/")
        assert status == 200 and "static/app.js" in page
        for name in ("static/app.js", "static/style.css", "static/vendor/leaflet/leaflet.js"):
            status, _, _ = await get(f"{base}/{name}")
            assert status == 200, name
        status, text, _ = await get(base + "/config.json")
        assert json.loads(text) == {"mode": "live", "title": "test", "tiles": None}
        async with connect(ws_url(view)) as ws:
            async with asyncio.timeout(5):
                first = json.loads(await ws.recv())
            assert [r["topic"] for r in first["records"]] == ["/run/meta", "/events"]
            feed.publish("/events", "foxglove.Log", 2.0, b'{"message":"later"}')
            async with asyncio.timeout(5):
                second = json.loads(await ws.recv())
            assert [r["data"]["message"] for r in second["records"]] == ["later"]


async def test_off_loopback_every_request_needs_the_token() -> None:
    # Served on loopback (the tests stay there) under the rule of a non-loopback address.
    feed = LiveFeed()
    async with serving(WebView(LIVE, feed=feed, port=0, token="s3cret-token")) as view:
        base = f"http://127.0.0.1:{view.port}"
        for path in ("/", "/config.json", "/static/app.js", "/ws"):
            status, text, _ = await get(base + path)
            assert status == 401, path
            assert "token" in text
        status, _, _ = await get(base + "/?token=wrong")
        assert status == 401
        with pytest.raises(InvalidStatus) as refused:
            async with connect(ws_url(view)):
                pass
        assert refused.value.response.status_code == 401
        # A browser keeps cookies of an IP address too (aiohttp's jar only when "unsafe").
        async with aiohttp.ClientSession(cookie_jar=aiohttp.CookieJar(unsafe=True)) as session:
            async with session.get(base + "/?token=s3cret-token") as response:
                assert response.status == 200
                cookie = response.cookies["gcs_token"]
                assert cookie.value == "s3cret-token" and cookie["httponly"]
            # The page's own requests carry the cookie, not the token.
            async with session.get(base + "/static/app.js") as response:
                assert response.status == 200
        async with connect(ws_url(view, "s3cret-token")) as ws:
            async with asyncio.timeout(5):
                await ws.send("hello")  # the connection is open


async def test_a_page_of_another_site_may_not_connect() -> None:
    async with serving(WebView(LIVE, feed=LiveFeed(), port=0)) as view:
        with pytest.raises(InvalidStatus) as refused:
            async with connect(ws_url(view), origin="http://evil.example"):  # type: ignore[arg-type]
                pass
        assert refused.value.response.status_code == 403
        origin = f"http://127.0.0.1:{view.port}"
        async with connect(ws_url(view), origin=origin):  # type: ignore[arg-type]
            pass


async def test_a_replay_is_sent_whole_once() -> None:
    data = b'{"records":[{"topic":"/events","t":1.0,"data":{}}],"complete":true}'
    config = PageConfig(mode="replay", title="r")
    async with serving(WebView(config, replay=data, port=0)) as view, connect(ws_url(view)) as ws:
        async with asyncio.timeout(5):
            assert await ws.recv() == data


async def test_a_taken_port_is_told_with_what_to_do() -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        with pytest.raises(WebViewError, match=f"127.0.0.1:{port}.*0 for any free one"):
            await WebView(LIVE, feed=LiveFeed(), port=port).start()


def stuck_client(port: int) -> socket.socket:
    """A WebSocket client that opens the connection and then never reads a byte."""
    sock = socket.socket()
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    sock.connect(("127.0.0.1", port))
    sock.sendall(
        b"GET /ws HTTP/1.1\r\nHost: 127.0.0.1\r\nUpgrade: websocket\r\n"
        b"Connection: Upgrade\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n"
        b"Sec-WebSocket-Version: 13\r\n\r\n"
    )
    return sock


async def test_a_stuck_client_is_dropped_and_nobody_waits_for_it() -> None:
    feed = LiveFeed()
    big = b'{"data":"%s"}' % (b"x" * 400_000)  # a large map, every update
    async with serving(WebView(LIVE, feed=feed, port=0, pace=FAST)) as view:
        stuck = stuck_client(view.port)
        try:
            async with connect(ws_url(view), max_size=None) as healthy:
                received = 0
                published = 0
                async with asyncio.timeout(20):
                    while view.dropped == 0:
                        # The mission's side: filing a message never waits on a client.
                        feed.publish("/map", "foxglove.Grid", float(published), big)
                        feed.publish("/events", "l", float(published), b'{"n":%d}' % published)
                        published += 1
                        message = json.loads(await healthy.recv())
                        received += len(message["records"])
                assert view.dropped == 1
                # The healthy client is still served, up to the last message written.
                feed.publish("/events", "l", 1e6, b'{"n":"last"}')
                async with asyncio.timeout(5):
                    while True:
                        message = json.loads(await healthy.recv())
                        if message["records"][-1]["data"]["n"] == "last":
                            break
                assert received > 0 and view.clients == 1
        finally:
            stuck.close()


def test_the_vendored_library_is_the_npm_package_it_names() -> None:
    """``web/vendor.py --check``: the files the page loads are those of the locked npm
    package (their digests as vendored), so nothing was edited by hand."""
    script = Path(__file__).resolve().parents[3] / "web" / "vendor.py"
    done = subprocess.run(
        [sys.executable, str(script), "--check"], capture_output=True, text=True, timeout=30
    )
    assert done.returncode == 0, done.stdout + done.stderr


async def test_what_was_written_before_the_close_reaches_the_clients() -> None:
    """The end of a mission is written just before the station closes: a client that
    was waiting out its pace gets it before the connection ends."""
    feed = LiveFeed()
    pace = ClientPace(update_period_s=30.0)  # without the close, nothing for 30 s
    view = WebView(LIVE, feed=feed, port=0, pace=pace)
    await view.start()
    try:
        async with connect(ws_url(view)) as ws:
            feed.publish("/events", "l", 1.0, b'{"n":1}')
            async with asyncio.timeout(5):
                await ws.recv()
            feed.publish("/run/progress", "p", 2.0, b'{"state":"every vehicle parked"}')
            await view.close()
            async with asyncio.timeout(5):
                last = json.loads(await ws.recv())
            assert [r["topic"] for r in last["records"]] == ["/run/progress"]
    finally:
        await view.close()


@pytest.mark.parametrize(
    ("options", "message"),
    [
        (["--tiles", "https://tiles.example/{z}/{x}/{y}.png"], "--web-host and --tiles need --web"),
        (["--web-host", "0.0.0.0"], "--web-host and --tiles need --web"),
        (["--web", "70000"], "--web: port 70000 is not in 0-65535"),
        (["--web", "0", "--tiles", "https://tiles.example/map.png"], "is not a URL template"),
    ],
)
@pytest.mark.parametrize("command", ["run", "report"])
def test_the_page_options_are_checked_before_anything_flies(
    command: str, options: list[str], message: str, tmp_path: Path, capsys: Any
) -> None:
    demo = Path(__file__).resolve().parents[3] / "missions" / "demo.yaml"
    if command == "run":
        args = ["run", str(demo), "--sim", *options]
    else:  # a report needs a log: the shortest one a plan writes
        out = tmp_path / "plan"
        assert main(["plan", str(demo), "--agents", "1", "--quiet", "--out", str(out)]) in (0, 1)
        args = ["report", str(out / "mission.mcap"), "--quiet", *options]
    assert main(args) == 2
    assert message in capsys.readouterr().err
