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
* with fields on and collisions reported, no ``collision`` between two robots both in a motion whose fields
  are long enough to stop: on a one-way lane (every robot faces and drives east) any margin is (a
  follower's field of margin plus its braking distance stops it short of what entered it, and a leader
  never drives back); head-on, each margin must exceed the braking distance of a robot coming the other
  way (docs/robots.md, "Head-on: how long fields must be": both close the gap), so the head-on fleets draw
  margins above ``BRAKING``. The last tests derive the head-on case by hand at, above and below that
  bound.

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
MARGINS = (0.5, 1.0, 2.0)
LONG_ENOUGH = (1.5, 2.0, 3.0)  # above BRAKING, the braking distance of any robot coming the other way


@st.composite
def corridors(draw: st.DrawFn, one_way: bool = False, margins: tuple[float, ...] = MARGINS) -> dict[str, Any]:
    """2-4 robots on the x axis, 3 m or more apart, facing either way; each sent to one or two points of
    the lane at drawn instants; fields of a margin drawn from ``margins`` plus the braking distance.
    ``one_way``: all face east and are sent only east, each goal past the last."""
    n = draw(st.integers(2, 4))
    slots = sorted(draw(st.lists(st.integers(0, 8), min_size=n, max_size=n, unique=True)))
    margin = draw(st.sampled_from(margins))
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


#: fleets whose fields are long enough to stop (module docstring): one way with any margin, or both ways
#: with margins above the braking distance
STOPPING = st.one_of(corridors(one_way=True), corridors(margins=LONG_ENOUGH))


@settings(max_examples=40)
@given(STOPPING)
def test_no_contact_between_robots_in_motion(data: dict[str, Any]) -> None:
    """docs/contract.md §12, issue 32 item 6: fields long enough to stop keep moving robots apart, one way
    and head-on."""
    check_no_contact_in_motion(run(data))


@pytest.mark.slow
@settings(max_examples=400)
@given(STOPPING)
def test_all_three_properties_in_a_longer_search(data: dict[str, Any]) -> None:
    """The three properties above on one run each, searched longer (docs/contract.md §12)."""
    result = run(data)
    check_stops_when_blocked(result)
    check_blocked_time(result)
    check_no_contact_in_motion(result)


def head_on(margin: float) -> vcran.Result:
    """The head-on pair the contact property first found (docs/contract.md §12): r1 rests at 0 facing east and
    is sent to 3; r2 rests at 6 facing west and is sent to 0; both at t = 0, fields of ``margin`` plus the
    braking distance (``margin + v^2``)."""
    robot = {"max_velocity": SPEED, "max_acceleration": DECEL, "footprint": SQUARE}
    return run({"simulation": {"name": "lane", "duration": DURATION}, "traffic": {"field": {"margin": margin}},
                "robots": [{"id": "r1", "pose": [0.0, 0.0, 0.0], **robot},
                           {"id": "r2", "pose": [6.0, 0.0, math.pi], **robot}],
                "script": [{"t": 0.0, "robot": "r1", "kind": "task", "task": "a", "path": [[3.0, 0.0]]},
                           {"t": 0.0, "robot": "r2", "kind": "task", "task": "b", "path": [[0.0, 0.0]]}]})


def seen(result: vcran.Result) -> dict[tuple[str, str], dict[str, Any]]:
    """The run's events by (event, robot), the last of each."""
    return {(e["event"], e["robot"]): e for e in result.events}


def at_end(result: vcran.Result) -> list[float]:
    """Where r1 and r2 stand at the run's end (x)."""
    return [round(float(x), 6) for x in result.telemetry[result.telemetry["t"] == DURATION]["x"]]


def test_head_on_both_fields_see_the_other_and_stop_them_margin_minus_braking_apart() -> None:
    """docs/robots.md "Head-on: how long fields must be", on :func:`head_on`, derived by hand.

    r1's 3 m leg: 2 s up to x = 1, 1 s at 1 m/s to 2 (t = 3), 2 s down to 3 (t = 5); r2's 6 m leg: 2 s up to
    5, then 1 m/s. The gap between their fronts is ``x2 - x1 - 1``: ``5 - t^2/2`` up to t = 2, then
    ``3 - 2 (t - 2)``. r2's goal is far: its field is ``m + v^2``; r1's is ``min(m + v^2, s + m)`` with ``s``
    its distance to its goal, 3 - x1 >= 1 = v^2 while it cruises: ``m + v^2`` too. Both fields reach the
    other when the gap is ``m + 1`` (in the cruise for m < 2): t = 3 - m/2, r1 at 2 - m/2, r2 at 4 + m/2,
    **both blocked at once**. Each brakes 1 m in 2 s: both stop at t = 5 - m/2, r1 at 3 - m/2 (short of its
    goal), r2 at 3 + m/2, their fronts ``m - 1`` apart: each margin less the other's braking distance. At
    rest, each in the other's waiting field: a deadlock at 5 - m/2.

    Margin 1.5: blocked at 2.25 (r1 at 1.25, r2 at 4.75), stopped at 4.25 at 2.25 and 3.75, 0.5 m apart: no
    contact. Margin 1, the pair as found: blocked at 2.5 (1.5 and 4.5), stopped at 4.5 at 2.5 and 3.5, fronts
    both at 3.0: touching, which counts as contact (docs/contract.md §4), so a margin must *exceed* the other's
    braking distance. The gap is then ``2 - 2 tau + tau^2 / 2`` (tau from 2.5), 0 at tau = 2 only: the
    contact starts as both come to rest, t = 4.5, at (3, 0).

    Before the cut moved to the goal plus the margin, r1's field ended at its goal's front (3.5) and saw r2
    only once r2 passed it, after r1 had begun to slow for its goal: r1 stopped at 3 and r2 at 3.5, 0.5 m
    into each other."""
    for margin, blocked, x1, x2 in ((1.5, 2.25, 1.25, 4.75), (1.0, 2.5, 1.5, 4.5)):
        result = head_on(margin)
        events = seen(result)
        assert [(events["blocked", r]["t"], events["blocked", r]["x"]) for r in ("r1", "r2")] == [
            (pytest.approx(blocked), pytest.approx(x1)), (pytest.approx(blocked), pytest.approx(x2))]
        assert at_end(result) == [3 - margin / 2, 3 + margin / 2]
        assert events["deadlock", "r1"]["t"] == pytest.approx(5 - margin / 2)
        collisions = [e for e in result.events if e["event"] == "collision"]
        if margin > BRAKING:
            assert collisions == []
        else:
            # the gap is 0.5 (4.5 - t)^2 m before 4.5, under the positions' rounding (4e-16 m at x = 3) from
            # 3e-8 s before: the contact is found there, or at 4.5
            [contact] = collisions
            assert (contact["t"], contact["x"], contact["y"]) == (
                pytest.approx(4.5, abs=1e-6), pytest.approx(3.0), pytest.approx(0.0, abs=EPS))


def test_head_on_a_margin_below_the_others_braking_distance_ends_in_contact() -> None:
    """The condition is needed (docs/robots.md "Head-on: how long fields must be"): :func:`head_on` with a
    margin of 0.5 m, below the 1 m either robot needs to brake. Fields ``0.5 + v^2``, 1.5 m at 1 m/s; by the
    derivation above both are blocked at t = 3 - 0.25 = 2.75, r1 at 1.75, r2 at 4.25, their fronts 1.5 m
    apart. Both brake, ``tau - tau^2 / 4`` each in ``tau`` s: the gap ``1.5 - 2 tau + tau^2 / 2`` is 0 at
    tau = 1: **contact at t = 3.75**, r1 at 2.5 and r2 at 3.5, their fronts meeting at (3, 0), while both
    still brake (in a motion). They stop at t = 4.75 at 2.75 and 3.25, overlapping by 0.5 m, deadlocked."""
    result = head_on(0.5)
    events = seen(result)
    assert [events["blocked", r]["t"] for r in ("r1", "r2")] == [pytest.approx(2.75)] * 2
    contact = events["collision", "r1"]
    assert (contact["other"], contact["t"], contact["x"], contact["y"]) == (
        "r2", pytest.approx(3.75), pytest.approx(3.0), pytest.approx(0.0, abs=EPS))
    assert at_end(result) == [2.75, 3.25]
    assert events["deadlock", "r1"]["t"] == pytest.approx(4.75)
    with pytest.raises(AssertionError, match="contact in motion"):
        check_no_contact_in_motion(result)


def test_the_strategy_makes_robots_meet() -> None:
    """The properties are not vacuous: the strategy draws fleets whose robots block one another (hypothesis
    finds one, or raises NoSuchExample), and blocks that end (an ``unblocked``)."""

    def events_of(data: dict[str, Any]) -> set[str]:
        return {e["event"] for e in run(data).events}

    settings_ = settings(max_examples=200, database=None, phases=[Phase.generate])  # found, not shrunk
    assert "blocked" in events_of(find(corridors(), lambda d: "blocked" in events_of(d), settings=settings_))
    assert "unblocked" in events_of(find(corridors(), lambda d: "unblocked" in events_of(d), settings=settings_))
