"""The web page's options, shared by ``gcs run`` and ``gcs report``."""

from __future__ import annotations

import argparse

from gcs.web import DEFAULT_PORT, LOOPBACK


def add_web_options(p: argparse.ArgumentParser, what: str) -> None:
    """``--web [PORT]``, ``--web-host`` and ``--tiles``; ``what`` the page shows."""
    p.add_argument(
        "--web",
        type=int,
        nargs="?",
        const=DEFAULT_PORT,
        metavar="PORT",
        help=f"serve {what} as a map page in the browser (the address is printed; default "
        f"port {DEFAULT_PORT}, 0 for any free one); nothing to install",
    )
    p.add_argument(
        "--web-host",
        default=LOOPBACK,
        metavar="ADDRESS",
        help=f"where --web listens (default {LOOPBACK}, this machine only); any other "
        "address needs the access token printed in the page's address",
    )
    p.add_argument(
        "--tiles",
        metavar="URL",
        help="a map tile layer under the page's map at the mission's origin, as a URL "
        "template with {z}, {x} and {y} (e.g. a tile server on your network); without "
        "one the map is drawn on its own",
    )
