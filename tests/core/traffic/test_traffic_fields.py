"""docs/contract.md §12 safety fields: the field's length and rectangle, and the instants another footprint enters and
leaves it along both tracks, each derived by hand in its comment.

Robots are 1 m x 1 m squares around their origin (front at x = 0.5, width -0.5 .. 0.5) driving 1 m/s with
0.5 m/s^2 ramps; from rest a 20 m leg is 2 s up (1 m), 16 s at 1 m/s, 2 s down: at 2 + s it is 1 + s m along.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from vcran.core.collisions import Footprint, Track
from vcran.core.motion import Leg, Limits
from vcran.core.traffic.fields import Field, FieldSpec, driving, waiting
from vcran.core.traffic.intrusion import first_entry, first_exit, inside

SQUARE = ((0.5, 0.5), (-0.5, 0.5), (-0.5, -0.5), (0.5, -0.5))
LIMITS = Limits(1.0, 0.5, 0.5)
RES = 0.05
#: margin 2 m plus the braking distance at 0.5 m/s^2: v^2 / (2 * 0.5) = v^2; 3 m at 1 m/s
CORRIDOR = Field.of(FieldSpec(margin=2.0), SQUARE, 0.5)


def robot(index: int, pose: tuple[float, float, float] = (0.0, 0.0, 0.0), leg: Leg | None = None,
          convex: bool = True) -> Track:
    return Track(index, Footprint(SQUARE, None if convex else False), leg, pose, leg.t_end if leg else math.inf)


def test_length_formula_and_rectangle() -> None:
    assert CORRIDOR.length(0.0) == 2.0 and CORRIDOR.length(1.0) == 3.0 and CORRIDOR.length(0.5) == 2.25
    fixed = Field.of(FieldSpec(margin=1.5, braking=False), SQUARE, 0.5)
    assert fixed.length(0.0) == fixed.length(2.0) == 1.5
    reaction = Field.of(FieldSpec(margin=0.5, reaction=2.0, braking=False, side=0.25), SQUARE, 0.5)
    assert reaction.length(1.0) == 2.5
    assert reaction.corners(2.5) == ((0.5, -0.75), (3.0, -0.75), (3.0, 0.75), (0.5, 0.75))
    # unlimited deceleration stops at once: no braking distance
    assert Field.of(FieldSpec(margin=1.0), SQUARE, 0.0).length(3.0) == 1.0
    with pytest.raises(ValueError, match="margin must be a finite number >= 0"):
        FieldSpec(margin=-1.0)


@pytest.mark.parametrize("convex", [True, False], ids=["separating-axes", "shapely"])
def test_head_on_robots_enter_each_other_field_at_t_9(convex: bool) -> None:
    """docs/robots.md "Traffic", the corridor: A east from (0, 0), B west from (20, 0), both from t = 0.
    At cruise (t >= 2) A is at 1 + (t - 2), B at 19 - (t - 2); A's field reaches 0.5 + 3 m ahead of A, B's
    near side is 0.5 m before B: they meet when 19 - (t - 2) - 0.5 = 1 + (t - 2) + 3.5, t = 9 (A at 8, B at 12)."""
    a = Leg(0.0, 0.0, 0.0, 0.0, 20.0, 0.0, None, LIMITS)
    b = Leg(0.0, 20.0, 0.0, math.pi, 0.0, 0.0, None, LIMITS)
    t = first_entry(driving(0, CORRIDOR, a), robot(1, leg=b, convex=convex), 0.0, 20.0, RES)
    assert t == pytest.approx(9.0, abs=1e-6)
    t = first_entry(driving(1, CORRIDOR, b), robot(0, leg=a, convex=convex), 0.0, 20.0, RES)
    assert t == pytest.approx(9.0, abs=1e-6)


def test_a_field_growing_with_speed_is_entered_while_speeding_up() -> None:
    # field 2 s of reaction, no margin: length 2 v. From rest x = 0.25 t^2, v = 0.5 t: the tip is at
    # 0.25 t^2 + 0.5 + t; a robot resting at (4, 0) has its near side at 3.5: t^2 + 4 t - 12 = 0, t = 2
    field = Field.of(FieldSpec(margin=0.0, reaction=2.0, braking=False), SQUARE, 0.5)
    a = Leg(0.0, 0.0, 0.0, 0.0, 20.0, 0.0, None, LIMITS)
    assert first_entry(driving(0, field, a), robot(1, (4.0, 0.0, 0.0)), 0.0, 20.0, RES) == pytest.approx(2.0, abs=1e-6)


def test_a_field_points_where_the_leg_drives_while_the_robot_turns() -> None:
    """docs/robots.md "Fields": turning in place the robot does not translate, so its field points the way
    its leg will drive. Facing +y, turning to +x at 1 rad/s (pi/2 s) to drive to (10, 0): its field (2 m at
    rest, cut at 10 + 2) covers x 0.5 .. 2.5, y -0.5 .. 0.5 from the start. A square at (3, 0) (its side
    at x 2.5) is in it at once, before the robot has turned at all; a square at (0, 2.5), in the field of
    the way the robot faced (y 0.5 .. 2.5 there, its side at 2), never enters it: the robot drives away
    from it along y = 0 (the field's y range stays -0.5 .. 0.5, the square's starts at 2)."""
    leg = Leg(0.0, 0.0, 0.0, math.pi / 2, 10.0, 0.0, None, Limits(1.0, 0.5, 0.5, 1.0))
    assert leg.t_turn1 == pytest.approx(math.pi / 2)
    field = driving(0, CORRIDOR, leg)
    assert first_entry(field, robot(1, (3.0, 0.0, 0.0)), 0.0, leg.t_end, RES) == 0.0
    assert first_entry(field, robot(1, (0.0, 2.5, 0.0)), 0.0, leg.t_end, RES) is None
    # at rest, before the leg, the robot faces +y: a field pointing that way would hold the second square
    facing = waiting(0, CORRIDOR, 0.0, None, (0.0, 0.0, math.pi / 2))
    assert bool(inside(facing, robot(1, (0.0, 2.5, 0.0)), np.array([0.0]))[0])
    # a waiting field given the leg's heading points where the robot will drive, whatever it faces
    ahead = waiting(0, CORRIDOR, 0.0, None, (0.0, 0.0, math.pi / 2), heading=leg.heading)
    assert not inside(ahead, robot(1, (0.0, 2.5, 0.0)), np.array([0.0]))[0]
    assert inside(ahead, robot(1, (3.0, 0.0, 0.0)), np.array([0.0]))[0]


def test_a_field_keeps_pointing_the_way_the_robot_came_in_its_last_turn() -> None:
    """Driving (0, 0) -> (4, 0) and then turning at 1 rad/s to face +y (pi/2 s): 4 m is 2 s up (1 m), 2 s
    at 1 m/s, 2 s down (1 m), so the turn runs from 6 to 6 + pi/2. A square resting at (4, 2.5)
    (its side at y 2) is beside the drive (the field's y range -0.5 .. 0.5) and would be 0.5 .. 2.5 ahead of
    the turned robot: it never enters the field, which keeps pointing +x, cut at margin past the goal."""
    leg = Leg(0.0, 0.0, 0.0, 0.0, 4.0, 0.0, math.pi / 2, Limits(1.0, 0.5, 0.5, 1.0))
    assert leg.t_end == pytest.approx(6.0 + math.pi / 2)
    assert first_entry(driving(0, CORRIDOR, leg), robot(1, (4.0, 2.5, 0.0)), 0.0, leg.t_end, RES) is None


def test_a_robot_passing_beside_enters_only_a_widened_field() -> None:
    # B drives west along y = 1.01: its right side at 0.51, beyond the field's 0.5; a side of 0.02 reaches it
    a = Leg(0.0, 0.0, 0.0, 0.0, 20.0, 0.0, None, LIMITS)
    b = robot(1, leg=Leg(0.0, 20.0, 1.01, math.pi, 0.0, 1.01, None, LIMITS))
    assert first_entry(driving(0, CORRIDOR, a), b, 0.0, 20.0, RES) is None
    wide = Field.of(FieldSpec(margin=2.0, side=0.02), SQUARE, 0.5)
    assert first_entry(driving(0, wide, a), b, 0.0, 20.0, RES) == pytest.approx(9.0, abs=1e-6)


def test_a_waiting_field_clears_when_the_other_robot_has_left_it() -> None:
    """A waits at (9, 0) with its field for 1 m/s: 3 m, up to x = 12.5. B, resting at (11, 0) facing east,
    drives off at t = 20: its back side (x - 0.5) passes 12.5 when it is 2 m on: 2 s up (1 m) + 1 s, t = 23."""
    field = waiting(0, CORRIDOR, 1.0, None, (9.0, 0.0, 0.0))
    b = robot(1, leg=Leg(20.0, 11.0, 0.0, 0.0, 30.0, 0.0, None, LIMITS))
    assert bool(inside(field, b, np.array([20.0]))[0])
    assert first_exit(field, b, 20.0, b.until, RES) == pytest.approx(23.0, abs=1e-6)
    # a robot without a footprint is never in a field
    ghost = Track(2, Footprint(()), None, (11.0, 0.0, 0.0), math.inf)
    assert not inside(field, ghost, np.array([0.0])).any()


def test_field_track_bounds() -> None:
    a = Leg(0.0, 0.0, 0.0, 0.0, 20.0, 0.0, None, LIMITS)
    track = driving(0, CORRIDOR, a)
    # the longest field (3 m at 1 m/s) reaches its far corners (3.5, +-0.5) from the origin
    assert track.radius == pytest.approx(math.hypot(3.5, 0.5))
    # its far edge moves at 1 m/s plus the growth (2 * 1 * 1 m per m/s) * 0.5 m/s^2 = 1 m/s: 2 m/s
    assert track.speed == pytest.approx(2.0)
    # turns in place add nothing: the field does not turn with the robot (it points the way the leg travels)
    turning = driving(0, CORRIDOR, Leg(0.0, 0.0, 0.0, math.pi, 20.0, 0.0, 0.5, Limits(1.0, 0.5, 0.5, 1.0)))
    assert turning.speed == pytest.approx(2.0)
    r = track.radius
    assert track.box() == pytest.approx((-r, -r, 20.0 + r, r), abs=1e-5)


@pytest.mark.parametrize("convex", [True, False], ids=["separating-axes", "shapely"])
def test_only_the_field_own_axes_separate_a_diamond_beside_it(convex: bool) -> None:
    # a diamond (the square turned 45 degrees, half-diagonal 0.7071) above the field (y up to 0.5) of a
    # robot waiting at the origin (x 0.5 .. 3.5): at (2, 1.3) its lowest corner is at 0.593, apart (only the
    # field's y axis says so: the diamond's own axes see overlapping projections); at (2, 1.2), 0.493: inside
    field = waiting(0, CORRIDOR, 1.0, None, (0.0, 0.0, 0.0))
    times = np.array([0.0])
    assert not inside(field, robot(1, (2.0, 1.3, math.pi / 4), convex=convex), times)[0]
    assert inside(field, robot(1, (2.0, 1.2, math.pi / 4), convex=convex), times)[0]
