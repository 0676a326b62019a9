"""Range readings -> the planner's eight neighbour cell states (pure functions).

Each reading is a ray: DISTANCE_SENSOR gives one per 45-degree sector relative to
the heading (orientation NONE = forward, YAW_45 ... YAW_315 clockwise),
OBSTACLE_DISTANCE many narrow sectors clockwise from ``angle_offset`` in the body
frame (``rays_from_sensors``, ``rays_from_obstacles``). A ray is followed from
where the vehicle really stood when it measured: a real vehicle stops anywhere
inside its cell (ArduPilot Rover up to its WP_RADIUS short of the centre), and
from half a cell off the centre a wall in the next cell is met where, from the
centre, a free cell would have let the ray through. Where the vehicle stood is known
only to a few centimetres, so a ray must say a thing clearly enough that such an
error cannot turn it into the opposite.

Walls fill whole cells, so what a ray says of a neighbour cell follows from
where it crosses that cell's square (``neighbour_states``):

* a ray that goes right through a neighbour's inside (its square shrunk a little)
  says it is free;
* a ray that stops where it enters a neighbour says that neighbour is a wall,
  unless it enters near a corner, where the wall may be the cell beside it;
* anything else says nothing, and a neighbour nothing was said of, or of which
  rays disagree, stays UNKNOWN: the planner never overwrites what it was told,
  so an unsure reading must be UNKNOWN rather than a guess.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass

from core.cells import Cell, CellState, Direction
from core.geo import wrap_deg
from sitl_mock.gridmap import GridMap
from vehicles.telemetry import ObstacleDistances, RangeReading

#: DISTANCE_SENSOR orientations of the eight horizontal sectors: MAV_SENSOR_ROTATION_NONE (0)
#: is forward, YAW_45 (1) ... YAW_315 (7) go clockwise in 45-degree steps.
SECTOR_ORIENTATIONS = tuple(range(8))


@dataclass(frozen=True)
class SensingSettings:
    #: How far (cells) a ray's end may be from where it entered a cell and still be
    #: that cell's wall: ranges come in whole centimetres, and the vehicle may still
    #: creep a little while it measures.
    hit_margin_cells: float = 0.04
    #: A ray must enter a cell this far from its corners (cells) to say it is a wall; one
    #: that crosses less than 2.5 ``hit_margin_cells`` of a cell says nothing of it.
    corner_margin_cells: float = 0.12
    #: A ray says a neighbour is free only if it crosses the neighbour's square shrunk by
    #: this much (cells) on every side: seen from a place known to less than that, the
    #: real ray then went through the neighbour's inside, which a wall would have stopped.
    #: A ray that only cuts a corner says nothing of it.
    free_inset_cells: float = 0.06


DEFAULT_SENSING = SensingSettings()


#: Where a ray starts: cells east and north of the centre of the vehicle's cell.
Origin = tuple[float, float]
CENTRE: Origin = (0.0, 0.0)


@dataclass(frozen=True)
class Ray:
    """One range along a compass bearing, with the sensor's reach (metres), measured from
    ``origin`` (where the vehicle stood then)."""

    bearing_deg: float
    distance_m: float
    max_m: float
    origin: Origin = CENTRE


@dataclass(frozen=True)
class Pose:
    """Where a vehicle reported itself (local metres), its heading, and when (boot ms)."""

    north_m: float
    east_m: float
    heading_deg: float
    time_ms: int


#: Between the poses that bracket a range reading, a vehicle that turned more than this
#: (degrees) is not known to have pointed its sensors anywhere in particular: a ray off
#: by a few degrees passes a corner where the real one met the wall.
STILL_HEADING_DEG = 2.0


def still_between(before: Pose, after: Pose) -> bool:
    """Whether the vehicle held its heading between two poses."""
    return abs(wrap_deg(after.heading_deg - before.heading_deg)) <= STILL_HEADING_DEG


def pose_at(before: Pose, after: Pose, time_ms: int) -> Pose:
    """The pose at ``time_ms`` on the straight line between two reported poses (clamped
    to them)."""
    span = after.time_ms - before.time_ms
    f = 0.0 if span <= 0 else min(1.0, max(0.0, (time_ms - before.time_ms) / span))
    turn = wrap_deg(after.heading_deg - before.heading_deg)
    return Pose(
        before.north_m + f * (after.north_m - before.north_m),
        before.east_m + f * (after.east_m - before.east_m),
        (before.heading_deg + f * turn) % 360.0,
        time_ms,
    )


def rays_from_sensors(
    heading_deg: float, readings: Mapping[int, RangeReading], origin: Origin = CENTRE
) -> list[Ray]:
    """DISTANCE_SENSOR readings (by orientation) as compass rays. Orientations other than
    the eight horizontal sectors (pitch up/down, custom) are ignored."""
    return [
        Ray((heading_deg + 45.0 * orientation) % 360.0, reading.distance_m, reading.max_m, origin)
        for orientation, reading in readings.items()
        if orientation in SECTOR_ORIENTATIONS
    ]


def rays_from_obstacles(
    heading_deg: float, obstacles: ObstacleDistances, origin: Origin = CENTRE
) -> list[Ray]:
    """OBSTACLE_DISTANCE sectors (body frame, clockwise from ``angle_offset``) as compass
    rays; a sector with no measurement (None) gives none."""
    if obstacles.increment_deg <= 0:
        return []
    return [
        Ray(
            (heading_deg + obstacles.angle_offset_deg + i * obstacles.increment_deg) % 360.0,
            min(distance, obstacles.max_m),
            obstacles.max_m,
            origin,
        )
        for i, distance in enumerate(obstacles.distances_m)
        if distance is not None
    ]


def neighbour_states(
    rays: Iterable[Ray], cell_size_m: float, settings: SensingSettings = DEFAULT_SENSING
) -> dict[Direction, CellState]:
    """The eight neighbours' states from rays, each followed from its own origin (see the
    module's docstring)."""
    said: dict[Direction, set[CellState]] = {d: set() for d in Direction}
    for ray in rays:
        for direction, state in _ray_says(ray, cell_size_m, settings):
            said[direction].add(state)
    return {
        d: next(iter(states)) if len(states) == 1 else CellState.UNKNOWN
        for d, states in said.items()
    }


def _ray_says(
    ray: Ray, cell_size_m: float, settings: SensingSettings
) -> list[tuple[Direction, CellState]]:
    start = ray.origin
    theta = math.radians(ray.bearing_deg)
    step = (math.sin(theta), math.cos(theta))  # east, north per cell along the ray
    reach = ray.max_m / cell_size_m
    hit = ray.distance_m < ray.max_m - 1e-6
    end = ray.distance_m / cell_size_m if hit else reach
    margin, corner = settings.hit_margin_cells, settings.corner_margin_cells
    said: list[tuple[Direction, CellState]] = []
    for direction in Direction:
        span = _crossing(start, step, direction)
        if span is None:
            continue
        enter, leave = span
        if leave - enter < 2.5 * margin:
            continue  # only grazes a corner of the cell
        inside = _crossing(start, step, direction, settings.free_inset_cells)
        if inside is not None and end - margin >= inside[1]:
            said.append((direction, CellState.FREE))  # right through its inside
        elif hit and abs(end - enter) <= margin:
            at = (start[0] + step[0] * enter, start[1] + step[1] * enter)
            if not _near_corner(at, direction, corner):
                said.append((direction, CellState.OBSTACLE))
    return said


def _square(direction: Direction, inset: float = 0.0) -> tuple[float, float, float, float]:
    """The neighbour's square (shrunk by ``inset`` on every side), in cells east and north
    of the vehicle's cell's centre."""
    row, col = direction.value
    half = 0.5 - inset
    return col - half, col + half, -row - half, -row + half


def _crossing(
    start: tuple[float, float], step: tuple[float, float], direction: Direction, inset: float = 0.0
) -> tuple[float, float] | None:
    """Where a ray from ``start`` enters and leaves the neighbour's square (shrunk by
    ``inset``), in cells along the ray, or None if it misses it."""
    west, east, south, north = _square(direction, inset)
    enter, leave = 0.0, math.inf
    for position, speed, low, high in (
        (start[0], step[0], west, east),
        (start[1], step[1], south, north),
    ):
        if abs(speed) < 1e-12:
            if not low < position < high:
                return None
            continue
        t1, t2 = (low - position) / speed, (high - position) / speed
        enter, leave = max(enter, min(t1, t2)), min(leave, max(t1, t2))
    return (enter, leave) if enter < leave else None


def _near_corner(at: tuple[float, float], direction: Direction, margin: float) -> bool:
    west, east, south, north = _square(direction)
    near_x = min(abs(at[0] - west), abs(at[0] - east)) <= margin
    near_y = min(abs(at[1] - south), abs(at[1] - north)) <= margin
    return near_x and near_y


def readings_from_map(grid: GridMap, cell: Cell) -> dict[Direction, CellState]:
    """Readings of a vehicle that takes the map as known (``sensing: map``), from the
    operator's map of the mission (outside the map counts as an obstacle)."""
    return {
        d: CellState.FREE if grid.is_free(d.of(cell)) else CellState.OBSTACLE for d in Direction
    }
