"""``--web``: the map page of ``gcs run`` (live) and ``gcs report`` (a replay)."""

from __future__ import annotations

import argparse
import sys

from gcs.errors import UsageError
from gcs.web import LOOPBACK
from gcs.web.feed import LiveFeed
from gcs.web.server import PageConfig, WebView, WebViewError


def wants_web(args: argparse.Namespace) -> bool:
    """Whether any of the page's options was given (the others then need ``--web``)."""
    return args.web is not None or args.tiles is not None or args.web_host != LOOPBACK


def web_view(
    args: argparse.Namespace,
    title: str,
    *,
    feed: LiveFeed | None = None,
    replay: bytes | None = None,
) -> WebView:
    """The page the options ask for (not serving yet: ``start_web``)."""
    if args.web is None:
        raise UsageError("--web-host and --tiles need --web")
    if not 0 <= args.web <= 65535:
        raise UsageError(f"--web: port {args.web} is not in 0-65535")
    tiles = args.tiles
    if tiles is not None and not all(k in tiles for k in ("{z}", "{x}", "{y}")):
        raise UsageError(f"--tiles: {tiles!r} is not a URL template with {{z}}, {{x}} and {{y}}")
    config = PageConfig(mode="live" if feed is not None else "replay", title=title, tiles=tiles)
    return WebView(config, feed=feed, replay=replay, host=args.web_host, port=args.web)


async def start_web(view: WebView, command: str) -> None:
    """Serve the page and print its address (also with --quiet: the operator asked for it)."""
    try:
        await view.start()
    except WebViewError as exc:
        raise UsageError(f"--web: {exc}") from exc
    what = "mission" if view.config.mode == "live" else "replay"
    print(f"gcs {command}: {what} map page at {view.url}", file=sys.stderr, flush=True)
    if view.token:
        print(
            f"gcs {command}: the page listens on {view.host}: only with the token in this "
            "address; keep it to those who may watch",
            file=sys.stderr,
            flush=True,
        )
