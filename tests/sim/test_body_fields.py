"""The shared body with safety fields (docs/contract.md §12), driven without a protocol: what it tells the fields when a
second protocol's commands move it (stop_now, place). The robots are docs/robots.md's corridor robots: 1 m x
1 m squares, 1 m/s, 0.5 m/s^2 both ways; fields 2 m plus the braking distance (3 m at 1 m/s). A leg from rest
covers 1 m in its first 2 s, then 1 m/s."""

from __future__ import annotations

from typing import Any

import pytest

from vcran.core.events import Event
from vcran.core.motion import FleetKinematics
from vcran.core.scenario import RobotConfig, Scenario, Settings, TrafficSettings
from vcran.core.stations import StationMap
from vcran.core.traffic.fields import FieldSpec
from vcran.sim.body import Body, Reached, Waypoint
from vcran.sim.timing import FAULT, Environment, at
from vcran.sim.traffic import SafetyFields

SQUARE = ((0.5, 0.5), (-0.5, 0.5), (-0.5, -0.5), (0.5, -0.5))


def fleet() -> tuple[Body, Body, list[tuple[float, str, str, Any]]]:
    """A at (0, 0) facing east; B resting at (15, 5), off A's way."""
    env = Environment(0.0)
    configs = [RobotConfig(rid, pose, max_velocity=1.0, max_acceleration=0.5, max_deceleration=0.5, footprint=SQUARE)
               for rid, pose in (("A", (0.0, 0.0, 0.0)), ("B", (15.0, 5.0, 0.0)))]
    scenario = Scenario(Settings(duration=100.0), tuple(configs), (), (), traffic=TrafficSettings(FieldSpec(2.0)))
    kinematics = FleetKinematics([c.pose for c in configs])
    log: list[tuple[float, str, str, Any]] = []
    bodies = [Body(env, i, c, kinematics, StationMap([]), {}) for i, c in enumerate(configs)]

    def write(i: int, event: Event) -> None:
        log.append((env.now, bodies[i].id, event.NAME, event.fields()))

    fields = SafetyFields.of(env, scenario, write)
    assert fields is not None
    for b in bodies:
        fields.attach(b.index, b)
        b.fields = fields
        b.tell = lambda report, b=b: log.append((env.now, b.id, "told", report))
        b.start()
    return bodies[0], bodies[1], log


def when(b: Body, t: float, do) -> None:  # type: ignore[no-untyped-def]
    at(b.env, t, FAULT).callbacks.append(lambda _: do())


def brief(log: list[tuple[float, str, str, Any]]) -> list[tuple[Any, ...]]:
    out: list[tuple[Any, ...]] = []
    for t, rid, what, detail in log:
        if what == "told":
            out.append((round(t, 6), rid, type(detail).__name__))
        else:
            out.append((round(t, 6), rid, what, *(round(v, 6) if isinstance(v, float) else v for v in detail.values())))
    return out


def test_s12_a_robot_placed_in_the_way_blocks_and_stop_now_ends_the_block():
    """B is placed at (15, 0) at t = 5 (VDA 5050's initPosition): the fields learn where it is. A's field
    reaches B's side (14.5) when A is at 11: t = 12; A brakes 1 m in 2 s. stop_now at 20 ends A's leg where
    it stands (x = 12), unreported, and its block (8 s); nothing moves after."""
    a, b, log = fleet()
    a.drive([Waypoint(20.0, 0.0, tag="east")])
    when(b, 5.0, lambda: b.place(15.0, 0.0, 0.0))
    when(a, 20.0, a.stop_now)
    a.env.run(until=60.0)
    assert brief(log) == [(12.0, "A", "blocked", "B", 11.0, 0.0), (20.0, "A", "unblocked", 8.0)]
    assert a.pose[:2] == pytest.approx((12.0, 0.0)) and not a.driving


def test_s12_without_the_place_the_robot_passes():
    """The same without B placed in the way: A drives its 20 m (2 + 18 + 2 s) unblocked and reaches at 22."""
    a, _, log = fleet()
    a.drive([Waypoint(20.0, 0.0, tag="east")])
    a.env.run(until=60.0)
    assert [(round(t, 6), rid, type(d).__name__) for t, rid, what, d in log] == [(22.0, "A", Reached.__name__)]
