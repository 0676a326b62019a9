"""A mission log as the web page's records, for ``gcs report LOG.mcap --web``.

The same records as a live client gets (``gcs.web.feed``), every message of the
topics the page reads, in the file's order, with each one's mission seconds; a
log cut short (the station died) gives what it holds up to the cut.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

from mcap.records import Channel, Message, Schema

from gcs.log.reader import LogError, mcap_records
from gcs.log.topics import META_TOPIC
from gcs.web.feed import kind_of, message, record


@dataclass(frozen=True)
class Replay:
    """A log ready to serve: the one message a client gets, and what it holds."""

    data: bytes
    records: int
    truncated: bool
    #: Mission seconds of the last record.
    end_s: float


def load_replay(path: Path) -> Replay:
    """Read a mission log's records; ``LogError`` names a file that is not one."""
    if not path.is_file():
        raise LogError(f"{path}: {'is a folder' if path.is_dir() else 'no such file'}")
    topics: dict[int, str] = {}
    started_ns = 0
    records: list[bytes] = []
    end_s = 0.0
    truncated = True
    try:
        for item in mcap_records(path):
            if isinstance(item, Channel):
                topics[item.id] = item.topic
            elif isinstance(item, Message):
                topic = topics.get(item.channel_id, "")
                if topic == META_TOPIC:
                    # Stamps count from the mission start it names (``gcs.log.mcap_log``).
                    started_ns = int(json.loads(item.data).get("started_unix_ns", 0))
                if kind_of(topic) is None:
                    continue
                t_s = max(0.0, (item.log_time - started_ns) / 1e9)
                end_s = max(end_s, t_s)
                records.append(record(topic, t_s, item.data))
            elif not isinstance(item, Schema):
                truncated = False  # the footer: the file was finished
    except EOFError:
        pass
    except OSError as exc:
        raise LogError(f"{path}: cannot read: {exc.strerror}") from exc
    if not records:
        raise LogError(f"{path}: holds nothing to replay")
    return Replay(message(records, complete=True), len(records), truncated, end_s)
