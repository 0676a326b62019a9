"""The web page's server: aiohttp on the mission's own event loop.

Routes: ``/`` the page, ``/static/`` its scripts and styles, ``/config.json``
what the page is showing (live or a replay, the tile layer), ``/ws`` the records
(``gcs.web.feed``) over a WebSocket.

Never in the mission's way: the log only files messages in the feed; each
client has its own task, which sends what changed at most every
``ClientPace.update_period_s`` and drops the client when a send does not go out
in time or too much waits in its buffer (a stuck or slow browser).

Access: on a loopback address anyone on this machine may look, as with the
Foxglove live view. Listening elsewhere (``--web-host``) needs a token, made at
start and printed in the address: every request without it (in the query, or
the cookie the page gets with it) is refused with 401. WebSocket requests from a
page of another site (their ``Origin``) are refused with 403 either way.
"""

from __future__ import annotations

import asyncio
import contextlib
import hmac
import ipaddress
import json
import logging
import secrets
import socket
from dataclasses import dataclass
from importlib import resources
from typing import Any
from urllib.parse import urlsplit

from aiohttp import WSMsgType, web

from gcs.web import DEFAULT_PORT, LOOPBACK
from gcs.web.feed import Cursor, LiveFeed

log = logging.getLogger(__name__)

TOKEN_COOKIE = "gcs_token"


@dataclass(frozen=True)
class ClientPace:
    """How clients are served (real seconds)."""

    #: Between two updates to one client: a few a second, whatever the mission writes.
    update_period_s: float = 0.5
    #: How long a send may take, and how many bytes may wait in a client's buffer,
    #: before the client is dropped.
    send_timeout_s: float = 5.0
    max_buffered_bytes: int = 16 * 1024 * 1024
    #: Between two looks at a client with nothing to send (it may have left).
    idle_s: float = 5.0


class WebViewError(Exception):
    """The page cannot be served (the port is taken, the address is not this machine's)."""


def needs_token(host: str) -> bool:
    """Whether a listener on ``host`` must ask for the token: anywhere but loopback."""
    if host == "localhost":
        return False
    try:
        return not ipaddress.ip_address(host).is_loopback
    except ValueError:
        return True  # a name: it may resolve to anything


@dataclass(frozen=True)
class PageConfig:
    """What the page is told at load: live or a replay, and the map's tile layer."""

    mode: str  # "live" or "replay"
    title: str
    #: A tile URL template ({z}/{x}/{y}) drawn under the map at the mission's origin.
    tiles: str | None = None


class WebView:
    """Serves the page, live from a ``LiveFeed`` or a replay's one message."""

    def __init__(
        self,
        config: PageConfig,
        *,
        feed: LiveFeed | None = None,
        replay: bytes | None = None,
        host: str = LOOPBACK,
        port: int = DEFAULT_PORT,
        token: str | None = None,
        pace: ClientPace = ClientPace(),
    ) -> None:
        """``token``: None makes one if ``host`` needs it (``needs_token``); "" never
        asks for one."""
        if (feed is None) == (replay is None):
            raise ValueError("a web view serves either a live feed or a replay")
        self.config = config
        self.feed = feed
        self.replay = replay
        self.host = host
        self.port = port
        if token is None:
            token = secrets.token_urlsafe(18) if needs_token(host) else ""
        self.token = token
        self.pace = pace
        self._runner: web.AppRunner | None = None
        self._clients: set[web.WebSocketResponse] = set()
        self._senders: set[asyncio.Future[None]] = set()
        self._closing = asyncio.Event()
        #: Clients dropped for not taking their updates in time.
        self.dropped = 0

    @property
    def url(self) -> str:
        """The page's address (with the token, if one is needed); a listener on every
        interface is named by this machine's host name, which others can reach."""
        host = socket.gethostname() if self.host in ("0.0.0.0", "::") else self.host
        host = f"[{host}]" if ":" in host else host
        query = f"?token={self.token}" if self.token else ""
        return f"http://{host}:{self.port}/{query}"

    @property
    def clients(self) -> int:
        return len(self._clients)

    # -- life cycle ------------------------------------------------------------------

    async def start(self) -> None:
        app = web.Application(middlewares=[self._guard])
        static = resources.files("gcs.web") / "static"
        app.router.add_get("/", self._page)
        app.router.add_get("/config.json", self._config)
        app.router.add_get("/ws", self._socket)
        app.router.add_static("/static/", str(static))
        runner = web.AppRunner(app, handle_signals=False, access_log=None)
        await runner.setup()
        site = web.TCPSite(runner, self.host, self.port, reuse_address=True)
        try:
            await site.start()
        except OSError as exc:
            await runner.cleanup()
            reason = exc.strerror or str(exc)
            hint = " (another program has it: give another port, or 0 for any free one)"
            in_use = exc.errno in (98, 48)  # EADDRINUSE on Linux, macOS
            raise WebViewError(
                f"cannot serve on {self.host}:{self.port}: {reason}{hint if in_use else ''}"
            ) from exc
        self._runner = runner
        self.port = int(runner.addresses[0][1])  # the port taken, when 0 asked for any

    async def close(self) -> None:
        """Send each client what it has not seen yet (the end of the mission), then stop."""
        self._closing.set()
        if self.feed is not None:
            self.feed.wake()
        if self._senders:
            await asyncio.wait(list(self._senders), timeout=self.pace.send_timeout_s)
        for ws in list(self._clients):
            with contextlib.suppress(Exception):
                async with asyncio.timeout(1.0):
                    await ws.close(code=1001, message=b"the station stops")
        if self._runner is not None:
            await self._runner.cleanup()
            self._runner = None

    async def __aenter__(self) -> WebView:
        await self.start()
        return self

    async def __aexit__(self, *exc: object) -> None:
        await self.close()

    # -- access ----------------------------------------------------------------------

    @web.middleware
    async def _guard(self, request: web.Request, handler: Any) -> web.StreamResponse:
        given = request.query.get("token")
        if self.token:
            offered = given or request.cookies.get(TOKEN_COOKIE, "")
            if not hmac.compare_digest(offered.encode(), self.token.encode()):
                return web.Response(
                    status=401,
                    text="the token is missing or wrong: open the address the "
                    "station printed at start\n",
                )
        if request.path == "/ws" and not _same_origin(request):
            return web.Response(status=403, text="a page of another site may not connect\n")
        response: web.StreamResponse = await handler(request)
        if self.token and given and request.path != "/ws":
            response.set_cookie(TOKEN_COOKIE, self.token, httponly=True, samesite="Strict")
        return response

    # -- routes ----------------------------------------------------------------------

    async def _page(self, _request: web.Request) -> web.Response:
        page = (resources.files("gcs.web") / "static" / "index.html").read_text("utf-8")
        return web.Response(text=page, content_type="text/html")

    async def _config(self, _request: web.Request) -> web.Response:
        config = self.config
        body = {"mode": config.mode, "title": config.title, "tiles": config.tiles}
        return web.Response(text=json.dumps(body), content_type="application/json")

    async def _socket(self, request: web.Request) -> web.WebSocketResponse:
        # Uncompressed: the updates are a few kilobytes a second, and compressing each
        # client's copy would cost the mission's loop (or its worker threads) for nothing.
        ws = web.WebSocketResponse(heartbeat=30.0, max_msg_size=64 * 1024, compress=False)
        await ws.prepare(request)
        self._clients.add(ws)
        sender = asyncio.ensure_future(self._send_to(ws, request))
        self._senders.add(sender)
        sender.add_done_callback(self._senders.discard)
        try:
            async for msg in ws:  # the page sends nothing; this sees it leave
                if msg.type == WSMsgType.ERROR:
                    break
        finally:
            sender.cancel()
            await asyncio.gather(sender, return_exceptions=True)
            self._clients.discard(ws)
        return ws

    async def _send_to(self, ws: web.WebSocketResponse, request: web.Request) -> None:
        try:
            if self.replay is not None:
                await self._send(ws, request, self.replay)
                return
            assert self.feed is not None
            cursor = Cursor()
            while not ws.closed:
                closing = self._closing.is_set()
                data, cursor = self.feed.since(cursor)
                if data is not None:
                    await self._send(ws, request, data)
                if closing:
                    return  # the last of the mission went out
                if data is not None:
                    # The pace (what comes meanwhile coalesces), cut short by the close.
                    with contextlib.suppress(TimeoutError):
                        async with asyncio.timeout(self.pace.update_period_s):
                            await self._closing.wait()
                if not self._closing.is_set():
                    await self.feed.wait(cursor, self.pace.idle_s)
        except _Dropped as exc:
            self.dropped += 1
            log.info("web client %s dropped: %s", request.remote, exc)
            transport = request.transport
            if transport is not None:
                transport.abort()
        except (ConnectionError, RuntimeError):
            pass  # the client left while we sent

    async def _send(self, ws: web.WebSocketResponse, request: web.Request, data: bytes) -> None:
        transport = request.transport
        pace = self.pace
        if transport is not None and transport.get_write_buffer_size() > pace.max_buffered_bytes:
            raise _Dropped("its buffer is full")
        try:
            async with asyncio.timeout(pace.send_timeout_s):
                await ws.send_bytes(data)
        except TimeoutError:
            raise _Dropped(f"an update took over {pace.send_timeout_s:g} s to go out") from None


class _Dropped(Exception):
    """A client that does not take its updates: closed, never waited on."""


def _same_origin(request: web.Request) -> bool:
    """No ``Origin`` (not a browser), or one naming this server."""
    origin = request.headers.get("Origin")
    if origin is None:
        return True
    return urlsplit(origin).netloc == request.host
