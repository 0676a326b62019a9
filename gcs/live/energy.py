"""Online estimate of a vehicle's battery use per metre, from its own telemetry.

The planner budgets every return on ``energy_per_m_pct``; on a live mission
that figure is not known in advance (payload, wind, wear, a different pack)
and must come from what the battery telemetry says while the vehicle moves.
The estimate is deliberately pessimistic:

* it starts from a prior taken from the vehicle model (``vehicles.models``);
* while little has been measured it uses a hard upper bound: autopilots
  report remaining charge in whole percent, so a reported drop of ``k``
  percent over ``d`` metres means a true drop below ``k + 1`` percent;
* once enough has been measured it uses an upper quantile of the rates
  measured over windows of a few percent each (so a sag or a noisy stretch
  counts, but one outlier does not rule for ever);
* everything is multiplied by a safety margin.

Charging (the remaining percentage going up) starts a new discharge; the
windows measured so far are kept. What a vehicle uses while it waits (a copter
hovering while held back, for instance) is left out (``pause``/``resume``): it
depends on how long the planner holds it, not on the metres it will fly, and
counted per metre it would send copters home early after every long wait (the
planner sees the battery fall while it waits and sends it home if need be).
"""

from __future__ import annotations

from dataclasses import dataclass

from vehicles.models import MODELS
from vehicles.modes import VehicleKind


@dataclass(frozen=True)
class EnergySettings:
    #: Every estimate is multiplied by this.
    margin: float = 1.3
    #: Quantile of the window rates used once there are ``min_windows`` of them.
    quantile: float = 0.9
    min_windows: int = 3
    #: A window closes when the reported remaining charge has fallen by this much.
    window_pct: float = 5.0
    #: Resolution of the reported remaining charge (whole percent on ArduPilot and PX4).
    resolution_pct: float = 1.0
    #: Before this distance of a discharge the bound is too loose to use: the prior rules.
    min_distance_m: float = 5.0
    #: Rates of a window are ignored when it covered less than this distance (a sag while
    #: standing still says nothing per metre; the battery level itself already shows it).
    min_window_m: float = 2.0

    def __post_init__(self) -> None:
        if self.margin < 1.0:
            raise ValueError("margin must be at least 1")
        if not 0.0 < self.quantile <= 1.0:
            raise ValueError("quantile must be in (0, 1]")


def model_prior(kind: VehicleKind) -> float:
    """The vehicle model's battery use per metre: where an estimate starts."""
    return MODELS[kind].drain_pct_per_m


class EnergyEstimator:
    """Battery percent per metre of one vehicle, from (distance moved, remaining %) samples."""

    def __init__(self, prior_pct_per_m: float, settings: EnergySettings | None = None) -> None:
        if prior_pct_per_m <= 0:
            raise ValueError("the prior must be positive")
        self.settings = settings or EnergySettings()
        self.prior_pct_per_m = prior_pct_per_m
        self.windows: list[float] = []
        self.odometer_m = 0.0
        self._last_pct: float | None = None
        # The current discharge, and the current window within it.
        self._discharge_start: tuple[float, float] | None = None  # (odometer, pct)
        self._window_start: tuple[float, float] | None = None
        #: The remaining charge reported when a wait began (``pause``), else None.
        self._paused_at: float | None = None

    def add(self, moved_m: float, remaining_pct: float) -> None:
        """``moved_m`` metres travelled since the previous sample; ``remaining_pct`` now."""
        if moved_m < 0:
            raise ValueError("moved_m must not be negative")
        self.odometer_m += moved_m
        last = self._last_pct
        self._last_pct = remaining_pct
        if last is None or remaining_pct > last:  # first sample, or charging
            self._discharge_start = (self.odometer_m, remaining_pct)
            self._window_start = (self.odometer_m, remaining_pct)
            if self._paused_at is not None:
                self._paused_at = remaining_pct
            return
        if remaining_pct < last and self._paused_at is None:
            assert self._window_start is not None
            start_m, start_pct = self._window_start
            if start_pct - remaining_pct >= self.settings.window_pct:
                distance = self.odometer_m - start_m
                if distance >= self.settings.min_window_m:
                    self.windows.append((start_pct - remaining_pct) / distance)
                # The next window starts where this change was seen, so its ends fall on
                # changes of the reported value and quantisation hardly matters.
                self._window_start = (self.odometer_m, remaining_pct)

    def pause(self) -> None:
        """The vehicle waits: what it uses until ``resume`` is not per metre."""
        if self._paused_at is None:
            self._paused_at = self._last_pct

    def resume(self) -> None:
        """The wait is over: the charge it used comes off the current discharge and
        window, as if the vehicle had not waited. Reports in whole percent hide up to
        one percent either way: one less is taken off, so that what was used moving is
        never taken for waiting (an estimate too low would let a vehicle go too far)."""
        paused_at, self._paused_at = self._paused_at, None
        last = self._last_pct
        if paused_at is None or last is None:
            return
        used = paused_at - last - self.settings.resolution_pct
        if used <= 0.0:
            return
        if self._discharge_start is not None:
            self._discharge_start = (self._discharge_start[0], self._discharge_start[1] - used)
        if self._window_start is not None:
            self._window_start = (self._window_start[0], self._window_start[1] - used)

    def _bound(self) -> float | None:
        """Upper bound of the rate over the current discharge (None: not enough distance)."""
        if self._discharge_start is None or self._last_pct is None:
            return None
        start_m, start_pct = self._discharge_start
        distance = self.odometer_m - start_m
        if distance < self.settings.min_distance_m:
            return None
        return (start_pct - self._last_pct + self.settings.resolution_pct) / distance

    @property
    def rate_pct_per_m(self) -> float:
        """The best guess without margin (for display and tests)."""
        s = self.settings
        if len(self.windows) >= s.min_windows:
            return _quantile(self.windows, s.quantile)
        bound = self._bound()
        if bound is None:
            return max([self.prior_pct_per_m, *self.windows])
        return max([bound, *self.windows])

    @property
    def estimate_pct_per_m(self) -> float:
        """What the planner should budget with: the rate with the safety margin."""
        return self.settings.margin * self.rate_pct_per_m


def _quantile(values: list[float], q: float) -> float:
    """Linear-interpolated quantile (as numpy's default), without numpy."""
    ordered = sorted(values)
    pos = q * (len(ordered) - 1)
    low = int(pos)
    high = min(low + 1, len(ordered) - 1)
    return ordered[low] + (ordered[high] - ordered[low]) * (pos - low)
