"""The mission in the browser: the station serves its own map page (``gcs run --web``),
live from the stream the mission log writes, and replays a log (``gcs report --web``).

``feed``: the log's messages as the page's records, coalesced for live clients;
``replay``: the same records read from an MCAP file; ``server``: the HTTP and
WebSocket server (aiohttp) on the mission's event loop, with its access rule;
``static/``: the page (plain HTML and JavaScript, Leaflet vendored from npm).
"""

#: Where the page is served unless told otherwise (``--web PORT``, ``--web-host``).
DEFAULT_PORT = 8090
LOOPBACK = "127.0.0.1"
