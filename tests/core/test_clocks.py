"""Injected time (``core.clocks``): sped-up simulated time and a clock tests move."""

from __future__ import annotations

import asyncio

import pytest

from core.clocks import ManualClock, ScaledClock


def test_a_scaled_clock_runs_speedup_times_faster() -> None:
    clock = ScaledClock(20.0)
    assert clock.to_real(10.0) == 0.5
    t0 = clock.now()

    async def nap() -> None:
        await clock.sleep(1.0)  # 50 ms of real time

    asyncio.run(nap())
    assert clock.now() - t0 >= 1.0


def test_a_scaled_clock_needs_a_positive_speedup() -> None:
    with pytest.raises(ValueError, match="positive"):
        ScaledClock(0.0)


def test_a_manual_clock_wakes_its_sleepers_in_order_when_advanced() -> None:
    clock = ManualClock(start=5.0)
    woke: list[str] = []

    async def sleeper(name: str, seconds: float) -> None:
        await clock.sleep(seconds)
        woke.append(f"{name}@{clock.now():g}")

    async def run() -> None:
        tasks = [asyncio.create_task(sleeper(n, s)) for n, s in (("b", 3.0), ("a", 1.0))]
        await asyncio.sleep(0)
        clock.advance(2.0)
        await asyncio.sleep(0)
        assert woke == ["a@7"]
        clock.advance(2.0)
        await asyncio.gather(*tasks)

    asyncio.run(run())
    assert woke == ["a@7", "b@9"]
    assert clock.to_real(100.0) == 0.0
