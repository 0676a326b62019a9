"""A serial cable between two programs on pseudo-terminals, that can be unplugged.

Each end is a pseudo-terminal whose device is reached through a stable link
(``vehicle_end``, ``station_end``), as ``/dev/serial/by-id`` names a radio.
A thread copies bytes between the two masters (what socat's ``pty,link=``
pair does). ``unplug`` closes the station's pseudo-terminal and removes its
link, as pulling a USB radio does (the station's reads fail at once); ``plug``
makes a new one under the same name.
"""

from __future__ import annotations

import contextlib
import os
import select
import threading
import tty
from pathlib import Path

from tests.relay import Relay


class _End:
    def __init__(self, link: Path) -> None:
        self.link = link
        self.master, self.slave = os.openpty()
        tty.setraw(self.slave)  # no echo, no line editing, from the first byte
        os.set_blocking(self.master, False)
        with contextlib.suppress(FileNotFoundError):
            link.unlink()
        link.symlink_to(os.ttyname(self.slave))

    def close(self) -> None:
        with contextlib.suppress(FileNotFoundError):
            self.link.unlink()
        for fd in (self.master, self.slave):
            with contextlib.suppress(OSError):
                os.close(fd)


class SerialCable(Relay):
    def __init__(self, folder: Path) -> None:
        super().__init__("serial-cable")
        self.vehicle_end = folder / "vehicle-radio"
        self.station_end = folder / "station-radio"
        self._lock = threading.Lock()
        self._vehicle = _End(self.vehicle_end)
        self._station: _End | None = _End(self.station_end)
        #: Bytes carried each way.
        self.to_station = 0
        self.to_vehicle = 0

    def close(self) -> None:
        with self._lock:
            self._vehicle.close()
            if self._station is not None:
                self._station.close()

    def unplug(self) -> None:
        with self._lock:
            if self._station is not None:
                self._station.close()
                self._station = None

    def plug(self) -> None:
        with self._lock:
            if self._station is None:
                self._station = _End(self.station_end)

    def relay_once(self) -> None:
        with self._lock:
            station = self._station
            fds = [self._vehicle.master] + ([station.master] if station else [])
        try:
            readable, _, _ = select.select(fds, [], [], self.wait_s)
        except (OSError, ValueError):
            return  # an end was closed meanwhile
        with self._lock:
            for fd in readable:
                if station is not self._station:
                    break  # unplugged meanwhile
                try:
                    data = os.read(fd, 65536)
                except OSError:
                    continue  # nobody on the far side of that terminal yet
                if fd == self._vehicle.master:
                    if station is not None:
                        self.to_station += _write(station.master, data)
                else:
                    self.to_vehicle += _write(self._vehicle.master, data)


def _write(fd: int, data: bytes) -> int:
    """Write what the terminal takes; the rest is lost, as on a radio link."""
    try:
        return os.write(fd, data)
    except OSError:
        return 0
