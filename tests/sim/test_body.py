"""The robot's shared body driven without any protocol (docs/protocols.md, vcran/sim/body.py): what a second
protocol's glue can count on. Every instant is derived by hand: the robot's defaults drive at 1 m/s with
instantaneous acceleration and turns, so a leg of d metres takes d seconds."""

from __future__ import annotations

import math

import pytest

from vcran.core.actions import ActionKind
from vcran.core.battery import BatteryConfig, FleetBattery
from vcran.core.motion import FleetKinematics
from vcran.core.scenario import RobotConfig
from vcran.core.stations import StationMap
from vcran.sim.agvaction import Acted
from vcran.sim.body import Body, Reached, Waypoint
from vcran.sim.holds import MOTION_FAILED, Halted
from vcran.sim.timing import FAULT, Environment, at


def body(actions: tuple[str, ...] = ("dummy",)) -> tuple[Body, list[tuple[float, object]]]:
    env = Environment(0.0)
    config = RobotConfig("r", pose=(0.0, 0.0, 0.0), actions=actions)
    b = Body(env, 0, config, FleetKinematics([config.pose]), StationMap([]), {"dummy": 2.0})
    told: list[tuple[float, object]] = []
    b.tell = lambda report: told.append((env.now, report))
    b.start()
    return b, told


def when(b: Body, t: float, do) -> None:  # type: ignore[no-untyped-def]
    at(b.env, t, FAULT).callbacks.append(lambda _: do())


def reached(told: list[tuple[float, object]]) -> list[tuple[float, object]]:
    return [(t, r.waypoint.tag) for t, r in told if isinstance(r, Reached)]


def test_a_route_is_driven_leg_after_leg_and_each_waypoint_reported():
    b, told = body()
    b.drive([Waypoint(3.0, 0.0, tag="a"), Waypoint(3.0, 4.0, tag="b")])
    b.env.run(until=20.0)
    # 3 m, then 4 m: reached at 3 s and 7 s; the second leg heads +y, so the robot ends facing pi/2
    assert reached(told) == [(3.0, "a"), (7.0, "b")]
    assert b.pose == pytest.approx((3.0, 4.0, math.pi / 2))


def test_a_route_can_be_appended_to_while_a_leg_runs():
    """VDA 5050's Drive appends to the route being driven (docs/vda5050.md): the AGV drives on without a stop."""
    b, told = body()
    b.drive([Waypoint(3.0, 0.0, tag="a")])
    when(b, 1.0, lambda: b.extend([Waypoint(6.0, 0.0, tag="b")]))
    b.env.run(until=20.0)
    assert reached(told) == [(3.0, "a"), (6.0, "b")]


def test_a_hold_resumes_exactly_where_it_stopped():
    """docs/contract.md §4: held from 1 s to 3 s, the 4 m leg ends 2 s late, at 6 s; during the hold the robot stands at x = 1."""
    b, told = body()
    b.drive([Waypoint(4.0, 0.0, tag="a")])
    when(b, 1.0, lambda: b.hold("pause"))
    seen: list[tuple[float, float]] = []
    when(b, 2.0, lambda: seen.append(b.position()))
    when(b, 3.0, lambda: b.release("pause"))
    b.env.run(until=20.0)
    assert seen == [pytest.approx((1.0, 0.0))]
    assert reached(told) == [(6.0, "a")]


def test_a_halt_stops_the_leg_for_good_and_is_reported():
    b, told = body()
    b.drive([Waypoint(4.0, 0.0, tag="a"), Waypoint(8.0, 0.0, tag="b")])
    stop = Halted(MOTION_FAILED, "stopped")
    when(b, 2.5, lambda: b.halt(stop))
    b.env.run(until=20.0)
    assert told == [(2.5, stop)]
    assert b.pose[:2] == pytest.approx((2.5, 0.0))


def test_an_action_is_performed_and_reported_with_its_tag():
    b, told = body()
    b.act((None, ActionKind.DUMMY, "x"))  # the dummy lasts 2 s (durations above)
    b.act((None, ActionKind.LOAD, "y"))  # not among this robot's actions: fails at once when its turn comes
    b.env.run(until=20.0)
    assert [(t, r.tag, r.ok, r.code) for t, r in told if isinstance(r, Acted)] == [
        (2.0, "x", True, ""), (2.0, "y", False, "action_not_capable")]


def test_work_of_a_token_no_longer_current_is_not_done():
    """A route or action waiting for the AGV runs only while its token is the logic's current one."""
    b, told = body()
    b.current = lambda: "t2"
    b.drive([Waypoint(3.0, 0.0, tag="a")], token="t1")
    b.act(("t1", ActionKind.DUMMY, "x"))
    b.env.run(until=20.0)
    assert told == [] and b.pose == (0.0, 0.0, 0.0)


def test_stop_now_ends_the_leg_where_the_robot_is_without_a_report():
    """VDA 5050's StopNow: at 1.5 s on a 4 m leg the robot stands at x = 1.5; the rest of the route is dropped."""
    b, told = body()
    b.drive([Waypoint(4.0, 0.0, tag="a"), Waypoint(8.0, 0.0, tag="b")])
    when(b, 1.5, b.stop_now)
    b.env.run(until=20.0)
    assert told == [] and not b.driving and not b.working
    assert b.pose[:2] == pytest.approx((1.5, 0.0))


def test_stop_now_while_held_on_a_leg_ends_it_where_it_was_held():
    b, told = body()
    b.drive([Waypoint(2.0, 0.0, tag="a"), Waypoint(4.0, 0.0, tag="b")])
    when(b, 1.0, lambda: b.hold("pause"))  # mid-leg: the leg to a resumes at release
    when(b, 2.0, lambda: b.release("pause"))  # a is reached at 3 s, the leg to b starts then
    when(b, 3.5, lambda: b.hold("pause"))  # at x = 2.5
    when(b, 4.0, b.stop_now)
    when(b, 5.0, lambda: b.release("pause"))
    b.env.run(until=20.0)
    assert reached(told) == [(3.0, "a")]
    assert b.pose[:2] == pytest.approx((2.5, 0.0)) and not b.working


def test_stop_now_while_held_before_a_leg_drives_nothing():
    """A route given while paused waits with its first waypoint taken: stop_now drops that one too."""
    b, told = body()
    b.hold("pause")
    when(b, 1.0, lambda: b.drive([Waypoint(2.0, 0.0, tag="a")]))
    when(b, 2.0, b.stop_now)
    when(b, 3.0, lambda: b.release("pause"))
    b.env.run(until=20.0)
    assert told == [] and b.pose == (0.0, 0.0, 0.0)


def test_actions_performed_beside_run_at_once_while_driving_and_one_can_be_interrupted():
    """Several at once, also while driving: each lasts 2 s from its start; the one interrupted reports nothing."""
    b, told = body()
    b.drive([Waypoint(5.0, 0.0, tag="a")])
    when(b, 1.0, lambda: b.perform(ActionKind.DUMMY, "x"))
    when(b, 1.5, lambda: b.perform(ActionKind.DUMMY, "y"))
    when(b, 2.0, lambda: b.perform(ActionKind.DUMMY, "z"))
    when(b, 2.5, lambda: b.interrupt("y"))
    b.env.run(until=20.0)
    assert [(t, r.tag) for t, r in told if isinstance(r, Acted)] == [(3.0, "x"), (4.0, "z")]
    assert reached(told) == [(5.0, "a")]


def test_a_hold_pauses_actions_beside_and_a_halt_ends_them_unreported():
    """Held from 1 s to 2 s, a 2 s action begun at 0 ends at 3 s; the one begun at 3.5 s is ended by the halt
    at 4 s, which alone is reported."""
    b, told = body()
    b.perform(ActionKind.DUMMY, "x")
    when(b, 1.0, lambda: b.hold("breakdown"))
    when(b, 2.0, lambda: b.release("breakdown"))
    when(b, 3.5, lambda: b.perform(ActionKind.DUMMY, "y"))
    stop = Halted(MOTION_FAILED, "stopped")
    when(b, 4.0, lambda: b.halt(stop))
    b.env.run(until=20.0)
    assert [(t, getattr(r, "tag", r)) for t, r in told] == [(3.0, "x"), (4.0, stop)]
    assert b.beside == {}


def test_place_sets_the_pose_of_a_body_at_rest():
    b, told = body()
    b.place(2.0, 1.0, 0.5)
    b.drive([Waypoint(2.0, 4.0, tag="a")])
    b.env.run(until=20.0)
    assert reached(told) == [(3.0, "a")]  # 3 m from where it was placed


def test_what_the_body_shows_mid_leg_pose_speeds_odometer_and_charge():
    """At 1.5 s on a 4 m leg along +x at 1 m/s: x = 1.5, speed 1, odometer 1.5; no battery: no charge. With a
    battery of 10 Ah drawing 0.1 Ah a metre and nothing at rest: 10 - 0.15 Ah."""
    b, _ = body()
    b.drive([Waypoint(4.0, 0.0, tag="a")])
    seen: list[object] = []
    when(b, 1.5, lambda: seen.extend([b.motion(), b.odometer(), b.charge()]))
    b.env.run(until=20.0)
    assert seen == [pytest.approx((1.5, 0.0, 0.0, 1.0, 0.0)), pytest.approx(1.5), None]
    assert b.motion() == (4.0, 0.0, 0.0, 0.0, 0.0) and b.odometer() == pytest.approx(4.0)


def test_the_battery_drains_by_the_metre_and_reads_as_the_charge():
    env = Environment(0.0)
    config = RobotConfig("r", battery=BatteryConfig(capacity=10.0, per_metre=0.1))
    b = Body(env, 0, config, FleetKinematics([config.pose]), StationMap([]), {}, FleetBattery([config.battery]))
    b.start()
    b.drive([Waypoint(4.0, 0.0, tag="a")])
    seen: list[float | None] = []
    when(b, 1.5, lambda: seen.append(b.charge()))
    env.run(until=20.0)
    assert seen == [pytest.approx(10.0 - 0.15)] and b.charge() == pytest.approx(10.0 - 0.4)
