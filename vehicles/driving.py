"""How a vehicle moves, as its own settings say: acceptance radius, speed, turns.

A ground station that times a move from one cell's straight-line distance
alone gives up on a rover pivoting at a corner, and one that demands
arrival tighter than the autopilot's own acceptance radius waits for ever.
``read_driving_limits`` reads the figures the autopilot flavour names
(ArduPilot Rover: WP_RADIUS, WP_SPEED, WP_PIVOT_RATE, TURN_RADIUS; PX4:
NAV_ACC_RAD); ``DrivingLimits`` estimates from them how long a move takes.
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import math
from dataclasses import dataclass

from vehicles.errors import LinkError
from vehicles.link import VehicleLink

log = logging.getLogger(__name__)

#: ArduPilot Rover's defaults when a parameter cannot be read (WP_PIVOT_RATE, TURN_RADIUS).
DEFAULT_PIVOT_RATE_DEG_S = 60.0
DEFAULT_TURN_RADIUS_M = 0.9
#: Time allowed to reach cruise speed and stop again (a move of a cell or two is mostly
#: speeding up and braking).
SPEED_UP_AND_STOP_S = 2.0


@dataclass(frozen=True)
class DrivingLimits:
    """What the vehicle's own settings say; None where it did not tell."""

    acceptance_radius_m: float | None = None
    speed_m_s: float | None = None
    pivot_rate_deg_s: float | None = None
    turn_radius_m: float | None = None

    def cruise_m_s(self, planned_m_s: float) -> float:
        """The speed to time moves with: the mission's, or the vehicle's when slower."""
        if self.speed_m_s is not None and 0 < self.speed_m_s < planned_m_s:
            return self.speed_m_s
        return planned_m_s

    def turn_s(self, angle_deg: float, *, car: bool, speed_m_s: float) -> float:
        """Time to turn by ``angle_deg``: a pivot in place, or for a car the arc of its
        turning circle at a creep (a car cannot turn standing still)."""
        angle = abs(angle_deg)
        if car:
            radius = self.turn_radius_m or DEFAULT_TURN_RADIUS_M
            creep = min(speed_m_s, 0.5)
            return math.radians(angle) * radius / creep
        rate = self.pivot_rate_deg_s or DEFAULT_PIVOT_RATE_DEG_S
        return angle / rate


async def read_driving_limits(link: VehicleLink) -> DrivingLimits:
    """The limits the vehicle's flavour names, each read once; one that cannot be read
    (not there, no answer) stays None."""
    profile = link.profile
    if profile is None:
        return DrivingLimits()
    found: dict[str, float] = {}
    for field, param in profile.flavour.limit_params(profile.kind).items():
        with contextlib.suppress(LinkError):
            value = await link.read_param(param.name)
            if math.isfinite(value) and value > 0:
                found[field] = value * param.scale
    log.info("system %s drives with %s", link.target_system, found)
    return dataclasses.replace(DrivingLimits(), **found)
