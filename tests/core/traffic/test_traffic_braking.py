"""docs/contract.md §12: braking to a stop within the robot's deceleration from any instant of a leg, and driving on.

The leg of most tests: (0, 0) -> (20, 0), 1 m/s, 0.5 m/s^2 both ways: 2 s up (1 m), 16 s at 1 m/s, 2 s down
(1 m); it ends at t = 20. At t = 9 the robot is 1 + 7 = 8 m along at 1 m/s.
"""

from __future__ import annotations

import math

import pytest

from vcran.core.motion import FleetKinematics, Leg, Limits
from vcran.core.traffic.braking import brake

LIMITS = Limits(1.0, 0.5, 0.5)


def aisle(t0: float = 0.0) -> Leg:
    return Leg(t0, 0.0, 0.0, 0.0, 20.0, 0.0, None, LIMITS)


def test_braking_at_cruise_stops_after_the_braking_distance() -> None:
    # v = 1, d = 0.5: v^2 / 2d = 1 m further on, v / d = 2 s later
    b = brake(aisle(), 9.0, 0.5)
    assert b.stop is not None
    assert b.t_stop == pytest.approx(11.0, abs=1e-12) and b.pose == pytest.approx((9.0, 0.0, 0.0), abs=1e-12)
    # halfway through braking (t = 10): 8 + 1 * 1 - 0.5 * 0.5 * 1^2 = 8.75 m at 0.5 m/s
    x, y, theta, v, w = b.stop.pose_at(10.0)
    assert (x, y, theta, v, w) == pytest.approx((8.75, 0.0, 0.0, 0.5, 0.0), abs=1e-12)
    # the braked stretch starts where and as fast as the leg was: no jump in position or speed
    assert b.stop.pose_at(9.0) == pytest.approx(aisle().pose_at(9.0), abs=1e-12)


def test_braking_while_speeding_up() -> None:
    # t = 1: 0.25 m along at 0.5 m/s; braking 0.5^2 / 1 = 0.25 m more, 1 s
    b = brake(aisle(), 1.0, 0.5)
    assert b.t_stop == pytest.approx(2.0, abs=1e-12) and b.pose[0] == pytest.approx(0.5, abs=1e-12)


def test_the_remainder_drives_on_from_rest_to_the_leg_goal() -> None:
    b = brake(aisle(), 9.0, 0.5)
    rest = b.remainder(13.0)
    # 9 -> 20: 11 m: 2 s up, 9 s cruising, 2 s down: 13 s, so it ends at 26; no turn (stopped on its line)
    assert (rest.x0, rest.x1, rest.theta_goal, rest.limits) == (pytest.approx(9.0), 20.0, None, LIMITS)
    assert rest.t_turn1 == pytest.approx(0.0, abs=1e-12) and rest.t_end == pytest.approx(26.0, abs=1e-9)
    assert b.resume_speed == 1.0


def test_a_robot_turning_in_place_stops_turning_at_once() -> None:
    # facing +y, turning at 1 rad/s to face +x: at t = 0.5 it faces pi/2 - 0.5 and has no speed
    leg = Leg(0.0, 0.0, 0.0, math.pi / 2, 10.0, 0.0, None, Limits(1.0, 0.5, 0.5, 1.0))
    b = brake(leg, 0.5, 0.5)
    assert b.stop is None and b.t_stop == 0.5 and b.pose == pytest.approx((0.0, 0.0, math.pi / 2 - 0.5))
    rest = b.remainder(3.0)
    assert rest.t_turn1 == pytest.approx(math.pi / 2 - 0.5) and rest.x1 == 10.0


def test_unlimited_deceleration_stops_where_the_robot_is() -> None:
    b = brake(aisle(), 9.0, 0.0)
    assert b.stop is None and b.pose == pytest.approx((8.0, 0.0, 0.0)) and b.t_stop == 9.0


def test_braking_never_overshoots_the_leg_end() -> None:
    # the leg itself stops at once at its end (decel 0): at cruise 0.5 m before it, braking at 0.5 m/s^2
    # would need 1 m; the robot stops at the end, exactly, having braked over the 0.5 m it had:
    # v^2 = 2 * 0.5 * 0.5, peak sqrt(0.5), sqrt(0.5) / 0.5 s = 1.414 s
    leg = Leg(0.0, 0.0, 0.0, 0.0, 20.0, 0.0, None, Limits(1.0, 0.5, 0.0))
    t = 2.0 + 18.5  # 2 s up (1 m), then 18.5 m at 1 m/s: 19.5 m along
    b = brake(leg, t, 0.5)
    assert b.pose[:2] == (20.0, 0.0) and b.t_stop == pytest.approx(t + math.sqrt(0.5) / 0.5)


def test_fleet_kinematics_holds_a_braked_leg_and_its_remainder() -> None:
    """What the SimPy body will do (module docstring of vcran.core.traffic.braking), on the pure fleet:
    the odometer adds up to the whole leg and the pose follows the braked profile."""
    fleet = FleetKinematics([(0.0, 0.0, 0.0)])
    leg = aisle()
    fleet.start(0, leg)
    b = brake(leg, 9.0, 0.5)
    assert fleet.stop(0, 9.0) == pytest.approx((8.0, 0.0, 0.0))
    assert b.stop is not None
    fleet.start(0, b.stop)
    assert fleet.pose(0, 10.0) == pytest.approx((8.75, 0.0, 0.0), abs=1e-12)
    assert fleet.sample(10.0)[0, 3] == pytest.approx(0.5, abs=1e-12)  # the vectorised sweep agrees
    fleet.finish(0)
    rest = b.remainder(13.0)
    fleet.start(0, rest)
    fleet.finish(0)
    assert fleet.odometer[0] == pytest.approx(20.0, abs=1e-12) and fleet.rest[0] == (20.0, 0.0, rest.end_theta)
