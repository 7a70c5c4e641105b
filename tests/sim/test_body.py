"""The robot's shared body driven without any protocol (docs/protocols.md, vcran/sim/body.py): what a second
protocol's glue can count on. Every instant is derived by hand: the robot's defaults drive at 1 m/s with
instantaneous acceleration and turns, so a leg of d metres takes d seconds."""

from __future__ import annotations

import math

import pytest

from vcran.core.actions import ActionKind
from vcran.core.motion import FleetKinematics
from vcran.core.scenario import RobotConfig
from vcran.core.stations import StationMap
from vcran.sim.body import Acted, Body, Reached, Waypoint
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
    """SPEC §4: held from 1 s to 3 s, the 4 m leg ends 2 s late, at 6 s; during the hold the robot stands at x = 1."""
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
