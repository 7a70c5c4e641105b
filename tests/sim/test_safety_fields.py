"""docs/contract.md §12 safety fields in simulated time: :class:`vcran.sim.traffic.SafetyFields` runs the pure Traffic
state machine in SimPy, with a minimal body (tests/sim/traffic_body.py), and writes ``blocked``,
``unblocked`` and ``deadlock`` events.

The robots are those of docs/robots.md's corridor: 1 m x 1 m squares around their origin, 1 m/s, 0.5 m/s^2
both ways, turns at once, fields of margin 2 m plus the braking distance, L(v) = 2 + v^2 (3 m at 1 m/s).
A leg from rest covers 1 m in its first 2 s (0.25 t^2), then 1 m/s.
"""

from __future__ import annotations

import math
from typing import Any

import pytest

from tests.sim.traffic_body import Fleet, scenario
from vcran.core.scenario import RobotConfig, TrafficSettings
from vcran.core.traffic.fields import FieldSpec

SQUARE = ((0.5, 0.5), (-0.5, 0.5), (-0.5, -0.5), (0.5, -0.5))
FIELD = FieldSpec(margin=2.0)


def robot(rid: str, x: float, y: float = 0.0, theta: float = 0.0) -> RobotConfig:
    return RobotConfig(rid, (x, y, theta), max_velocity=1.0, max_acceleration=0.5, max_deceleration=0.5,
                       footprint=SQUARE)


def corridor(**traffic: Any) -> Fleet:
    """A at W (0, 0) facing east, B at E (20, 0) facing west, each sent to the other end at t = 0."""
    fleet = Fleet(scenario([robot("A", 0.0), robot("B", 20.0, theta=math.pi)], TrafficSettings(FIELD, **traffic)))
    fleet.send("A", [(20.0, 0.0)])
    fleet.send("B", [(0.0, 0.0)])
    return fleet


def events(log: list[tuple[float, str, str, Any]], *names: str) -> list[tuple[float, str, str, Any]]:
    return [(round(t, 6), what, rid, detail) for t, what, rid, detail in log if what in names]


def test_head_on_in_the_corridor_both_block_at_9_and_deadlock_at_11() -> None:
    """docs/robots.md, "The corridor, by hand": the fields touch at t = 9 (A at 8, B at 12: A's field ends at
    8 + 0.5 + 3 = 11.5, B's side at 12 - 0.5); both brake 1 m in 2 s, stop at 9 and 11 at t = 11, each in the
    other's waiting field: one ``deadlock`` (a cycle, A first in fleet order) at 11. Nothing moves after it."""
    fleet = corridor()
    log = fleet.run(120.0)
    blocked = events(log, "blocked")
    assert [(t, rid, d["other"]) for t, _, rid, d in blocked] == [(9.0, "A", "B"), (9.0, "B", "A")]
    assert [(round(d["x"], 6), round(d["y"], 6)) for *_, d in blocked] == [(8.0, 0.0), (12.0, 0.0)]
    # A, blocked since 9, waits for B, which waits for A
    assert events(log, "deadlock") == [(11.0, "deadlock", "A", {"kind": "cycle", "other": "B", "duration": 2.0})]
    assert events(log, "unblocked", "arrived") == []
    assert [tuple(round(v, 6) for v in fleet.kinematics.rest[i][:2]) for i in (0, 1)] == [(9.0, 0.0), (11.0, 0.0)]
    fields = fleet.fields  # blocked from 9 to the end (120): 111 s each, 2 blocks, 1 deadlock
    assert fields.blocks == [1, 1]
    assert fields.figures() == pytest.approx({"blocks": 2, "blocked_time": 222.0, "deadlocks": 1})


def test_on_deadlock_cancel_tells_the_protocol_to_cancel_both() -> None:
    """``on_deadlock = "cancel"``: the deadlocked robots are told to cancel (reason deadlock, the protocol's
    part); their bodies halt and rest, which ends their blocks: ``unblocked`` after 11 - 9 = 2 s each."""
    fleet = corridor(on_deadlock="cancel")
    cancelled: list[tuple[float, int, tuple[int, ...]]] = []

    class Cancel:
        def blocked(self, robot: int, other: int) -> None:
            pass

        def unblocked(self, robot: int) -> None:
            pass

        def cancel(self, robot: int, robots: Any) -> None:
            cancelled.append((fleet.env.now, robot, tuple(robots)))
            fleet.robots[robot].halt()

    fleet.fields.signals = Cancel()
    log = fleet.run(120.0)
    assert [(round(t, 6), r, rs) for t, r, rs in cancelled] == [(11.0, 0, (1,)), (11.0, 1, (0,))]
    assert events(log, "halted", "unblocked") == [
        (11.0, "halted", "A", pytest.approx((9.0, 0.0))), (11.0, "unblocked", "A", {"duration": pytest.approx(2.0)}),
        (11.0, "halted", "B", pytest.approx((11.0, 0.0))), (11.0, "unblocked", "B", {"duration": pytest.approx(2.0)})]
    assert fleet.fields.figures() == pytest.approx({"blocks": 2, "blocked_time": 4.0, "deadlocks": 1})


def parked(bound: float | None = None) -> Fleet:
    """A drives from (0, 0) east to (20, 0); B stands at (15, 0) until t = 30, then drives north to (15, 10)."""
    fleet = Fleet(scenario([robot("A", 0.0), robot("B", 15.0, theta=math.pi / 2)], TrafficSettings(FIELD, bound)))
    fleet.send("A", [(20.0, 0.0)])
    fleet.send("B", [(15.0, 10.0)], start=30.0)
    return fleet


def test_a_robot_waits_for_one_parked_in_its_way_and_drives_on_when_it_leaves() -> None:
    """A's field (3 m at 1 m/s, from its front x_A + 0.5) reaches B's side at 14.5 when x_A = 11: t = 12 (A at
    1 + (t - 2) from t = 2). A brakes 1 m in 2 s: at rest at 12 from t = 14, 2 m short of B (12.5 to 14.5).
    B leaves at t = 30 going north: its square clears A's field (y up to 0.5) once y_B - 0.5 > 0.5, after 1 m
    from rest, 2 s: t = 32. A drives on from rest the last 8 m: 2 s up (1 m), 6 s at 1 m/s, 2 s down:
    arrives at t = 42. B is never blocked (A is behind its field); a parked robot has no field."""
    log = parked().run(120.0)
    assert events(log, "blocked", "unblocked", "arrived") == [
        (12.0, "blocked", "A", {"other": "B", "x": pytest.approx(11.0), "y": 0.0}),
        (32.0, "unblocked", "A", {"duration": pytest.approx(20.0)}),
        (42.0, "arrived", "B", (15.0, 10.0)),  # 10 m from rest: 2 s up, 8 s at 1 m/s, 2 s down from t = 30
        (42.0, "arrived", "A", (20.0, 0.0)),  # B's end was scheduled first (at 30): it comes first at the tie
    ]
    assert events(log, "deadlock") == []


def test_a_robot_blocked_past_the_bound_is_a_deadlock_once() -> None:
    """With ``deadlock_bound = 10`` A, blocked from t = 12, is reported at t = 22 (kind bound, blocked 10 s),
    once, naming B in its field; it still drives on when B leaves (t = 32) and arrives at 42."""
    log = parked(bound=10.0).run(120.0)
    assert events(log, "deadlock") == [(22.0, "deadlock", "A", {"kind": "bound", "other": "B", "duration": 10.0})]
    assert events(log, "arrived")[-1] == (42.0, "arrived", "A", (20.0, 0.0))


def test_the_same_run_twice_logs_the_same() -> None:
    """Determinism (docs/contract.md §5): the same robots and routes give the same log, event for event."""
    assert corridor().run(120.0) == corridor().run(120.0)
    assert parked(10.0).run(120.0) == parked(10.0).run(120.0)
