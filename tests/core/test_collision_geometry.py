"""docs/contract.md §4 footprints and collisions in the pure core: the separating-axis test, refinement, track boxes.

Every expectation is derived by hand from the geometry in the test's comment.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from vcran.core.collisions import TIME_TOL, Footprint, Track
from vcran.core.motion import Leg, Limits
from vcran.core.overlap import convex_axes, first_change, shape_of, touching

SQUARE = ((0.5, 0.5), (-0.5, 0.5), (-0.5, -0.5), (0.5, -0.5))  # 1 m x 1 m around the robot's origin


def track(index, points, pose=(0.0, 0.0, 0.0), leg=None, convex=True):
    return Track(index, Footprint(points, None if convex else False), leg, pose, leg.t_end if leg else math.inf)


def touch(a, b):
    return bool(touching(a, b, np.array([0.0]))[0])


@pytest.mark.parametrize("convex", [True, False], ids=["separating-axes", "shapely"])
@pytest.mark.parametrize(
    ("at", "expected"),
    [
        # a diamond (the square turned 45 degrees, half-diagonal 0.7071) left of x = 1.2: its left corner at
        # 0.4929 reaches into the square (right edge x = 0.5); at x = 1.25 the corner is at 0.5429: apart
        ((1.2, 0.0), True),
        ((1.25, 0.0), False),
        # diagonally at (0.9, 0.9): the diamond's lower-left edge is the line x + y = 1.8 - 0.7071 = 1.0929,
        # the square's corner (0.5, 0.5) has x + y = 1.0: apart, though the projections on both of the
        # square's own axes overlap (only the diamond's axis separates them); at (0.8, 0.8) x + y = 0.8929
        ((0.9, 0.9), False),
        ((0.8, 0.8), True),
        # edge to edge, exactly: touching counts (x = 1 puts the diamond's corner 0.2929 into the square)
        ((1.0, 0.0), True),
    ],
)
def test_s4_convex_footprints_touch_as_the_geometry_says(at, expected, convex):
    square = track(0, SQUARE, convex=convex)
    diamond = track(1, SQUARE, pose=(at[0], at[1], math.pi / 4), convex=convex)
    assert touch(square, diamond) is expected
    assert touch(diamond, square) is expected


def test_s4_squares_sharing_an_edge_touch():
    # x = 1 exactly: the right edge of one is the left edge of the other
    assert touch(track(0, SQUARE), track(1, SQUARE, pose=(1.0, 0.0, 0.0)))
    assert not touch(track(0, SQUARE), track(1, SQUARE, pose=(1.001, 0.0, 0.0)))


def test_s4_a_concave_footprint_is_not_tested_by_its_hull():
    # an L (2 m x 2 m with the upper right 1 m x 1 m cut away); a 0.5 m square at (1.6, 1.6) sits in the cut,
    # inside the L's convex hull but clear of the L itself
    ell = ((0, 0), (2, 0), (2, 1), (1, 1), (1, 2), (0, 2))
    assert convex_axes(shape_of(ell)) is None
    small = ((0.25, 0.25), (-0.25, 0.25), (-0.25, -0.25), (0.25, -0.25))
    assert not touch(track(0, ell), track(1, small, pose=(1.6, 1.6, 0.0)))
    assert touch(track(0, ell), track(1, small, pose=(1.6, 1.2, 0.0)))  # reaches below y = 1: in the L's foot


def _regular(n, step=1):
    return tuple((math.cos(2 * math.pi * i * step / n), math.sin(2 * math.pi * i * step / n)) for i in range(n))


@pytest.mark.parametrize(
    ("points", "convex"),
    [
        (SQUARE, True),
        (SQUARE[::-1], True),  # clockwise: every corner turns right
        # a regular pentagon: convex, though its area and its convex hull's round apart in the last bit
        (_regular(5), True),
        # the square with a corner given twice, or a point halfway along its top edge: still the square
        (SQUARE[:2] + SQUARE[1:], True),
        ((SQUARE[0], (0.0, 0.5)) + SQUARE[1:], True),
        # a pentagram: every corner turns the same way, but the boundary goes round twice
        (_regular(5, step=2), False),
        # an arrowhead (dart): (1, 2) -> (0, 0) -> (1, 0.5) turns the other way at (1, 0.5)
        (((0, 0), (1, 0.5), (2, 0), (1, 2)), False),
        # a spike: the top edge goes out to (1.5, 0.5) and straight back along itself
        (((0.5, 0.5), (1.5, 0.5), (0.5, 0.5), (-0.5, 0.5), (-0.5, -0.5), (0.5, -0.5)), False),
        # no area: three corners on one line
        (((0, 0), (1, 0), (2, 0)), False),
    ],
    ids=["square", "clockwise", "pentagon", "repeated-corner", "collinear-corner", "pentagram", "dart", "spike",
         "flat"],
)
def test_s4_separating_axes_are_used_for_exactly_the_convex_footprints(points, convex):
    assert (convex_axes(shape_of(points)) is not None) is convex


@pytest.mark.parametrize("convex", [True, False], ids=["separating-axes", "shapely"])
def test_s4_contact_instants_are_refined_to_the_time_tolerance(convex):
    # a square drives from (0, 0) to (10, 0) at a constant 2 m/s (no ramps) toward a square at rest at (6, 0):
    # its front (x + 0.5) reaches the other's back (5.5) at x = 5, t = 2.5; its back (x - 0.5) leaves the
    # other's front (6.5) at x = 7, t = 3.5 (touching counts, so the contact ends just after)
    leg = Leg(0.0, 0.0, 0.0, 0.0, 10.0, 0.0, None, Limits(2.0))
    mover = track(0, SQUARE, leg=leg, convex=convex)
    still = track(1, SQUARE, pose=(6.0, 0.0, 0.0), convex=convex)
    start = first_change(mover, still, 0.0, leg.t_end, 0.05, want=True)
    assert start is not None and 2.5 <= start <= 2.5 + 2 * TIME_TOL
    end = first_change(mover, still, start, leg.t_end, 0.05, want=False)
    assert end is not None and 3.5 <= end <= 3.5 + 2 * TIME_TOL
    assert first_change(mover, still, end, leg.t_end, 0.05, want=True) is None


def test_s4_a_legs_box_covers_only_what_is_left_of_it():
    # 2 m/s along x from 0 to 10: between t = 1 and t = 2 it covers x in 2..4, plus the footprint's radius
    leg = Leg(0.0, 0.0, 0.0, 0.0, 10.0, 0.0, None, Limits(2.0))
    mover = track(0, SQUARE, leg=leg)
    r = math.sqrt(0.5)
    assert mover.box(1.0, 2.0) == pytest.approx((2.0 - r, -r, 4.0 + r, r), abs=1e-5)
    assert mover.box() == pytest.approx((-r, -r, 10.0 + r, r), abs=1e-5)


def test_s4_a_graze_between_two_coarse_samples_is_found():
    # diamonds (corners 0.75 m out on the axes) touch when |dx| + |dy| <= 1.5; one drives along y = 0 at
    # 2 m/s past one at rest at (10.31, 1.45): they touch while x is within 10.31 +- 0.05, t in 5.13 .. 5.18
    # (a 10 cm graze; the origins are 1.6 m apart and more at every 0.8 s a coarse pass looks at)
    diamond = ((0.75, 0.0), (0.0, 0.75), (-0.75, 0.0), (0.0, -0.75))
    leg = Leg(0.0, 0.0, 0.0, 0.0, 20.0, 0.0, None, Limits(2.0))
    mover = track(0, diamond, leg=leg)
    still = track(1, diamond, pose=(10.31, 1.45, 0.0))
    start = first_change(mover, still, 0.0, leg.t_end, 0.05, want=True)
    assert start == pytest.approx(5.13, abs=2 * TIME_TOL)
    end = first_change(mover, still, start, leg.t_end, 0.05, want=False)
    assert end == pytest.approx(5.18, abs=2 * TIME_TOL)


def test_s4_an_inexact_change_is_the_first_sample_after_it():
    # the crossing of the refinement test: the contact ends at 3.5; sampling every 0.05 m / 2 m/s = 0.025 s
    # from t = 3 puts the first sample apart at 3.525 (3.5 itself still touches)
    leg = Leg(0.0, 0.0, 0.0, 0.0, 10.0, 0.0, None, Limits(2.0))
    mover, still = track(0, SQUARE, leg=leg), track(1, SQUARE, pose=(6.0, 0.0, 0.0))
    assert first_change(mover, still, 3.0, leg.t_end, 0.05, want=False, exact=False) == pytest.approx(3.525)


def _convex_polygon(radii, angles):
    """A convex polygon: points on an ellipse at increasing angles (a convex curve's points are in convex position)."""
    rx, ry = radii
    return tuple((rx * math.cos(a), ry * math.sin(a)) for a in sorted(set(angles)))


@pytest.mark.slow
@settings(max_examples=150, deadline=None)
@given(
    st.tuples(st.floats(0.2, 2.0), st.floats(0.2, 2.0)),
    st.lists(st.floats(0.0, 2 * math.pi, exclude_max=True), min_size=3, max_size=8),
    st.lists(st.tuples(st.floats(-3, 3), st.floats(-3, 3), st.floats(-math.pi, math.pi)), min_size=1, max_size=40),
)
def test_s4_separating_axes_agree_with_shapely_wherever_the_answer_is_clear(radii, angles, poses):
    """The separating-axis test (numpy) against shapely's ``intersects`` on random convex footprints, a
    robot at rest at the origin and another at many poses; poses within 1e-9 m of touching are left out
    (there the two may round differently, and neither is wrong)."""
    import shapely

    points = _convex_polygon(radii, angles)
    assume(len(points) >= 3 and shapely.Polygon(points).area > 1e-3 and convex_axes(shape_of(points)) is not None)
    fixed = track(0, points)
    exact = shapely.Polygon(points)
    clear = []
    for x, y, theta in poses:
        c, s = math.cos(theta), math.sin(theta)
        moved = shapely.Polygon([(x + c * px - s * py, y + s * px + c * py) for px, py in points])
        gap = exact.distance(moved)
        if gap > 1e-9 or exact.intersection(moved).area > 1e-9:
            clear.append(((x, y, theta), gap == 0.0))
    assume(clear)
    for (x, y, theta), expected in clear:
        other = track(1, points, pose=(x, y, theta))
        assert touch(fixed, other) is expected, (x, y, theta)
        assert touch(other, fixed) is expected, (x, y, theta)


def driving_diamond(start, end):
    """The diamond of the cases above (the square turned 45 degrees) on a leg from ``start`` to ``end``: its
    footprint is turned so that, facing the leg's heading, it is the diamond."""
    heading = math.atan2(end[1] - start[1], end[0] - start[0])
    turn = math.pi / 4 - heading
    diamond = tuple((x * math.cos(turn) - y * math.sin(turn), x * math.sin(turn) + y * math.cos(turn)) for x, y in SQUARE)
    leg = Leg(0.0, *start, heading, *end, None, Limits(1.0))
    assert leg.t_turn1 == 0.0
    return track(1, diamond, leg=leg)


def test_s4_one_test_of_many_instants_mixes_samples_either_footprints_axes_separate():
    """The diamond tested at both ends of a leg in one call: at (1.25, 0) the square's own axis x separates
    them, at (0.9, 0.9) only the diamond's axis does (see above), so the diamond's axes are tested on the
    samples the square's left, and both are apart; at (1.2, 0) and (0.8, 0.8) both touch."""
    square = track(0, SQUARE)
    apart = driving_diamond((1.25, 0.0), (0.9, 0.9))
    assert touching(square, apart, np.array([0.0, apart.until])).tolist() == [False, False]
    near = driving_diamond((1.2, 0.0), (0.8, 0.8))
    assert touching(square, near, np.array([0.0, near.until])).tolist() == [True, True]
