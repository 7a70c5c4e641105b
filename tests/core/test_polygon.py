"""Simple polygons (docs/contract.md §4): footprints and station areas are checked when a scenario loads, exactly and
without shapely; the answer agrees with shapely's own validity wherever shapely says anything."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vcran.core.polygon import polygon_problem

SQUARE = [(0.5, 0.5), (-0.5, 0.5), (-0.5, -0.5), (0.5, -0.5)]


@pytest.mark.parametrize(("points", "problem"), [
    (SQUARE, None),
    (SQUARE[::-1], None),
    ([*SQUARE, SQUARE[0]], None),  # closed as a ring: the first corner again at the end
    ([(1, 0), (-1, 1), (-0.5, 0), (-1, -1)], None),  # concave (an arrowhead) is fine
    ([(0.5, 0.5), (-0.5, -0.5), (-0.5, 0.5), (0.5, -0.5)], "cross or touch"),  # a bow tie
    ([(0, 0), (2, 0), (2, 2), (1, 0), (0, 2)], "cross or touch"),  # a corner on another edge
    ([(0, 0), (1, 0), (2, 0)], "runs back along itself"),  # flat, back along the line
    ([(0, 0), (1, 0), (2, 0), (1, 1e-300)], None),  # a sliver has an area
    ([(0, 0), (1, 0)], "at least 3 different corners, got 2"),
    ([(1, 1)] * 3, "at least 3 different corners, got 1"),
])
def test_s4_polygon_problem(points, problem):
    found = polygon_problem(points)
    assert found is None if problem is None else problem in found


@pytest.mark.slow
@settings(max_examples=2000, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 3), st.integers(0, 3)), min_size=1, max_size=7))
def test_s4_a_simple_polygon_is_what_shapely_calls_a_valid_polygon_with_an_area(points):
    # small integer grids are full of the degenerate cases: corners on edges, spikes, repeated corners
    from shapely.geometry import Polygon

    try:
        shape = Polygon(points)
        valid = shape.is_valid and shape.area > 0
    except ValueError:  # fewer than 3 corners: shapely cannot even make the ring
        valid = False
    assert (polygon_problem(points) is None) == valid


@pytest.mark.slow
@settings(max_examples=2000, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 4), st.integers(0, 4)), min_size=3, max_size=7),
       st.integers(-2, 10), st.integers(-2, 10))
def test_s4_covers_is_shapelys_covers_on_simple_polygons(points, x2, y2):
    # half-integer points: on corners, on edges, inside and outside (a station's dock is checked with it)
    from hypothesis import assume
    from shapely.geometry import Point, Polygon

    from vcran.core.polygon import covers

    assume(polygon_problem(points) is None)
    assert covers(points, x2 / 2, y2 / 2) == Polygon(points).covers(Point(x2 / 2, y2 / 2))
