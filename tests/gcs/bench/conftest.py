"""What the bench tests share."""

from __future__ import annotations

import pytest

from gcs.bench import plans as bench_plans


@pytest.fixture
def planner_failing_on_seed_2(monkeypatch: pytest.MonkeyPatch) -> None:
    """``gcs bench plans``' planner runs raise on the maps of seed 2, as a planner bug
    would (patched where the bench calls it; in-process workers see it too)."""
    real = bench_plans.simulate

    def failing_on_seed_2(mission, options):
        if mission.name.endswith("-2"):
            raise RuntimeError("planner bug")
        return real(mission, options)

    monkeypatch.setattr(bench_plans, "simulate", failing_on_seed_2)
