"""One percentile for every figure the ground station and its benchmarks report."""

from __future__ import annotations

import statistics
from collections.abc import Sequence


def percentile(values: Sequence[float], q: float) -> float:
    """The ``q``-th percentile (0-100, interpolated between samples); nan when empty."""
    if not values:
        return float("nan")
    if len(values) == 1 or q <= 0:
        return min(values)
    if q >= 100:
        return max(values)
    cuts = statistics.quantiles(values, n=100, method="inclusive")
    return cuts[min(98, max(0, round(q) - 1))]
