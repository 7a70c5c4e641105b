"""docs/contract.md §12 end to end in the pure core: robots brake for what enters their field, wait, drive on when it
clears, and deadlock head-on; driven by a minimal body (tests/core/traffic/body.py) standing for SimPy.

Robots are 1 m x 1 m squares, 1 m/s with 0.5 m/s^2 ramps, fields of 2 m plus the braking distance (v^2 at
0.5 m/s^2: 3 m at 1 m/s). A leg from rest is 2 s up (1 m), then 1 m/s, then 2 s down (1 m).
"""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tests.core.traffic.body import Body
from vcran.core.collisions import Footprint
from vcran.core.motion import Leg, Limits
from vcran.core.traffic.control import Traffic
from vcran.core.traffic.deadlock import BOUND, CYCLE, Deadlock
from vcran.core.traffic.fields import Field, FieldSpec

SQUARE = ((0.5, 0.5), (-0.5, 0.5), (-0.5, -0.5), (0.5, -0.5))
LIMITS = Limits(1.0, 0.5, 0.5)
FIELD = Field.of(FieldSpec(margin=2.0), SQUARE, 0.5)


def traffic(poses, fields=None, bound=None) -> Traffic:
    n = len(poses)
    return Traffic([Footprint(SQUARE)] * n, poses, fields or [FIELD] * n, [0.5] * n, 0.05, bound)


def events(log, *kinds):
    return [(round(t, 6), what, robot, detail) for t, what, robot, detail in log if what in kinds]


def test_corridor_head_on_blocks_at_9_stops_at_11_and_deadlocks_at_11() -> None:
    """docs/robots.md "Traffic": robot 0 east from (0, 0), robot 1 west from (20, 0), both at t = 0.
    Fields meet the other robot at t = 9 (robots at 8 and 12); braking 1 m in 2 s: stopped at 9 and 11
    at t = 11, 1 m apart face to face; each still in the other's waiting field (3 m): a cycle at rest."""
    body = Body(traffic([(0.0, 0.0, 0.0), (20.0, 0.0, math.pi)], bound=60.0))
    body.send(0, Leg(0.0, 0.0, 0.0, 0.0, 20.0, 0.0, None, LIMITS))
    body.send(1, Leg(0.0, 20.0, 0.0, math.pi, 0.0, 0.0, None, LIMITS))
    log = body.run(200.0)
    blocked = events(log, "blocked")
    assert blocked == [(9.0, "blocked", 0, 1), (9.0, "blocked", 1, 0)]
    brakes = [(t, robot, round(d[0], 6), round(d[1][0], 6)) for t, what, robot, d in log if what == "brake"]
    assert brakes == [(9.0, 0, 11.0, 9.0), (9.0, 1, 11.0, 11.0)]
    deadlocks = [detail for _, what, _, detail in log if what == "deadlock"]
    assert len(deadlocks) == 1 and deadlocks[0].kind == CYCLE and deadlocks[0].robots == (0, 1)
    assert deadlocks[0].t == pytest.approx(11.0, abs=1e-6)
    # nothing else happens: reported once, no bound report for robots already in the cycle, nobody arrives
    assert events(log, "unblocked", "drive_on", "arrived") == []


def test_a_robot_drives_on_when_its_field_clears() -> None:
    """Robot 1 rests at (15, 0); robot 0 drives east from (0, 0) at t = 0. Its field (3 m at 1 m/s) meets
    robot 1's back (14.5) when robot 0 is at 11: t = 12; it stops 1 m on, at 12, at t = 14. Robot 1 drives
    off east at t = 20; its back leaves robot 0's waiting field (3 m from its front 12.5: 15.5) when it is at
    16, 1 m on: t = 22. Robot 0 drives on then: 8 m, 2 + 6 + 2 s, and arrives at 32 (at 1 m/s behind robot
    1, which keeps 1 m/s, its field's tip stays 1 m short of robot 1's back: no second block)."""
    body = Body(traffic([(0.0, 0.0, 0.0), (15.0, 0.0, 0.0)]))
    body.send(0, Leg(0.0, 0.0, 0.0, 0.0, 20.0, 0.0, None, LIMITS))
    body.send(1, Leg(20.0, 15.0, 0.0, 0.0, 40.0, 0.0, None, LIMITS))
    log = body.run(200.0)
    assert events(log, "blocked", "unblocked", "drive_on", "arrived") == [
        (12.0, "blocked", 0, 1), (22.0, "unblocked", 0, None), (22.0, "drive_on", 0, None),
        (32.0, "arrived", 0, (20.0, 0.0)), (47.0, "arrived", 1, (40.0, 0.0)),
    ]


def test_a_field_cleared_while_braking_drives_on_once_stopped() -> None:
    """Robot 1 (no field) crosses robot 0's path going north along x = 12.5 from (12.5, -2) at t = 7: its
    centre is at y = -1 at t = 9 (2 s up, 1 m), then at -1 + (t - 9). Its square (x 12 .. 13) overlaps the
    field's y range (-0.5 .. 0.5) while its centre is within -1 .. 1: t = 9 .. 11. Robot 0, east from the
    origin at t = 0, is at 1 + (t - 2) with its field's tip 3.5 m ahead: the tip reaches x = 12 at t = 9.5.
    Blocked at 9.5, robot 0 brakes until 11.5; robot 1 leaves the field's y range at t = 11, while robot 0
    still brakes (unblocked then); robot 0 drives on once stopped, at 11.5."""
    body = Body(traffic([(0.0, 0.0, 0.0), (12.5, -2.0, math.pi / 2)], fields=[FIELD, None]))
    body.send(0, Leg(0.0, 0.0, 0.0, 0.0, 20.0, 0.0, None, LIMITS))
    body.send(1, Leg(7.0, 12.5, -2.0, math.pi / 2, 12.5, 20.0, None, LIMITS))
    log = body.run(200.0)
    assert events(log, "blocked", "unblocked", "drive_on") == [
        (9.5, "blocked", 0, 1), (11.0, "unblocked", 0, None), (11.5, "drive_on", 0, None)]


def test_a_robot_blocked_by_a_parked_robot_is_reported_past_the_bound() -> None:
    # robot 1 rests at (15, 0) for good: robot 0 blocked at 12 (above), reported at 12 + 30 = 42
    body = Body(traffic([(0.0, 0.0, 0.0), (15.0, 0.0, 0.0)], bound=30.0))
    body.send(0, Leg(0.0, 0.0, 0.0, 0.0, 20.0, 0.0, None, LIMITS))
    log = body.run(100.0)
    deadlocks = [detail for _, what, _, detail in log if what == "deadlock"]
    assert len(deadlocks) == 1
    d = deadlocks[0]
    assert (d.kind, d.robots, d.waiting_for) == (BOUND, (0,), (1,))
    assert d.t == pytest.approx(42.0, abs=1e-6) and d.since == pytest.approx(12.0, abs=1e-6)
    assert isinstance(d, Deadlock)


def test_a_new_leg_for_a_blocked_robot_ends_its_block() -> None:
    t = traffic([(0.0, 0.0, 0.0), (15.0, 0.0, 0.0)])
    body = Body(t)
    body.send(0, Leg(0.0, 0.0, 0.0, 0.0, 20.0, 0.0, None, LIMITS))
    body.run(20.0)
    assert t.blocked(0)
    # the fleet manager sends robot 0 back west from where it stopped (12, 0): unblocked at once
    effects = t.drive(0, Leg(20.0, 12.0, 0.0, 0.0, 0.0, 0.0, None, LIMITS), 20.0)
    assert not t.blocked(0) and type(effects[0]).__name__ == "Unblocked"


def test_a_new_leg_into_the_robot_in_the_field_blocks_again_at_once() -> None:
    """docs/robots.md "Fields": an order from outside ends a block, and the new leg's field is blocked at
    once if it still holds someone. Robot 0 is blocked by robot 1 resting at (15, 0) at 12 and stops at 12
    at t = 14 (above). At 20 it is sent on east to (16, 0): ``unblocked``, and its field from rest (2 m from
    its front at 12.5: to 14.5, cut at 4 + 2 m past the goal) touches robot 1's back at 14.5: ``blocked``
    again at 20, stopped at once (no speed), at 12. It never drives into robot 1 (its square would reach
    16.5 at the goal, over robot 1's 14.5 .. 15.5)."""
    t = traffic([(0.0, 0.0, 0.0), (15.0, 0.0, 0.0)])
    body = Body(t)
    body.send(0, Leg(0.0, 0.0, 0.0, 0.0, 20.0, 0.0, None, LIMITS))
    body.send(0, Leg(20.0, 12.0, 0.0, 0.0, 16.0, 0.0, None, LIMITS))
    log = body.run(100.0)
    assert events(log, "blocked", "unblocked", "drive_on", "arrived") == [
        (12.0, "blocked", 0, 1), (20.0, "unblocked", 0, None), (20.0, "blocked", 0, 1)]
    brakes = [(round(t, 6), round(d[0], 6), round(d[1][0], 6)) for t, what, _, d in log if what == "brake"]
    assert brakes == [(12.0, 14.0, 12.0), (20.0, 20.0, 12.0)]
    assert t.blocked(0) and t.watch.holding(0) == {1}


def test_a_robot_parked_more_than_the_margin_beyond_the_goal_does_not_block_the_arrival() -> None:
    """docs/robots.md "Fields": the field is cut ``margin`` (2 m) past the front of the footprint at the goal.
    Robot 0 drives (0, 0) -> (20, 0), arriving at t = 22, its front at the goal at 20.5: its field never
    reaches past 22.5. While it cruises the field's tip is at x + 0.5 + 3, 22.5 at x = 19 (t = 20); during
    the last 2 s it has v^2 left to drive (0.5 m/s^2), so its uncut length 2 + v^2 is the cut 20 - x + 2 and
    the tip stays at 22.5. Robot 1 resting at (23.1, 0) (near side 22.6, 0.1 m beyond): no block, arrival at
    22. At (22.9, 0) (near side 22.4, 0.1 m within): the cruising tip reaches 22.4 at x = 18.9, **blocked at
    t = 19.9**; robot 0 brakes 1 m, stops at 19.9 (t = 21.9), 0.1 m short of its goal, and waits: its
    waiting field (3 m, cut at 0.1 + 2) reaches 20.4 + 2.1 = 22.5, over robot 1's side."""
    body = Body(traffic([(0.0, 0.0, 0.0), (23.1, 0.0, 0.0)]))
    body.send(0, Leg(0.0, 0.0, 0.0, 0.0, 20.0, 0.0, None, LIMITS))
    assert events(body.run(100.0), "blocked", "arrived") == [(22.0, "arrived", 0, (20.0, 0.0))]
    body = Body(traffic([(0.0, 0.0, 0.0), (22.9, 0.0, 0.0)]))
    body.send(0, Leg(0.0, 0.0, 0.0, 0.0, 20.0, 0.0, None, LIMITS))
    log = body.run(100.0)
    assert events(log, "blocked", "unblocked", "arrived") == [(19.9, "blocked", 0, 1)]
    brakes = [(round(t, 6), robot, round(d[0], 6), round(d[1][0], 6)) for t, what, robot, d in log if what == "brake"]
    assert brakes == [(19.9, 0, 21.9, 19.9)]


TURNING = Limits(1.0, 0.5, 0.5, 1.0)  # turns in place at 1 rad/s


def test_a_robot_facing_another_turns_and_drives_away() -> None:
    """docs/robots.md "Fields" (issue 32's turn): robot 0 rests at (9, 0) facing east, 1 m from robot 1
    resting at (11, 0) (fronts at 9.5 and 10.5), as the corridor's robots stop. At 20 robot 0 is sent west
    to (0, 0): it turns pi at 1 rad/s, then drives 9 m (2 s up, 7 s at 1 m/s, 2 s down). Its field points
    west from the start (x 8.5 .. 6.5 at rest): robot 1, behind it, never enters it: no block, arrived at
    20 + pi + 11."""
    body = Body(traffic([(9.0, 0.0, 0.0), (11.0, 0.0, math.pi)], bound=30.0))
    body.send(0, Leg(20.0, 9.0, 0.0, 0.0, 0.0, 0.0, None, TURNING))
    log = body.run(100.0)
    assert events(log, "blocked", "unblocked", "arrived", "deadlock") == [
        (round(31.0 + math.pi, 6), "arrived", 0, (0.0, 0.0))]


def test_a_robot_where_the_leg_drives_blocks_it_before_it_turns() -> None:
    """Robot 0 as above, robot 2 resting at (6.2, 0) (its side at 6.7). Sent west at 20, robot 0's field
    from rest points west, 2 m from its front at 8.5 (to 6.5, cut at 9 + 2): robot 2 is in it: blocked at
    20, before turning, stopped at once (no speed), still facing east. Its waiting field (3 m, for the
    1 m/s it will drive on at) points west too (robot 1, east, is not in it). Robot 2 drives south from 30:
    its top side leaves the field's y range (-0.5 .. 0.5) 1 m on (2 s from rest): clear at 32. Robot 0
    drives on from rest: the turn (pi s) and the 9 m (11 s): arrived at 43 + pi."""
    body = Body(traffic([(9.0, 0.0, 0.0), (11.0, 0.0, math.pi), (6.2, 0.0, -math.pi / 2)]))
    body.send(0, Leg(20.0, 9.0, 0.0, 0.0, 0.0, 0.0, None, TURNING))
    body.send(2, Leg(30.0, 6.2, 0.0, -math.pi / 2, 6.2, -10.0, None, TURNING))
    log = body.run(100.0)
    assert events(log, "blocked", "unblocked", "drive_on", "arrived") == [
        (20.0, "blocked", 0, 2), (32.0, "unblocked", 0, None), (32.0, "drive_on", 0, None),
        (42.0, "arrived", 2, (6.2, -10.0)), (round(43.0 + math.pi, 6), "arrived", 0, (0.0, 0.0))]
    [(_, _, _, (t_stop, pose))] = [e for e in log if e[1] == "brake"]
    assert (t_stop, pose) == (20.0, (9.0, 0.0, 0.0))


def test_a_turn_in_place_alone_has_no_field() -> None:
    """A leg that does not travel drives into nothing: robot 0 at (9, 0) facing robot 1 1 m ahead turns in
    place to face west (pi at 1 rad/s): no block, done at 20 + pi."""
    body = Body(traffic([(9.0, 0.0, 0.0), (11.0, 0.0, math.pi)], bound=30.0))
    body.send(0, Leg(20.0, 9.0, 0.0, 0.0, 9.0, 0.0, math.pi, TURNING))
    assert events(body.run(100.0), "blocked", "arrived") == [(round(20.0 + math.pi, 6), "arrived", 0, (9.0, 0.0))]


def test_a_robot_leaving_a_field_as_it_blocks_is_no_cycle() -> None:
    """docs/robots.md "Deadlock": a cycle needs every robot in it to wait at rest. Robot 1 rests at (0, 3)
    facing east and is sent 1 m east at 0: its field from rest (x 0.5 .. 2.5, y 2.5 .. 3.5) touches the
    corner (0.5, 3.5) of robot 0 resting at (0, 4): blocked at 0, stopped at once. At 1 robot 0 is sent to
    (1, 0) and turns at once to face it (heading atan2(-4, 1)): its turned square meets x = 0.5 only above
    y = 3.6, out of robot 1's field, while robot 1 (1 m ahead of it, at (0.97, -0.24) in its frame) is in
    its field: robot 0 is blocked at 1, and robot 1 is clear at that same instant and drives on (1 m from
    rest, a triangle: 2 sqrt(2) s, arriving at 1 + 2 sqrt(2)). Each waited for the other, never both at
    once: no cycle (a hypothesis example: the braked robot's stop was judged before the exit it caused)."""
    body = Body(traffic([(0.0, 4.0, 0.0), (0.0, 3.0, 0.0)], bound=50.0))
    body.send(1, Leg(0.0, 0.0, 3.0, 0.0, 1.0, 3.0, None, LIMITS))
    body.send(0, Leg(1.0, 0.0, 4.0, 0.0, 1.0, 0.0, None, LIMITS))
    log = body.run(10.0)
    assert events(log, "blocked", "unblocked", "drive_on", "arrived", "deadlock") == [
        (0.0, "blocked", 1, 0), (1.0, "blocked", 0, 1), (1.0, "unblocked", 1, None), (1.0, "drive_on", 1, None),
        (round(1 + 2 * math.sqrt(2), 6), "arrived", 1, (1.0, 3.0))]


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 20), st.integers(0, 20), st.integers(0, 20), st.integers(0, 20),
                          st.integers(0, 5)), min_size=2, max_size=4, unique_by=lambda r: (r[0], r[1])))
def test_random_fleets_never_run_away_and_blocks_pair_up(robots: list[tuple[int, int, int, int, int]]) -> None:
    """Robots on a 20 m square each sent once to a random point: the run ends (no endless stop-and-go at
    one instant), nobody drives on with a robot in its field (the body asserts it), blocked and unblocked
    alternate per robot, and every robot of a reported cycle had stopped."""
    poses = [(float(x), float(y), 0.0) for x, y, *_ in robots]
    t = traffic(poses, bound=50.0)
    body = Body(t)
    for i, (x, y, gx, gy, start) in enumerate(robots):
        if (gx, gy) != (x, y):
            body.send(i, Leg(float(start), float(x), float(y), 0.0, float(gx), float(gy), None, LIMITS))
    log = body.run(500.0, limit=20_000)
    for i in range(len(robots)):
        spells = [what for _, what, robot, _ in log if robot == i and what in ("blocked", "unblocked")]
        assert spells == ["blocked", "unblocked"] * (len(spells) // 2) + ["blocked"] * (len(spells) % 2)
    for _, what, _, d in log:
        if what == "deadlock" and d.kind == CYCLE:
            assert all(r in t.stopped for r in d.robots)
