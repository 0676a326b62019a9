"""A serial device on asyncio (pyserial), reopened when it disappears and comes back.

A telemetry radio on USB vanishes when it is unplugged or browns out, and its
device node (often a ``/dev/serial/by-id`` link) comes back a moment later.
``SerialPort`` reports every byte read to ``on_data``; when the device fails it
tells ``on_state(False)``, tries to open the same path again every
``reopen_s`` until it succeeds or the port is closed, then ``on_state(True)``.
Bytes written while the device is away are dropped (a radio link loses them
too; MAVLink's own retries recover what matters).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections.abc import Callable

import serial
import serial_asyncio_fast

log = logging.getLogger(__name__)

#: Pause between attempts to reopen a vanished device.
REOPEN_S = 0.5


class SerialPort:
    def __init__(
        self,
        device: str,
        baud: int,
        *,
        flow_control: bool = False,
        on_data: Callable[[bytes], None],
        on_state: Callable[[bool], None] | None = None,
        reopen_s: float = REOPEN_S,
    ) -> None:
        self.device = device
        self.baud = baud
        self.flow_control = flow_control
        self.reopen_s = reopen_s
        self._on_data = on_data
        self._on_state = on_state
        self._transport: asyncio.Transport | None = None
        self._closed = asyncio.Event()
        self._reopening: asyncio.Task[None] | None = None
        #: Times the device was opened again after it failed.
        self.reopens = 0

    @property
    def is_open(self) -> bool:
        return self._transport is not None and not self._transport.is_closing()

    async def open(self) -> None:
        """Open the device; ``OSError`` (pyserial's ``SerialException``) if it cannot."""
        loop = asyncio.get_running_loop()
        transport, _ = await serial_asyncio_fast.create_serial_connection(
            loop,
            lambda: _Protocol(self),
            self.device,
            baudrate=self.baud,
            rtscts=self.flow_control,
        )
        self._transport = transport

    def write(self, data: bytes) -> bool:
        """Write ``data``; False (dropped) while the device is away."""
        if not self.is_open:
            return False
        assert self._transport is not None
        self._transport.write(data)
        return True

    async def close(self) -> None:
        self._closed.set()
        if self._reopening is not None:
            self._reopening.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._reopening
        if self._transport is not None:
            self._transport.close()
            self._transport = None

    def _lost(self, exc: Exception | None) -> None:
        self._transport = None
        if self._closed.is_set():
            return
        log.warning("serial %s lost: %s; reopening", self.device, exc or "closed")
        if self._on_state is not None:
            self._on_state(False)
        if self._reopening is None or self._reopening.done():
            self._reopening = asyncio.get_running_loop().create_task(self._reopen())

    async def _reopen(self) -> None:
        while not self._closed.is_set():
            with contextlib.suppress(TimeoutError):
                async with asyncio.timeout(self.reopen_s):
                    await self._closed.wait()
                return
            try:
                await self.open()
            except (OSError, serial.SerialException) as exc:
                log.debug("serial %s still away: %s", self.device, exc)
                continue
            self.reopens += 1
            log.warning("serial %s back", self.device)
            if self._on_state is not None:
                self._on_state(True)
            return


class _Protocol(asyncio.Protocol):
    def __init__(self, owner: SerialPort) -> None:
        self._owner = owner

    def data_received(self, data: bytes) -> None:
        self._owner._on_data(data)

    def connection_lost(self, exc: Exception | None) -> None:
        self._owner._lost(exc)
