"""A thread that carries bytes between test peers until its ``with`` block ends."""

from __future__ import annotations

import threading
from types import TracebackType
from typing import Self


class Relay:
    """Subclasses carry what is ready in ``relay_once`` (waiting at most ``wait_s``) and
    free what they hold in ``close``."""

    wait_s = 0.05

    def __init__(self, name: str) -> None:
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)

    def __enter__(self) -> Self:
        self._thread.start()
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self._stop.set()
        self._thread.join(timeout=5)
        self.close()

    def _run(self) -> None:
        while not self._stop.is_set():
            self.relay_once()

    def relay_once(self) -> None:
        raise NotImplementedError

    def close(self) -> None:
        raise NotImplementedError
