"""docs/contract.md §12 under hypothesis (issue 32 item 6): small fleets on a one-lane corridor, every robot
with a protective field, driven by short scripts; the properties are judged from the run's events and
telemetry alone (:func:`vcran.simulate`'s Result), not from the traffic model's state.

* a robot never drives while its field holds another robot: from a ``blocked`` event to its ``unblocked``
  (or the run's end) the robot brakes straight on and stays stopped, so it ends at most its braking
  distance ``v_max^2 / (2 d)`` from where it began to brake and its speed, sampled each tick, is 0 from
  ``v_max / d`` after the block on (docs/robots.md "Fields": "brakes at once ... `v² / 2d` further,
  `v / d` later ... and waits");
* blocked time equals the sum of its block intervals: every ``unblocked`` follows one ``blocked`` of its
  robot and its ``duration`` is the time between them; summary.json's ``blocked_time`` is the sum of the
  closed intervals plus the open ones up to the run's end ("every `blocked` is followed by one
  `unblocked`, and a robot's blocked time is the sum of its blocks");
* with fields on and collisions reported, no ``collision`` between two robots both in a motion, on a
  one-way lane (every robot faces and drives east): a follower's field of margin plus its braking
  distance stops it short of what entered it, and a leader never drives back. Head-on it does not hold
  for any margin, as docs/robots.md's fields are cut at the end of the motion:
  ``test_head_on_a_robot_brakes_into_the_goal_of_one_whose_field_is_cut``.

The default profile runs a few dozen examples (quick); the ``slow`` test searches longer.
"""

from __future__ import annotations

import math
from typing import Any

import pytest
from hypothesis import Phase, find, given, settings
from hypothesis import strategies as st

import vcran
from vcran.io.scenario_file import parse

SPEED, DECEL = 1.0, 0.5
BRAKING = SPEED**2 / (2 * DECEL)  # 1 m, the farthest a robot drives once blocked
SQUARE = [[0.5, 0.5], [-0.5, 0.5], [-0.5, -0.5], [0.5, -0.5]]
DURATION = 60.0
EPS = 1e-6


@st.composite
def corridors(draw: st.DrawFn, one_way: bool = False) -> dict[str, Any]:
    """2-4 robots on the x axis, 3 m or more apart, facing either way; each sent to one or two points of
    the lane at drawn instants; fields of a drawn margin plus the braking distance. ``one_way``: all face
    east and are sent only east, each goal past the last."""
    n = draw(st.integers(2, 4))
    slots = sorted(draw(st.lists(st.integers(0, 8), min_size=n, max_size=n, unique=True)))
    margin = draw(st.sampled_from([0.5, 1.0, 2.0]))
    robots, script = [], []
    for i, slot in enumerate(slots):
        rid = f"r{i + 1}"
        theta = 0.0 if one_way else draw(st.sampled_from([0.0, math.pi]))
        x = 3 * slot
        robots.append({"id": rid, "pose": [3.0 * slot, 0.0, theta], "max_velocity": SPEED,
                       "max_acceleration": DECEL, "footprint": SQUARE})
        times = sorted(draw(st.lists(st.integers(0, 12), min_size=1, max_size=2)))  # its goals in order
        for k, t in enumerate(times):
            x = draw(st.integers(x + 1, x + 12)) if one_way else draw(st.integers(0, 24))
            script.append({"t": float(t), "robot": rid, "kind": "task",
                           "task": f"{rid}-{k}", "path": [[float(x), 0.0]]})
    script.sort(key=lambda s: s["t"])  # stable: a robot's tasks stay in order
    return {"simulation": {"name": "lane", "duration": DURATION}, "traffic": {"field": {"margin": margin}},
            "robots": robots, "script": script}


def blocks(result: vcran.Result) -> dict[str, list[tuple[float, float | None, dict[str, Any]]]]:
    """Each robot's blocks: (start, end or None while open at the run's end, the ``blocked`` event)."""
    out: dict[str, list[tuple[float, float | None, dict[str, Any]]]] = {r: [] for r in result.robots}
    for e in result.events:
        if e["event"] == "blocked":
            assert not out[e["robot"]] or out[e["robot"]][-1][1] is not None, f"blocked twice: {e}"
            out[e["robot"]].append((e["t"], None, e))
        elif e["event"] == "unblocked":
            assert out[e["robot"]] and out[e["robot"]][-1][1] is None, f"unblocked without a block: {e}"
            start, _, blocked = out[e["robot"]][-1]
            assert e["duration"] == pytest.approx(e["t"] - start, abs=EPS)
            out[e["robot"]][-1] = (start, e["t"], blocked)
    return out


def check_stops_when_blocked(result: vcran.Result) -> None:
    rows = result.telemetry
    for rid, intervals in blocks(result).items():
        mine = rows[rows["robot"] == rid]
        for start, end, blocked in intervals:
            end = DURATION if end is None else end
            during = mine[(mine["t"] >= start) & (mine["t"] <= end)]
            for row in during:
                moved = math.hypot(row["x"] - blocked["x"], row["y"] - blocked["y"])
                assert moved <= BRAKING + EPS, f"{rid} drove {moved} m while blocked at t={row['t']}"
                if row["t"] >= start + SPEED / DECEL + EPS:
                    assert row["v"] == pytest.approx(0.0, abs=EPS), f"{rid} at {row['v']} m/s at t={row['t']}"


def check_blocked_time(result: vcran.Result) -> None:
    for rid, intervals in blocks(result).items():
        total = sum((DURATION if end is None else end) - start for start, end, _ in intervals)
        figures = result.summary["robots"][rid]
        assert figures["blocks"] == len(intervals)
        assert figures["blocked_time"] == pytest.approx(total, abs=EPS)


def in_motion(result: vcran.Result) -> dict[str, list[tuple[float, float]]]:
    """Each robot's spans in state MOTION, from the state events (the last one open to the run's end)."""
    spans: dict[str, list[tuple[float, float]]] = {r: [] for r in result.robots}
    since: dict[str, float] = {}
    for e in result.events:
        if e["event"] != "state":
            continue
        if e["to"] == "MOTION":
            since[e["robot"]] = e["t"]
        elif e["from"] == "MOTION":
            spans[e["robot"]].append((since.pop(e["robot"]), e["t"]))
    for rid, t in since.items():
        spans[rid].append((t, DURATION))
    return spans


def check_no_contact_in_motion(result: vcran.Result) -> None:
    spans = in_motion(result)

    def moving(rid: str, t: float) -> bool:
        return any(a <= t <= b for a, b in spans[rid])

    for e in result.events:
        if e["event"] == "collision":
            assert not (moving(e["robot"], e["t"]) and moving(e["other"], e["t"])), f"contact in motion: {e}"


def run(data: dict[str, Any]) -> vcran.Result:
    return vcran.simulate(parse(data, "<lane>"))


@settings(max_examples=30)
@given(corridors())
def test_a_blocked_robot_brakes_and_waits(data: dict[str, Any]) -> None:
    """docs/contract.md §12: a robot never drives while its field holds another robot."""
    check_stops_when_blocked(run(data))


@settings(max_examples=30)
@given(corridors())
def test_blocked_time_is_the_sum_of_the_blocks(data: dict[str, Any]) -> None:
    """docs/contract.md §12: each unblocked closes one block; the summary's blocked time is their sum."""
    check_blocked_time(run(data))


@settings(max_examples=30)
@given(corridors(one_way=True))
def test_no_contact_between_robots_in_motion(data: dict[str, Any]) -> None:
    """docs/contract.md §12, issue 32 item 6: fields long enough to stop keep moving robots apart."""
    check_no_contact_in_motion(run(data))


@pytest.mark.slow
@settings(max_examples=400)
@given(corridors(one_way=True))
def test_all_three_properties_in_a_longer_search(data: dict[str, Any]) -> None:
    """The three properties above on one run each, searched longer (docs/contract.md §12)."""
    result = run(data)
    check_stops_when_blocked(result)
    check_blocked_time(result)
    check_no_contact_in_motion(result)


def test_head_on_a_robot_brakes_into_the_goal_of_one_whose_field_is_cut() -> None:
    """Found by the contact property when it drew head-on traffic (docs/contract.md §12; pinned as the
    model now behaves, and reported on issue 32). Margin 1 m, so fields are 1 + v^2 (2 m at 1 m/s). r1 at
    0 is sent to 3 (a 3 m leg: 2 s up to x = 1, 1 s at 1 m/s, 2 s down: at rest at 3 at t = 5, its field
    never past its goal's front, 3.5); r2 at 6 is sent to 0. At t = 2.5 r2 (at 4.5, front 4.0, field to
    2.0) meets r1's front (1.5 + 0.5 = 2.0): r2 brakes 1 m in 2 s and stops at 3.5, front 3.0, at 4.5.
    r1's field, cut at 3.5, holds r2 only once r2's front passes 3.5; r1 is then already braking to its
    goal (it brakes at the same 0.5 m/s^2), so it still stops with its front at 3.5: the two overlap by
    0.5 m. The contact starts between r2's crossing 3.5 and r1's stop (3.09 s and 5 s); both robots are
    in a motion then, blocked on each other: a deadlock once both rest."""
    result = run({"simulation": {"name": "lane", "duration": DURATION}, "traffic": {"field": {"margin": 1.0}},
                  "robots": [{"id": "r1", "pose": [0.0, 0.0, 0.0], "max_velocity": SPEED, "max_acceleration": DECEL,
                              "footprint": SQUARE},
                             {"id": "r2", "pose": [6.0, 0.0, math.pi], "max_velocity": SPEED,
                              "max_acceleration": DECEL, "footprint": SQUARE}],
                  "script": [{"t": 0.0, "robot": "r1", "kind": "task", "task": "a", "path": [[3.0, 0.0]]},
                             {"t": 0.0, "robot": "r2", "kind": "task", "task": "b", "path": [[0.0, 0.0]]}]})
    seen = {(e["event"], e["robot"]): e for e in result.events}
    assert seen["blocked", "r2"]["t"] == pytest.approx(2.5)
    assert seen["blocked", "r2"]["x"] == pytest.approx(4.5)
    assert 2.5 < seen["blocked", "r1"]["t"] < 5.0
    assert 3.0 < seen["collision", "r1"]["t"] < 5.0
    end = result.telemetry[result.telemetry["t"] == DURATION]
    assert [round(float(x), 6) for x in end["x"]] == [3.0, 3.5]  # r1 at its goal, r2 1 m short of its stop
    assert seen["deadlock", "r1"]["t"] == pytest.approx(5.0)


def test_the_strategy_makes_robots_meet() -> None:
    """The properties are not vacuous: the strategy draws fleets whose robots block one another (hypothesis
    finds one, or raises NoSuchExample), and blocks that end (an ``unblocked``)."""

    def events_of(data: dict[str, Any]) -> set[str]:
        return {e["event"] for e in run(data).events}

    settings_ = settings(max_examples=200, database=None, phases=[Phase.generate])  # found, not shrunk
    assert "blocked" in events_of(find(corridors(), lambda d: "blocked" in events_of(d), settings=settings_))
    assert "unblocked" in events_of(find(corridors(), lambda d: "unblocked" in events_of(d), settings=settings_))
