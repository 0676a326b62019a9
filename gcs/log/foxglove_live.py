"""A running mission in Foxglove as it happens (``gcs run --live``).

The mission log's derived topics (map, vehicle fixes and poses, tracks,
backtracking points, batteries, events) are served over the Foxglove
WebSocket protocol as the log writes them, with the same schemas, so the
layout an operator builds for a recorded MCAP works live too. The raw MAVLink
channels stay in the file only: Foxglove does not decode them.

Loopback only: an operator elsewhere reaches it through an SSH tunnel.
"""

from __future__ import annotations

import json
import time
from typing import Any

import foxglove

HOST = "127.0.0.1"
DEFAULT_PORT = 8765


class LiveViewError(Exception):
    """The live view could not be served (the port is taken...)."""


class LiveView:
    def __init__(self, port: int = DEFAULT_PORT, schemas: dict[str, dict[str, Any]] | None = None):
        """``port`` 0 takes any free one (see ``port``). ``schemas``: JSON schemas by name."""
        self._context = foxglove.Context()
        try:
            self._server = foxglove.start_server(
                name="staying-alive-gcs", host=HOST, port=port, context=self._context
            )
        except Exception as exc:  # the SDK raises its own error types from Rust
            raise LiveViewError(f"cannot serve on {HOST}:{port}: {exc}") from exc
        self._schemas = schemas or {}
        self._channels: dict[str, foxglove.Channel] = {}

    @property
    def port(self) -> int:
        return int(self._server.port)

    @property
    def url(self) -> str:
        return f"ws://{HOST}:{self.port}"

    def publish(self, topic: str, schema: str, t_s: float, data: bytes) -> None:
        """One JSON message of ``schema`` (a name of ``schemas``) on ``topic``, now (a
        :class:`gcs.log.mcap_log.LogSink`; ``t_s``, the mission time, is in the message)."""
        channel = self._channels.get(topic)
        if channel is None:
            definition = json.dumps(self._schemas.get(schema, {"type": "object"})).encode()
            channel = foxglove.Channel(
                topic,
                schema=foxglove.Schema(name=schema, encoding="jsonschema", data=definition),
                message_encoding="json",
                context=self._context,
            )
            self._channels[topic] = channel
        # Stamped with the wall clock as it is sent, as a live source is; the message's own
        # timestamp is the file's stamp (the mission start plus the mission time, which runs
        # ahead of the wall clock under a speed-up: see ``gcs.log.mcap_log``).
        channel.log(data, log_time=time.time_ns())

    def close(self) -> None:
        self._server.stop()
