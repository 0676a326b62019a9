"""Range sensing against the ground-truth map: how far a ray goes before it hits a wall.

A ray walks the grid cell by cell (Amanatides and Woo's traversal) from the
sensor's position, in the local frame, until it enters an obstacle cell or
leaves the map (the outside counts as a wall) or runs past the maximum range.
A ray that passes exactly through a cell corner is stopped if any of the
three cells meeting there beyond the corner is a wall: a sensor cannot see
through a diagonal gap of zero width.
"""

from __future__ import annotations

import math

from sitl_mock.gridmap import GridMap

_TIE_EPS = 1e-9


def axis_exit(pos: float, index: int, direction: float) -> tuple[int, float]:
    """Along one grid axis: the step (-1, 0 or 1) a ray going ``direction`` takes when it
    leaves cell ``index``, and the ray length (in cells) from ``pos`` to that edge."""
    if direction > _TIE_EPS:
        return 1, (index + 1 - pos) / direction
    if direction < -_TIE_EPS:
        return -1, (index - pos) / direction
    return 0, math.inf


def _blocked(grid_map: GridMap, row: int, col: int) -> bool:
    return not grid_map.is_free((row, col))


def ray_distance_m(
    grid_map: GridMap,
    cell_size_m: float,
    north_m: float,
    east_m: float,
    bearing_deg: float,
    max_range_m: float,
) -> float:
    """Distance from the point along compass ``bearing_deg`` to the first wall, at most
    ``max_range_m``. The point's own cell is not tested (the sensor stands in it)."""
    theta = math.radians(bearing_deg)
    # Grid coordinates: rows grow southwards, columns eastwards; one unit = one cell.
    d_col = math.sin(theta)
    d_row = -math.cos(theta)
    col_f = east_m / cell_size_m
    row_f = -north_m / cell_size_m
    max_t = max_range_m / cell_size_m
    col, row = math.floor(col_f), math.floor(row_f)
    step_c, next_c = axis_exit(col_f, col, d_col)
    step_r, next_r = axis_exit(row_f, row, d_row)
    delta_c = abs(1.0 / d_col) if step_c else math.inf
    delta_r = abs(1.0 / d_row) if step_r else math.inf
    while True:
        t = min(next_c, next_r)
        if t > max_t:
            return max_range_m
        if abs(next_c - next_r) <= _TIE_EPS:
            hit = (
                _blocked(grid_map, row, col + step_c)
                or _blocked(grid_map, row + step_r, col)
                or _blocked(grid_map, row + step_r, col + step_c)
            )
            col += step_c
            row += step_r
            next_c += delta_c
            next_r += delta_r
        elif next_c < next_r:
            col += step_c
            next_c += delta_c
            hit = _blocked(grid_map, row, col)
        else:
            row += step_r
            next_r += delta_r
            hit = _blocked(grid_map, row, col)
        if hit:
            return max(0.0, t * cell_size_m)


def sector_distances_m(
    grid_map: GridMap,
    cell_size_m: float,
    north_m: float,
    east_m: float,
    heading_deg: float,
    sectors: int,
    max_range_m: float,
) -> list[float]:
    """Ranges of ``sectors`` rays evenly spread clockwise from the vehicle's heading."""
    step = 360.0 / sectors
    return [
        ray_distance_m(
            grid_map, cell_size_m, north_m, east_m, (heading_deg + i * step) % 360.0, max_range_m
        )
        for i in range(sectors)
    ]
