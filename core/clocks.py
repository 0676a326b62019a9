"""Injected time: the simulation runs faster than real time and tests stay deterministic.

Every component that needs time takes a ``Clock``. ``ScaledClock`` runs
``speedup`` seconds of simulated time per real second; ``ManualClock`` only
moves when a test advances it.
"""

from __future__ import annotations

import asyncio
import time
from typing import Protocol


class Clock(Protocol):
    def now(self) -> float:
        """Simulated seconds since an arbitrary epoch."""
        ...

    async def sleep(self, seconds: float) -> None:
        """Wait ``seconds`` of simulated time (for periodic processes only)."""
        ...

    def to_real(self, seconds: float) -> float:
        """Real seconds that ``seconds`` of simulated time take."""
        ...


class ScaledClock:
    def __init__(self, speedup: float = 1.0) -> None:
        if speedup <= 0:
            raise ValueError(f"speedup must be positive, got {speedup}")
        self.speedup = speedup
        self._t0 = time.monotonic()

    def now(self) -> float:
        return (time.monotonic() - self._t0) * self.speedup

    async def sleep(self, seconds: float) -> None:
        await asyncio.sleep(max(0.0, seconds) / self.speedup)

    def to_real(self, seconds: float) -> float:
        return seconds / self.speedup


class ManualClock:
    """A clock that stands still until ``advance`` is called; sleepers wake in order."""

    def __init__(self, start: float = 0.0) -> None:
        self._now = start
        self._waiters: list[tuple[float, asyncio.Future[None]]] = []

    def now(self) -> float:
        return self._now

    async def sleep(self, seconds: float) -> None:
        fut: asyncio.Future[None] = asyncio.get_running_loop().create_future()
        self._waiters.append((self._now + max(0.0, seconds), fut))
        await fut

    def to_real(self, seconds: float) -> float:
        return 0.0

    def advance(self, seconds: float) -> None:
        self._now += seconds
        due = [w for w in self._waiters if w[0] <= self._now]
        self._waiters = [w for w in self._waiters if w[0] > self._now]
        for _, fut in sorted(due, key=lambda w: w[0]):
            if not fut.done():
                fut.set_result(None)
