"""Range readings -> the planner's eight neighbour cell states (pure functions).

A vehicle stands at the centre of its cell. DISTANCE_SENSOR gives one range
per 45-degree sector relative to the heading (orientation NONE = forward,
YAW_45 ... YAW_315 clockwise); OBSTACLE_DISTANCE gives many narrow sectors
clockwise from ``angle_offset`` in the body frame. Both are turned into a
range per compass direction (``compass_ranges_*``), then into cell states
(``classify``).

The geometry, in cells from the centre of the vehicle's cell:

* straight ahead a wall in the neighbour cell is met at 0.5, while a free
  neighbour lets the ray go at least to its far edge at 1.5: below 1.0 is an
  obstacle, at or above is free;
* on a diagonal the ray passes the shared corner at 0.71 and, when the
  diagonal cell is free, reaches its far corner at 1.41. A short diagonal
  range only says that *one* of the three cells around that corner is a
  wall, so the diagonal is an obstacle only when both side neighbours are
  free, and unknown otherwise. The planner never overwrites what it was
  told, so an unsure reading must be UNKNOWN rather than a guess;
* OBSTACLE_DISTANCE's narrow sectors settle most of those: a ray a few
  degrees off the diagonal, on the side of a free neighbour, crosses that
  neighbour and enters the diagonal cell away from the corner. It stops
  inside the diagonal cell if that is a wall and goes on past its far edge
  if it is free (``diagonal_evidence``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

from planner.grid import Cell, CellState, Direction
from sitl_mock.gridmap import GridMap
from vehicles.telemetry import ObstacleDistances, RangeReading

#: DISTANCE_SENSOR orientations of the eight horizontal sectors: MAV_SENSOR_ROTATION_NONE (0)
#: is forward, YAW_45 (1) ... YAW_315 (7) go clockwise in 45-degree steps.
SECTOR_ORIENTATIONS = tuple(range(8))
ORTHOGONAL = (Direction.N, Direction.E, Direction.S, Direction.W)
#: A diagonal probe ray passing nearer the diagonal cell's corner than this (cells along
#: the ray) may have been stopped by a side cell: position and range are known to a
#: centimetre or so, and the vehicle may still be moving a little.
CORNER_CLEARANCE_CELLS = 0.05

DIAGONAL_SIDES: dict[Direction, tuple[Direction, Direction]] = {
    Direction.NE: (Direction.N, Direction.E),
    Direction.SE: (Direction.S, Direction.E),
    Direction.SW: (Direction.S, Direction.W),
    Direction.NW: (Direction.N, Direction.W),
}


@dataclass(frozen=True)
class SensingSettings:
    #: A straight range at or beyond this many cells means the neighbour is free.
    free_from_cells: float = 1.0
    #: A diagonal range at or beyond this many cells means the diagonal cell is free
    #: (halfway between the near corner, 0.71, and the far one, 1.41).
    diagonal_free_from_cells: float = (math.sqrt(0.5) + math.sqrt(2.0)) / 2
    #: A sector counts for a compass direction only if it points within this many degrees.
    align_tolerance_deg: float = 10.0
    #: Narrow sectors this far off a diagonal (degrees) are used to settle it.
    diagonal_probe_deg: tuple[float, float] = (4.0, 30.0)


DEFAULT_SENSING = SensingSettings()


def _angle_diff(a: float, b: float) -> float:
    return abs((a - b + 180.0) % 360.0 - 180.0)


def _direction_of(bearing_deg: float, tolerance_deg: float) -> Direction | None:
    """The compass direction a bearing points to, if it is within the tolerance."""
    best = min(Direction, key=lambda d: _angle_diff(d.heading_deg, bearing_deg))
    return best if _angle_diff(best.heading_deg, bearing_deg) <= tolerance_deg else None


@dataclass(frozen=True)
class Range:
    """One range in a compass direction, with the sensor's limits (metres)."""

    distance_m: float
    max_m: float


def compass_ranges_from_sensors(
    heading_deg: float,
    readings: Mapping[int, RangeReading],
    settings: SensingSettings = DEFAULT_SENSING,
) -> dict[Direction, Range]:
    """DISTANCE_SENSOR readings (by orientation) rotated by the heading into compass directions.

    Orientations other than the eight horizontal sectors (pitch up/down, custom) are ignored,
    and so is a sector that the heading does not align with a compass direction.
    """
    ranges: dict[Direction, Range] = {}
    for orientation, reading in readings.items():
        if orientation not in SECTOR_ORIENTATIONS:
            continue
        direction = _direction_of(heading_deg + 45.0 * orientation, settings.align_tolerance_deg)
        if direction is not None:
            ranges[direction] = Range(reading.distance_m, reading.max_m)
    return ranges


def compass_ranges_from_obstacles(
    heading_deg: float,
    obstacles: ObstacleDistances,
    settings: SensingSettings = DEFAULT_SENSING,
) -> dict[Direction, Range]:
    """OBSTACLE_DISTANCE sectors (body frame, clockwise from ``angle_offset``) in compass
    directions: for each direction the sector pointing closest to it, if close enough.
    A sector with no measurement (None) gives nothing."""
    best: dict[Direction, tuple[float, Range]] = {}
    if obstacles.increment_deg <= 0:
        return {}
    for i, distance in enumerate(obstacles.distances_m):
        if distance is None:
            continue
        bearing = heading_deg + obstacles.angle_offset_deg + i * obstacles.increment_deg
        direction = _direction_of(bearing, settings.align_tolerance_deg)
        if direction is None:
            continue
        error = _angle_diff(direction.heading_deg, bearing)
        if direction not in best or error < best[direction][0]:
            best[direction] = (error, Range(min(distance, obstacles.max_m), obstacles.max_m))
    return {d: r for d, (_, r) in best.items()}


def diagonal_evidence(
    heading_deg: float,
    obstacles: ObstacleDistances,
    cell_size_m: float,
    settings: SensingSettings = DEFAULT_SENSING,
    offset_cells: tuple[float, float] = (0.0, 0.0),
) -> dict[Direction, CellState]:
    """What the narrow OBSTACLE_DISTANCE sectors near each diagonal say of the diagonal cell.

    Each ray is followed from where the sensor is, ``offset_cells`` (east, north) from
    the cell's centre (a vehicle senses before it has quite stopped): stopping before it
    enters the diagonal cell says nothing (a side wall), stopping inside says wall,
    going past the far side says free. Any ray that says wall wins. From the centre a
    ray at ``phi`` from a side axis enters at ``max(0.5/cos phi, 0.5/sin phi)`` cells
    and leaves at ``min(1.5/cos phi, 1.5/sin phi)``; a few hundredths of a cell off
    the centre already move those points enough to turn a side wall into a diagonal one.
    """
    low, high = settings.diagonal_probe_deg
    found: dict[Direction, CellState] = {}
    if obstacles.increment_deg <= 0:
        return found
    margin = 0.02 * cell_size_m
    for i, distance in enumerate(obstacles.distances_m):
        if distance is None:
            continue
        bearing = (heading_deg + obstacles.angle_offset_deg + i * obstacles.increment_deg) % 360
        for diagonal in DIAGONAL_SIDES:
            if not low <= _angle_diff(diagonal.heading_deg, bearing) <= high:
                continue
            crossing = _crossing(offset_cells, bearing, diagonal)
            if crossing is None or crossing[2] < CORNER_CLEARANCE_CELLS:
                continue  # too near the corner to tell the diagonal cell from a side one
            enter, leave = crossing[0] * cell_size_m, crossing[1] * cell_size_m
            if distance < enter - margin:
                continue  # stopped by a side wall before the diagonal cell
            if distance < leave - margin and distance < obstacles.max_m - 1e-6:
                found[diagonal] = CellState.OBSTACLE
            elif distance >= leave - margin:
                found.setdefault(diagonal, CellState.FREE)
    return found


def _crossing(
    start: tuple[float, float], bearing_deg: float, diagonal: Direction
) -> tuple[float, float, float] | None:
    """Where a ray from ``start`` (cells east, north of the centre) along a compass
    bearing enters and leaves the ``diagonal`` neighbour cell, and how far (along the
    ray) from the cell's near corner it passes, in cells; None if it misses the cell."""
    theta = math.radians(bearing_deg)
    enter, leave = 0.0, math.inf
    near_lines: list[float] = []
    # Direction values are (rows south, cols east): the cell spans 0.5..1.5 on each axis
    # on the side the diagonal points to.
    for position, step, side in (
        (start[0], math.sin(theta), diagonal.value[1]),
        (start[1], math.cos(theta), -diagonal.value[0]),
    ):
        near, far = (0.5, 1.5) if side > 0 else (-1.5, -0.5)
        if abs(step) < 1e-12:
            if not near <= position <= far:
                return None
            continue
        t1, t2 = (near - position) / step, (far - position) / step
        enter, leave = max(enter, min(t1, t2)), min(leave, max(t1, t2))
        near_lines.append(min(t1, t2))
    if enter >= leave or len(near_lines) < 2:
        return None
    return enter, leave, abs(near_lines[0] - near_lines[1])


def classify(
    ranges: Mapping[Direction, Range],
    cell_size_m: float,
    settings: SensingSettings = DEFAULT_SENSING,
    diagonals: Mapping[Direction, CellState] | None = None,
) -> dict[Direction, CellState]:
    """Cell states of the eight neighbours from ranges measured at the cell's centre.

    A direction without a range, or with a sensor too short to tell, is UNKNOWN, unless
    ``diagonals`` (``diagonal_evidence``) settles it.
    """
    states: dict[Direction, CellState] = dict.fromkeys(Direction, CellState.UNKNOWN)
    for direction in ORTHOGONAL:
        states[direction] = _state(ranges.get(direction), settings.free_from_cells * cell_size_m)
    for direction, sides in DIAGONAL_SIDES.items():
        state = _state(ranges.get(direction), settings.diagonal_free_from_cells * cell_size_m)
        if state == CellState.OBSTACLE and not all(states[s] == CellState.FREE for s in sides):
            state = CellState.UNKNOWN  # the corner may belong to a side wall
        if state == CellState.UNKNOWN and diagonals:
            state = diagonals.get(direction, CellState.UNKNOWN)
        states[direction] = state
    return states


def _state(r: Range | None, free_from_m: float) -> CellState:
    if r is None:
        return CellState.UNKNOWN
    if r.distance_m >= free_from_m:
        return CellState.FREE
    if r.distance_m >= r.max_m - 1e-6:
        return CellState.UNKNOWN  # nothing seen, but the sensor does not reach far enough
    return CellState.OBSTACLE


def merge_ranges(*sources: Mapping[Direction, Range]) -> dict[Direction, Range]:
    """Ranges from several sensors: the first source that has a direction wins."""
    merged: dict[Direction, Range] = {}
    for source in sources:
        for direction, r in source.items():
            merged.setdefault(direction, r)
    return merged


def readings_from_map(grid: GridMap, cell: Cell) -> dict[Direction, CellState]:
    """Readings of a vehicle that takes the map as known (``sensing: map``), from the
    operator's map of the mission (outside the map counts as an obstacle)."""
    return {
        d: CellState.FREE if grid.is_free(d.of(cell)) else CellState.OBSTACLE for d in Direction
    }
