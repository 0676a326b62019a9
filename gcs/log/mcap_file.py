"""The MCAP file under the mission log: channels, messages, chunks, flushes.

Written by the Foxglove SDK's MCAP writer (Rust): a message costs about a
microsecond where the pure-Python ``mcap`` writer took several, and chunks are
compressed (zstd) outside the Python interpreter. ``gcs/log/reader.py`` reads the
files with the ``mcap`` package, an implementation of its own.

A write that fails (a full disk, a file system gone) must stop the file quietly
and be told once: the SDK would log an error for every later message instead,
so the file it writes to is a ``_GuardedFile`` that keeps the first error and
drops everything after it; the log asks ``failure`` after each flush.
"""

from __future__ import annotations

import io
import json
from pathlib import Path
from typing import Any

import foxglove
from foxglove.mcap import MCAPCompression, MCAPWriteOptions

#: Bytes gathered before they are handed to the file.
BUFFER_BYTES = 1 << 20


class _GuardedFile(io.RawIOBase):
    """A buffered binary file that never raises: after the first error it drops every
    write (keeping what reached the file) and remembers the error in ``error``.

    Positions are its own count of the bytes written (the writer checks them, and
    must see the same whether or not the bytes reached the disk). Buffered here, not
    by ``io.BufferedWriter``: the writer asks for its position before most writes (a
    seek to where it is), which would flush that buffer every time."""

    def __init__(self, path: Path) -> None:
        super().__init__()
        self._file = open(path, "wb")  # noqa: SIM115 - closed in close()
        self._pending = bytearray()
        self._position = 0
        self._length = 0
        self.error: OSError | None = None

    def writable(self) -> bool:
        return True

    def seekable(self) -> bool:
        return True

    def write(self, data: Any) -> int:
        size = len(data)
        self._pending += data
        self._position += size
        self._length = max(self._length, self._position)
        if len(self._pending) >= BUFFER_BYTES:
            self.flush()
        return size

    def seek(self, offset: int, whence: int = io.SEEK_SET) -> int:
        base = {io.SEEK_SET: 0, io.SEEK_CUR: self._position, io.SEEK_END: self._length}
        target = base[whence] + offset
        if target != self._position:
            self.flush()
            if self.error is None:
                try:
                    self._file.seek(target)
                except OSError as exc:
                    self.error = exc
            self._position = target
        return target

    def tell(self) -> int:
        return self._position

    def flush(self) -> None:
        pending, self._pending = self._pending, bytearray()
        if self.error is not None or not pending:
            return
        try:
            self._file.write(pending)
            self._file.flush()
        except OSError as exc:
            self.error = exc

    def close(self) -> None:
        if self.closed:
            return
        self.flush()
        try:
            self._file.close()
        except OSError as exc:
            self.error = self.error or exc
        super().close()


class Channel:
    """One topic of the file; ``log`` writes a message."""

    def __init__(self, base: Any) -> None:
        self._base = base

    def log(self, data: bytes, log_time: int) -> None:
        """One message, stamped ``log_time`` (UTC nanoseconds)."""
        self._base.log(data, log_time)


class McapFile:
    """An MCAP file being written: JSON channels with JSON schemas, raw channels
    without; messages stamped with UTC nanoseconds."""

    def __init__(self, path: Path, *, profile: str, chunk_size: int) -> None:
        self._file = _GuardedFile(path)
        self._context = foxglove.Context()
        options = MCAPWriteOptions(
            compression=MCAPCompression.Zstd, profile=profile, chunk_size=chunk_size
        )
        self._writer = foxglove.open_mcap(self._file, context=self._context, writer_options=options)
        self._schemas: dict[str, foxglove.Schema] = {}
        self._closed = False

    @property
    def failure(self) -> OSError | None:
        """The first error writing the file, if any (everything after it was dropped)."""
        return self._file.error

    def channel(
        self,
        topic: str,
        *,
        encoding: str,
        schema_name: str | None = None,
        schema: dict[str, Any] | None = None,
        metadata: dict[str, str] | None = None,
    ) -> Channel:
        """A channel on ``topic``: JSON with the named JSON schema, or raw bytes."""
        described = None
        if schema_name is not None and schema is not None:
            described = self._schemas.get(schema_name)
            if described is None:
                data = json.dumps(schema).encode()
                described = foxglove.Schema(name=schema_name, encoding="jsonschema", data=data)
                self._schemas[schema_name] = described
        # The SDK's channel class refuses a raw channel without a schema, which MCAP
        # allows (the MAVLink frames are one); its context makes any channel.
        base = self._context._create_channel(
            topic, message_encoding=encoding, schema=described, metadata=metadata or {}
        )
        return Channel(base)

    def flush(self) -> None:
        """End the current chunk and hand it to the OS."""
        if not self._closed:
            self._writer.flush()
            self._file.flush()

    def close(self) -> None:
        """Write the summary and close the file."""
        if self._closed:
            return
        self._closed = True
        try:
            self._writer.close()
        finally:
            self._file.close()
