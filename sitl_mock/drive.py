"""How an ArduPilot Rover drives to a point: the mock's ground-vehicle dynamics.

Observed on ArduPilot's own SITL Rover (see ``ARDUPILOT.md`` of the project):
a new target restarts the path from where the rover would stop; a point
moving along the straight track from there to the target (the s-curve
target of ArduPilot's ``AR_WPNav``) speeds up, cruises and stops on the
target, and the rover chases it and lags behind it. The target counts as
reached (MISSION_ITEM_REACHED) once the moving point is there and the rover
is within WP_RADIUS of it or past the line through it square to the track;
the rover then brakes where it is, often short of the target. A car turns
no tighter than its turning radius, so it cannot put itself on a point
beside it; a skid-steered rover stops and pivots when the target lies more
than WP_PIVOT_ANGLE off its nose. In HOLD the motors stop and the rover
rolls on until friction stops it.

``Drive`` holds the rover's speed, heading and the leg it is on; each
``step`` says which way to go and how far, and the vehicle moves there (or
is stopped by a wall).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import StrEnum

from core.geo import bearing_deg, wrap_deg

#: Below this a rover counts as standing still (m/s).
STOPPED_M_S = 0.05
#: A pivot ends within this many degrees of the wanted heading (AR_PIVOT_ANGLE_ACCURACY).
PIVOT_DONE_DEG = 5.0
#: Nearer than this the moving target point gives no direction: steer for the destination.
CLOSE_M = 0.2
#: The slowest a car creeps while it steers round to a target behind it (m/s).
CAR_CREEP_M_S = 0.3


class Steering(StrEnum):
    SKID = "skid"
    CAR = "car"


#: How fast SITL's skid-steered rover slows down in HOLD (m/s/s).
SKID_COAST_M_S2 = 1.9


@dataclass(frozen=True)
class DriveSettings:
    """A rover's driving, with ArduPilot's parameter names where there is one."""

    steering: Steering = Steering.SKID
    #: WP_RADIUS: a target is reached within this distance (or past its finish line).
    wp_radius_m: float = 2.0
    #: Speeding up and braking under control (ATC_ACCEL_MAX, ATC_DECEL_MAX).
    accel_m_s2: float = 1.0
    brake_m_s2: float = 1.0
    #: Slowing down with the motors off (HOLD): rolling resistance only. SITL's car set
    #: to HOLD at 2.3-2.6 m/s rolled 4.7-5.1 m (about 0.65 m/s/s); its skid rover, at
    #: 2.1 m/s, 1.15 m (``SKID_COAST_M_S2``).
    coast_m_s2: float = 0.65
    #: TURN_RADIUS: the tightest circle a car can drive.
    turn_radius_m: float = 0.9
    #: Fastest turn while driving (ATC_STR_RAT_MAX).
    turn_rate_deg_s: float = 120.0
    #: WP_PIVOT_ANGLE and WP_PIVOT_RATE: a skid rover pivots in place when the target is
    #: further than this off its nose, at this rate.
    pivot_angle_deg: float = 60.0
    pivot_rate_deg_s: float = 60.0
    #: How hard the rover chases the moving target point (1/s): its lag behind it.
    chase_gain_1_s: float = 1.0
    #: How much the target point slows for each metre the rover lags behind it (1/s;
    #: ArduPilot's PSC_POS_P): the lag it settles at is 0.05 x speed / this.
    track_gain_1_s: float = 0.2

    def __post_init__(self) -> None:
        positive = ("accel_m_s2", "brake_m_s2", "coast_m_s2", "turn_radius_m", "chase_gain_1_s")
        for name in positive:
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be positive, got {getattr(self, name)}")


@dataclass
class Leg:
    """One straight track from ``origin`` to ``destination`` (north, east in metres)."""

    origin: tuple[float, float]
    destination: tuple[float, float]
    #: How far along the track the moving target point is, and its speed.
    along_m: float = 0.0
    speed_m_s: float = 0.0
    reached: bool = False

    @property
    def length_m(self) -> float:
        return math.dist(self.origin, self.destination)

    @property
    def finished(self) -> bool:
        return self.along_m >= self.length_m - 1e-6

    def point(self) -> tuple[float, float]:
        length = self.length_m
        if length <= 1e-9:
            return self.destination
        f = min(1.0, self.along_m / length)
        (n0, e0), (n1, e1) = self.origin, self.destination
        return (n0 + (n1 - n0) * f, e0 + (e1 - e0) * f)

    def past_finish_line(self, north: float, east: float) -> bool:
        (n0, e0), (n1, e1) = self.origin, self.destination
        return (north - n1) * (n1 - n0) + (east - e1) * (e1 - e0) > 0.0


class Drive:
    """The driving state of one rover: speed along its heading, and the leg it follows."""

    def __init__(self, settings: DriveSettings) -> None:
        self.settings = settings
        self.speed_m_s = 0.0
        self.leg: Leg | None = None
        self.pivoting = False
        #: Brake to a stop under control (GUIDED with no target, or a target reached).
        self.braking = True
        #: Driving backwards (MAV_CMD_DO_SET_REVERSE): the tail leads.
        self.reversed = False

    @property
    def stopped(self) -> bool:
        return self.speed_m_s < STOPPED_M_S

    def stopping_point(self, north: float, east: float, heading_deg: float) -> tuple[float, float]:
        """Where the rover comes to rest if it brakes now."""
        run = self.speed_m_s**2 / (2.0 * self.settings.brake_m_s2)
        h = math.radians(self._travel(heading_deg))
        return (north + run * math.cos(h), east + run * math.sin(h))

    def go(self, north: float, east: float, heading_deg: float, to: tuple[float, float]) -> None:
        """A new target: the track starts at the rover's stopping point."""
        start = self.stopping_point(north, east, heading_deg)
        self.leg = Leg(start, to)
        self.braking = False

    def then(self, to: tuple[float, float]) -> None:
        """The next waypoint of a mission: the track runs on from the last one."""
        assert self.leg is not None
        self.leg = Leg(self.leg.destination, to, speed_m_s=self.leg.speed_m_s)
        self.braking = False

    def stop(self) -> None:
        """Brake to a stop under control; the leg (the target) is kept."""
        self.braking = True
        self.pivoting = False

    def release(self) -> None:
        """Motors off (HOLD, MANUAL without a pilot): roll to a stop."""
        self.leg = None
        self.braking = False
        self.pivoting = False

    def halt(self) -> None:
        """Stopped dead (by a wall)."""
        self.speed_m_s = 0.0
        self.pivoting = False
        self.braking = True

    def _travel(self, heading_deg: float) -> float:
        """The direction the rover moves in: its nose, or its tail when reversing."""
        return (heading_deg + 180.0) % 360.0 if self.reversed else heading_deg

    def step(
        self, north: float, east: float, heading_deg: float, cruise_m_s: float, dt_s: float
    ) -> tuple[float, float, float]:
        """The new heading, the direction of travel (the heading, or its opposite when
        reversing) and the distance to drive along it in ``dt_s``."""
        travel = self._travel(heading_deg)
        travel, metres = self._step(north, east, travel, cruise_m_s, dt_s)
        return self._travel(travel), travel, metres

    def _step(
        self, north: float, east: float, heading_deg: float, cruise_m_s: float, dt_s: float
    ) -> tuple[float, float]:
        s = self.settings
        leg = self.leg
        if leg is None or self.braking or leg.reached:
            decel = s.brake_m_s2 if (self.braking or leg is not None) else s.coast_m_s2
            self.speed_m_s = max(0.0, self.speed_m_s - decel * dt_s)
            return heading_deg, self.speed_m_s * dt_s
        point_m_s = self._advance_point(leg, cruise_m_s, dt_s, (north, east, heading_deg))
        pn, pe = leg.point()
        gap = math.hypot(pn - north, pe - east)
        # Steer for the moving point; while it is close, for the destination (where
        # ArduPilot's pivot looks too). Chase the point, slowing when ahead of it.
        ahead_m = gap
        if gap >= 0.02:
            ahead_m = gap * math.cos(math.radians(bearing_deg(pn - north, pe - east) - heading_deg))
        wanted_speed = min(cruise_m_s, max(0.0, point_m_s + s.chase_gain_1_s * ahead_m))
        if gap < CLOSE_M:
            pn, pe = leg.destination
        far = math.hypot(pn - north, pe - east) >= 0.02
        error = wrap_deg(bearing_deg(pn - north, pe - east) - heading_deg) if far else 0.0
        to_go = math.dist((north, east), leg.destination)
        heading_deg, wanted_speed = self._steer(heading_deg, error, wanted_speed, to_go, dt_s)
        self._throttle(wanted_speed, dt_s)
        return heading_deg % 360.0, self.speed_m_s * dt_s

    def check_reached(self, north: float, east: float) -> bool:
        """Whether the leg has just been reached (once per leg)."""
        leg = self.leg
        if leg is None or leg.reached or not leg.finished:
            return False
        near = math.dist((north, east), leg.destination) <= self.settings.wp_radius_m
        if near or leg.past_finish_line(north, east):
            leg.reached = True
            return True
        return False

    # -- inside a step ------------------------------------------------------------------

    def _advance_point(
        self, leg: Leg, cruise_m_s: float, dt_s: float, pose: tuple[float, float, float]
    ) -> float:
        """Move the target point on along the track: speeding up to the cruise speed and
        stopping on the destination, but slowed down while the rover does not keep up (a
        pivot, a wide turn), as ArduPilot scales its s-curve's time. Returns its speed."""
        s = self.settings
        left = max(0.0, leg.length_m - leg.along_m)
        speed = min(
            cruise_m_s, leg.speed_m_s + s.accel_m_s2 * dt_s, math.sqrt(2 * s.brake_m_s2 * left)
        )
        leg.speed_m_s = speed
        length = leg.length_m
        scale = 1.0
        if speed > 1e-6 and length > 1e-9:
            north, east, heading_deg = pose
            (n0, e0), (n1, e1) = leg.origin, leg.destination
            un, ue = (n1 - n0) / length, (e1 - e0) / length
            pn, pe = leg.point()
            behind_m = (pn - north) * un + (pe - east) * ue
            h = math.radians(heading_deg)
            along_m_s = self.speed_m_s * (math.cos(h) * un + math.sin(h) * ue)
            keep_up = (along_m_s - s.track_gain_1_s * behind_m) / speed
            scale = min(1.0, max(0.0, 0.05 + keep_up))
        leg.along_m = min(length, leg.along_m + speed * scale * dt_s)
        return speed * scale

    def _steer(
        self, heading_deg: float, error_deg: float, wanted_speed: float, to_go_m: float, dt_s: float
    ) -> tuple[float, float]:
        s = self.settings
        if s.steering is Steering.SKID:
            if self.pivoting or abs(error_deg) > s.pivot_angle_deg:
                self.pivoting = True
                if not self.stopped:
                    return heading_deg, 0.0  # stop first, then pivot
                turn = math.copysign(min(abs(error_deg), s.pivot_rate_deg_s * dt_s), error_deg)
                if abs(error_deg - turn) <= PIVOT_DONE_DEG:
                    self.pivoting = False
                return heading_deg + turn, 0.0
            turn = math.copysign(min(abs(error_deg), s.turn_rate_deg_s * dt_s), error_deg)
            return heading_deg + turn, wanted_speed * max(0.0, math.cos(math.radians(error_deg)))
        # A car: turns only while it rolls, no tighter than its turning circle. It creeps
        # round to a target off its nose; one it has just passed, it cannot turn back to.
        if to_go_m < 1.0 and abs(error_deg) > 90.0:
            return heading_deg, 0.0
        if abs(error_deg) > 1.0 and to_go_m > CLOSE_M:
            wanted_speed = max(
                CAR_CREEP_M_S, wanted_speed * max(0.0, math.cos(math.radians(error_deg)))
            )
        rate = math.degrees(self.speed_m_s / s.turn_radius_m)
        limit = min(rate, s.turn_rate_deg_s) * dt_s
        turn = math.copysign(min(abs(error_deg), limit), error_deg)
        return heading_deg + turn, wanted_speed

    def _throttle(self, wanted_m_s: float, dt_s: float) -> None:
        s = self.settings
        if wanted_m_s > self.speed_m_s:
            self.speed_m_s = min(wanted_m_s, self.speed_m_s + s.accel_m_s2 * dt_s)
        else:
            self.speed_m_s = max(wanted_m_s, self.speed_m_s - s.brake_m_s2 * dt_s)
