"""Battery physics of a mock vehicle: what drains it, what charges it, what it reports.

Remaining charge is the model's state; voltage, current, consumed charge and
charge state are derived from it so that every telemetry field tells the
same story. The ground station is meant to plan on remaining percent and
consumed mAh (as ArduPilot reports them), so voltage is only a plausible
4S LiPo curve.

Energy use follows the mission file: ``energy_per_m_pct`` percent per metre
moved, plus (for copters) ``hover_drain_pct_s`` percent per second airborne.
As on ArduPilot's analog battery monitor (BATT_MONITOR 4), the remaining
charge is counted down from the charge consumed and never rises by itself:
a charge on the pad shows only once the ground station says so with
MAV_CMD_BATTERY_RESET (``reset``), as after a battery swap. With
``pad_charging`` the pack instead charges itself while disarmed on a pad, as
a smart battery that reports its own state would. Noise and sudden sags
come from a seeded random source so runs repeat exactly.
"""

from __future__ import annotations

import bisect
import random
from dataclasses import dataclass
from enum import IntEnum

from pymavlink.dialects.v20 import ardupilotmega as mavlink


class ChargeState(IntEnum):
    """MAV_BATTERY_CHARGE_STATE as reported in BATTERY_STATUS."""

    OK = mavlink.MAV_BATTERY_CHARGE_STATE_OK
    LOW = mavlink.MAV_BATTERY_CHARGE_STATE_LOW
    CRITICAL = mavlink.MAV_BATTERY_CHARGE_STATE_CRITICAL
    EMERGENCY = mavlink.MAV_BATTERY_CHARGE_STATE_EMERGENCY
    FAILED = mavlink.MAV_BATTERY_CHARGE_STATE_FAILED
    CHARGING = mavlink.MAV_BATTERY_CHARGE_STATE_CHARGING


#: Resting voltage of one LiPo cell against state of charge (percent, volts).
LIPO_CELL_CURVE: tuple[tuple[float, float], ...] = (
    (0.0, 3.30),
    (5.0, 3.50),
    (10.0, 3.60),
    (20.0, 3.70),
    (40.0, 3.78),
    (60.0, 3.85),
    (80.0, 3.97),
    (100.0, 4.20),
)


#: No pack voltage below this per cell, however hard it is loaded.
_CELL_CUTOFF_V = 3.0


@dataclass(frozen=True)
class BatterySag:
    """A sudden loss of charge: at ``at_s`` seconds of vehicle time, drop ``drop_pct``."""

    at_s: float
    drop_pct: float


@dataclass(frozen=True)
class BatterySettings:
    capacity_mah: float = 5000.0
    energy_per_m_pct: float = 0.1
    hover_drain_pct_s: float = 0.05
    charge_rate_pct_s: float = 1.0
    start_pct: float = 100.0
    #: Charges itself while disarmed on a pad (a smart battery); False: only a
    #: MAV_CMD_BATTERY_RESET raises the remaining charge (ArduPilot's default monitor).
    pad_charging: bool = False
    cells: int = 4
    #: Voltage drop per amp drawn. 0 by default: mission energy figures can imply currents
    #: far beyond a real pack's, and ArduPilot's simulated voltage hardly moves either.
    internal_resistance_ohm: float = 0.0
    #: Remaining charge at which the vehicle reports its battery low, critical and in
    #: emergency (and says so). 0: never, as ArduPilot by default (BATT_LOW_VOLT and
    #: BATT_LOW_MAH are 0 on a Rover; a Copter's 10.5 V is an empty 4S pack), so its
    #: warnings never contradict the station's own reserve.
    low_pct: float = 0.0
    critical_pct: float = 0.0
    emergency_pct: float = 0.0
    #: Every drain is multiplied by ``1 + U(-noise_fraction, +noise_fraction)``.
    noise_fraction: float = 0.0
    sags: tuple[BatterySag, ...] = ()

    def __post_init__(self) -> None:
        if self.capacity_mah <= 0:
            raise ValueError(f"capacity_mah must be positive, got {self.capacity_mah}")
        if not 0.0 <= self.noise_fraction < 1.0:
            raise ValueError(f"noise_fraction must be in [0, 1), got {self.noise_fraction}")
        if not 0.0 < self.start_pct <= 100.0:
            raise ValueError(f"start_pct must be in (0, 100], got {self.start_pct}")


class Battery:
    """State of charge of one pack, advanced by the vehicle's ``step``."""

    def __init__(self, settings: BatterySettings, rng: random.Random | None = None) -> None:
        self.settings = settings
        self.remaining_pct = settings.start_pct
        self.current_a = 0.0
        self.charging = False
        self._rng = rng or random.Random(0)
        self._pending_sags = sorted(settings.sags, key=lambda s: s.at_s)

    @property
    def empty(self) -> bool:
        return self.remaining_pct <= 0.0

    def _noisy(self, pct: float) -> float:
        noise = self.settings.noise_fraction
        if noise == 0.0 or pct == 0.0:
            return pct
        return pct * (1.0 + self._rng.uniform(-noise, noise))

    def _pct_s_to_amps(self, pct_per_s: float) -> float:
        """Current that moves ``pct_per_s`` percent of the capacity per second."""
        return pct_per_s / 100.0 * self.settings.capacity_mah / 1000.0 * 3600.0

    def step(
        self,
        dt_s: float,
        *,
        moved_m: float,
        airborne: bool,
        can_charge: bool,
        vehicle_time_s: float,
    ) -> float:
        """Advance by ``dt_s``; returns the sag (percent) that happened in this step, if any."""
        if dt_s <= 0.0 or self.empty:
            return 0.0
        drain = moved_m * self.settings.energy_per_m_pct
        if airborne:
            drain += dt_s * self.settings.hover_drain_pct_s
        drain = self._noisy(drain)
        gain = 0.0
        self.charging = can_charge and self.settings.pad_charging and self.remaining_pct < 100.0
        if self.charging:
            gain = min(dt_s * self.settings.charge_rate_pct_s, 100.0 - self.remaining_pct)
        sag = 0.0
        while self._pending_sags and self._pending_sags[0].at_s <= vehicle_time_s:
            sag += self._pending_sags.pop(0).drop_pct
        self.remaining_pct = min(100.0, max(0.0, self.remaining_pct - drain - sag + gain))
        self.current_a = self._pct_s_to_amps((drain - gain) / dt_s)
        return sag

    def reset(self, remaining_pct: float) -> None:
        """MAV_CMD_BATTERY_RESET: the pack is now at ``remaining_pct`` (0-100), as after
        a swap; the charge consumed is counted from there."""
        if not self.empty:
            self.remaining_pct = min(100.0, max(0.0, remaining_pct))

    @property
    def consumed_mah(self) -> float:
        """Charge drawn from a full pack (so that remaining = 1 - consumed / capacity)."""
        return (100.0 - self.remaining_pct) / 100.0 * self.settings.capacity_mah

    @property
    def voltage_v(self) -> float:
        """Pack voltage: the cell curve at this charge, less the drop across the internal
        resistance under load."""
        pcts = [p for p, _ in LIPO_CELL_CURVE]
        i = bisect.bisect_left(pcts, self.remaining_pct)
        if i <= 0:
            cell_v = LIPO_CELL_CURVE[0][1]
        elif i >= len(pcts):
            cell_v = LIPO_CELL_CURVE[-1][1]
        else:
            (p0, v0), (p1, v1) = LIPO_CELL_CURVE[i - 1], LIPO_CELL_CURVE[i]
            cell_v = v0 + (v1 - v0) * (self.remaining_pct - p0) / (p1 - p0)
        resting = cell_v * self.settings.cells
        loaded = resting - self.current_a * self.settings.internal_resistance_ohm
        return max(_CELL_CUTOFF_V * self.settings.cells, loaded)

    @property
    def charge_state(self) -> ChargeState:
        s = self.settings
        if self.empty:
            return ChargeState.FAILED
        if self.charging:
            return ChargeState.CHARGING
        if self.remaining_pct <= s.emergency_pct:
            return ChargeState.EMERGENCY
        if self.remaining_pct <= s.critical_pct:
            return ChargeState.CRITICAL
        if self.remaining_pct <= s.low_pct:
            return ChargeState.LOW
        return ChargeState.OK
