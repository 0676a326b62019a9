"""A vehicle's stay on the charging pad, and how its autopilot learns the charge.

A smart battery (and the mock's self-charging pad) reports its own rising
charge: the ground station waits on the telemetry. ArduPilot's analog
monitor (BATT_MONITOR 4) counts the charge consumed and never rises by
itself: the ground station times the charge from the pad's rate and, when
it is done, tells the autopilot with MAV_CMD_BATTERY_RESET, as after a
battery swap, then checks that the telemetry shows it. ``Charging.AUTO``
waits on the telemetry, and resets only if it has not risen at all by the
time the charge should be done. A charge that takes much longer than it
should is given up, never waited on for ever.
"""

from __future__ import annotations

from dataclasses import dataclass

from gcs.mission import Charging

#: Telemetry this much above the charge at parking shows that the battery charges itself.
RISE_PCT = 1.0


@dataclass(frozen=True)
class ChargeSettings:
    #: A charge may take this many times its expected time, plus ``slack_s``, before it
    #: is reported and the vehicle kept out of the mission (mission seconds).
    time_factor: float = 2.0
    slack_s: float = 30.0
    #: Mission seconds for the telemetry to show a battery reset.
    reset_confirm_s: float = 10.0


@dataclass(frozen=True)
class PadStay:
    """One stay on the pad: from when, from what charge, to what, at what rate."""

    started_s: float
    start_pct: float
    target_pct: float
    rate_pct_s: float
    how: Charging

    @property
    def expected_s(self) -> float:
        return max(0.0, self.target_pct - self.start_pct) / self.rate_pct_s

    def estimate_pct(self, now_s: float) -> float:
        """The charge the pad has given by now."""
        gained = (now_s - self.started_s) * self.rate_pct_s
        return min(self.target_pct, self.start_pct + gained)

    def done(self, now_s: float) -> bool:
        return now_s - self.started_s >= self.expected_s

    def overdue(self, now_s: float, settings: ChargeSettings) -> bool:
        return now_s - self.started_s > settings.time_factor * self.expected_s + settings.slack_s

    def limit_s(self, settings: ChargeSettings) -> float:
        return settings.time_factor * self.expected_s + settings.slack_s

    def rises(self, telemetry_pct: float) -> bool:
        """Whether the telemetry shows the battery charging itself."""
        return telemetry_pct >= self.start_pct + RISE_PCT

    def needs_reset(self, now_s: float, telemetry_pct: float, risen: bool) -> bool:
        """Time to tell the autopilot its charge: the charge is done, the telemetry does
        not show it, and (``AUTO``) it never rose by itself."""
        if self.how == Charging.TELEMETRY or not self.done(now_s):
            return False
        if telemetry_pct >= self.target_pct - RISE_PCT:
            return False
        return self.how == Charging.RESET or not risen
