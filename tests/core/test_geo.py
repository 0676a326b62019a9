"""The geographic frame (``core.geo``): cells, local metres and latitude/longitude."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from core.geo import DEFAULT_ORIGIN, GeoFrame, bearing_deg, cell_centre_local, wrap_deg

FRAME = GeoFrame(lat_deg=47.0, lon_deg=8.0, alt_m=400.0, cell_size_m=2.0)


def test_the_origin_is_the_north_west_corner_of_cell_zero() -> None:
    assert FRAME.local_to_geo(0.0, 0.0) == (47.0, 8.0)
    assert FRAME.cell_centre_local((0, 0)) == (-1.0, 1.0)
    assert FRAME.local_to_cell(-0.1, 0.1) == (0, 0)
    assert FRAME.local_to_cell(0.1, -0.1) == (-1, -1)


def test_a_degree_of_latitude_is_about_111_km_and_longitude_shrinks_with_it() -> None:
    lat, lon = FRAME.local_to_geo(111_319.5, 111_319.5)
    assert lat - 47.0 == pytest.approx(1.0, rel=1e-4)
    assert lon - 8.0 == pytest.approx(1.0 / math.cos(math.radians(47.0)), rel=1e-4)


@given(st.integers(-500, 500), st.integers(-500, 500))
def test_a_cell_centre_is_found_in_its_cell(row: int, col: int) -> None:
    for frame in (FRAME, DEFAULT_ORIGIN):
        lat, lon = frame.cell_centre((row, col))
        assert frame.geo_to_cell(lat, lon) == (row, col)
        assert frame.cell_centre_local((row, col)) == cell_centre_local(
            (row, col), frame.cell_size_m
        )


@given(st.floats(-2000, 2000), st.floats(-2000, 2000))
def test_local_and_geo_round_trip(north: float, east: float) -> None:
    n, e = FRAME.geo_to_local(*FRAME.local_to_geo(north, east))
    assert n == pytest.approx(north, abs=1e-6) and e == pytest.approx(east, abs=1e-6)


def test_bearings_are_compass_degrees() -> None:
    assert bearing_deg(1.0, 0.0) == 0.0
    assert bearing_deg(0.0, 1.0) == 90.0
    assert bearing_deg(-1.0, 0.0) == 180.0
    assert bearing_deg(0.0, -1.0) == 270.0


@given(st.floats(-1000, 1000))
def test_a_wrapped_angle_is_the_short_turn_to_the_same_direction(angle: float) -> None:
    turn = wrap_deg(angle)
    assert -180.0 <= turn < 180.0
    assert math.isclose(math.cos(math.radians(turn)), math.cos(math.radians(angle)), abs_tol=1e-9)
    assert math.isclose(math.sin(math.radians(turn)), math.sin(math.radians(angle)), abs_tol=1e-9)
