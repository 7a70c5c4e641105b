"""Leg kinematics (docs/contract.md §4): analytic poses, and the scalar and vectorised paths agreeing bit for bit."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vcran.core.motion import SCALAR_BELOW, FleetKinematics, Leg, Limits, wrap

finite = st.floats(-50, 50, allow_nan=False)
positive = st.floats(0.05, 5)
rate = st.one_of(st.just(0.0), st.floats(0.1, 3))
angle = st.floats(-math.pi, math.pi)


@st.composite
def legs(draw):
    limits = Limits(draw(positive), draw(st.one_of(st.just(0.0), positive)), draw(st.one_of(st.just(0.0), positive)), draw(rate))
    goal = draw(st.one_of(st.none(), angle))
    return Leg(draw(st.floats(0, 100)), draw(finite), draw(finite), draw(angle), draw(finite), draw(finite), goal, limits)


def test_straight_leg_without_limits_is_distance_over_speed():
    leg = Leg(0.0, 0, 0, 0, 3, 4, None, Limits(2.0))
    assert leg.duration == 2.5
    assert leg.pose_at(1.25)[:2] == pytest.approx((1.5, 2.0), abs=1e-12)
    assert leg.pose_at(99) == (3, 4, math.atan2(4, 3), 0.0, 0.0)


def test_trapezoid_and_triangle_profiles():
    long = Leg(0.0, 0, 0, 0, 10, 0, None, Limits(1.0, 0.5, 0.5))  # 1 m ramps each side
    assert long.peak == 1.0 and long.t_drive == 2 + 8 + 2
    short = Leg(0.0, 0, 0, 0, 1, 0, None, Limits(1.0, 0.5, 0.5))  # never reaches 1 m/s
    assert short.peak == math.sqrt(0.5) and math.isclose(short.t_drive, 2 * math.sqrt(0.5) / 0.5)
    assert short.pose_at(short.t_drive / 2)[0] == pytest.approx(0.5, abs=1e-12)  # half way at peak


def test_turns_in_place_before_and_after():
    leg = Leg(0.0, 0, 0, 0, 0, 2, math.pi, Limits(1.0, 0, 0, 1.0))  # face +y, drive, turn to pi
    assert leg.t_turn1 == math.pi / 2 and leg.t_turn2 == math.pi / 2
    x, y, theta, v, w = leg.pose_at(math.pi / 4)
    assert (x, y, v, w) == (0, 0, 0.0, 1.0) and math.isclose(theta, math.pi / 4)
    assert leg.pose_at(leg.t_end) == (0, 2, math.pi, 0.0, 0.0)


@pytest.mark.parametrize(("theta0", "x1", "y1", "turn"), [
    (0.0, 0, 4, math.pi / 2),  # facing +x, the point straight to the left: a quarter turn
    (0.0, 0, -4, math.pi / 2),  # to the right: a quarter turn the other way, the same time
    (-3 * math.pi / 4, 0, 4, 3 * math.pi / 4),  # the short way round (3π/4), not the long one (5π/4)
])
def test_s4_a_legs_duration_includes_its_first_turn(theta0, x1, y1, turn):
    """docs/contract.md §4: a leg turns in place to face its point, then drives. From (0, 0) to a point 4 m away at
    2 m/s with no ramps, turning at 0.5 rad/s: turn / 0.5 s of turning (π s for a quarter turn) plus
    4 / 2 = 2 s of driving; the leg starts at t0 = 10 (issue 29 item 14(e))."""
    leg = Leg(10.0, 0, 0, theta0, x1, y1, None, Limits(2.0, 0, 0, 0.5))
    assert leg.duration == pytest.approx(turn / 0.5 + 2)
    assert leg.t_end == pytest.approx(10 + turn / 0.5 + 2)
    assert leg.pose_at(10 + turn / 0.5)[:2] == pytest.approx((0, 0), abs=1e-9)  # on the spot until the turn ends


def test_goal_theta_is_reached_exactly():
    leg = Leg(5.0, 1.1, 2.2, 0.3, -3.3, 4.4, 0.0, Limits(0.7, 0.3, 0.4, 0.9))
    assert leg.pose_at(leg.t_end)[:3] == (-3.3, 4.4, 0.0)


def test_cost_of_a_pose_does_not_depend_on_leg_length():
    short = Leg(0.0, 0, 0, 0, 1, 0, None, Limits(1.0, 0.5, 0.5))
    long = Leg(0.0, 0, 0, 0, 1e6, 0, None, Limits(1.0, 0.5, 0.5))
    # one closed-form evaluation, no stepping: the middle and the end of a 1000 km leg are exact
    assert long.pose_at(long.t_drive / 2)[0] == pytest.approx(5e5)
    assert long.pose_at(long.t_end)[0] == 1e6 and short.pose_at(short.t_end)[0] == 1


@pytest.mark.slow
@settings(max_examples=200, deadline=None)
@given(st.lists(legs(), min_size=1, max_size=40), st.floats(0, 200))
def test_scalar_and_vector_paths_are_bit_identical(leg_list, t):
    fleet = FleetKinematics([(0.0, 0.0, 0.0)] * len(leg_list))
    for i, leg in enumerate(leg_list):
        fleet.start(i, leg)
    vector = fleet.sample(t) if len(leg_list) >= SCALAR_BELOW else None
    from vcran.core.sampling import sample_moving

    vec = sample_moving(fleet.moving()[1], t)
    for i, leg in enumerate(leg_list):
        scalar = np.array(leg.pose_at(t))
        assert np.array_equal(vec[i], scalar), (i, t, vec[i], scalar)
        if vector is not None:
            assert np.array_equal(vector[i], scalar)


@given(legs())
def test_pose_stays_on_the_segment_and_theta_is_wrapped(leg):
    for k in range(11):
        t = leg.t0 + leg.duration * k / 10
        x, y, theta, v, w = leg.pose_at(t)
        assert -math.pi < theta <= math.pi
        assert min(leg.x0, leg.x1) - 1e-9 <= x <= max(leg.x0, leg.x1) + 1e-9
        assert v <= leg.limits.speed + 1e-9


def test_wrap():
    assert wrap(math.pi) == math.pi and wrap(-math.pi) == math.pi and wrap(3 * math.pi) == math.pi
    assert wrap(0.5) == 0.5


def test_fleet_odometer_banks_finished_legs():
    fleet = FleetKinematics([(0.0, 0.0, 0.0)])
    leg = Leg(0.0, 0, 0, 0, 4, 0, None, Limits(1.0))
    fleet.start(0, leg)
    assert fleet.distance(0, 1.0) == 1.0
    fleet.finish(0)
    assert fleet.distance(0, 10.0) == 4.0
    assert tuple(fleet.sample(10.0)[0]) == (4.0, 0.0, 0.0, 0.0, 0.0)


def _both_paths(leg: Leg, t: float) -> list[tuple[float, ...]]:
    """The pose at ``t`` from Leg.pose_at, the fleet's scalar sweep and its vectorised sweep."""
    scalar = FleetKinematics([(0.0, 0.0, 0.0)])
    scalar.start(0, leg)
    vector = FleetKinematics([(0.0, 0.0, 0.0)] * SCALAR_BELOW)
    for i in range(SCALAR_BELOW):
        vector.start(i, leg)
    return [leg.pose_at(t), tuple(scalar.sample(t)[0]), tuple(vector.sample(t)[0])]


def test_a_turn_in_place_takes_the_short_way():
    """Facing 3π/4, the point straight below (heading -π/2) is 3π/4 away turning left (through π), 5π/4
    turning right: at 1 rad/s the turn takes 3π/4 s and π/4 s into it the robot faces π."""
    leg = Leg(0.0, 0, 0, 3 * math.pi / 4, 0, -1, None, Limits(1.0, 0, 0, 1.0))
    assert leg.turn1 == pytest.approx(3 * math.pi / 4) and leg.t_turn1 == pytest.approx(3 * math.pi / 4)
    for x, y, theta, v, w in _both_paths(leg, math.pi / 4):
        assert (x, y, v, w) == (0, 0, 0.0, 1.0)
        assert abs(wrap(theta - math.pi)) < 1e-12


def test_poses_during_the_final_turn():
    """Drive 2 m along -y (heading -π/2, 2 s at 1 m/s), then turn to the goal θ = π the short way
    (-π/2 rad, clockwise) at 0.5 rad/s: π s. Half way through it the robot faces -3π/4, turning at -0.5."""
    leg = Leg(0.0, 0, 0, -math.pi / 2, 0, -2, math.pi, Limits(1.0, 0, 0, 0.5))
    assert leg.t_turn1 == 0 and leg.t_drive == 2.0 and leg.t_turn2 == pytest.approx(math.pi)
    for x, y, theta, v, w in _both_paths(leg, 2.0 + math.pi / 2):
        assert (x, y, v, w) == (0, -2, 0.0, -0.5)
        assert theta == pytest.approx(-3 * math.pi / 4, abs=1e-12)
    assert leg.pose_at(leg.t_end) == (0, -2, math.pi, 0.0, 0.0)


def _phase_instants(leg: Leg) -> list[float]:
    """The instants where a leg changes phase, and the floats either side of each."""
    marks = [leg.t0, leg.t0 + leg.t_turn1, leg.t0 + leg.t_turn1 + leg.t_acc,
             leg.t0 + leg.t_turn1 + leg.t_drive - leg.t_dec, leg.t0 + leg.t_turn1 + leg.t_drive, leg.t_end]
    return [x for m in marks for x in (math.nextafter(m, -math.inf), m, math.nextafter(m, math.inf))]


@pytest.mark.slow
@settings(max_examples=300, deadline=None)
@given(legs(), st.lists(st.floats(-10, 250), max_size=70), st.booleans())
def test_one_leg_sampled_phase_by_phase_is_bit_identical(leg, extra, ordered):
    """Collision checks sample one leg at many instants (vcran.core.sampling.leg_poses): the poses are
    those of the fleet sweep and of Leg.pose_at to the last bit, phase boundaries included; unordered
    instants give the same."""
    from vcran.core.sampling import leg_poses, sample_leg

    times = np.array(_phase_instants(leg) + extra + [leg.t0 + leg.duration * k / 7 for k in range(8)])
    if ordered:
        times.sort()
    got = leg_poses(leg, times)
    assert got.shape == (len(times), 3)
    assert np.array_equal(got, sample_leg(leg, times)[:, :3])
    for t, row in zip(times.tolist(), got):
        assert np.array_equal(row, np.array(leg.pose_at(t)[:3])), (t, row, leg.pose_at(t))


def test_one_leg_sampled_at_no_instant_and_at_repeated_instants():
    from vcran.core.sampling import leg_poses, sample_leg

    leg = Leg(2.0, 0, 0, 0, 0, 3, math.pi, Limits(1.0, 0.5, 0.5, 1.0))  # turn, trapezoid, turn
    assert leg_poses(leg, np.array([])).shape == (0, 3)
    same = leg_poses(leg, np.full(5, leg.t0 + leg.t_turn1 + 1.0))
    assert (same == same[0]).all() and same[0].tolist() == list(leg.pose_at(leg.t0 + leg.t_turn1 + 1.0)[:3])
    # NaN is no instant of any phase: the reference's answer (NaN theta), alone or among others
    for times in (np.array([np.nan]), np.array([1.0, np.nan, 9.0]), np.array([np.nan, 3.0])):
        assert np.array_equal(leg_poses(leg, times), sample_leg(leg, times)[:, :3], equal_nan=True), times
    # float32 instants are taken as the float64 numbers they are, as the fleet sweep takes them
    narrow = np.array([2.5, 4.25, 7.75], dtype=np.float32)
    assert np.array_equal(leg_poses(leg, narrow), sample_leg(leg, narrow)[:, :3])
