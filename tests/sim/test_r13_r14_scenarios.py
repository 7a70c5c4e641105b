"""R13 and R14 end to end: scenario files through the SimPy model, expectations worked out by hand.

The fleet is one robot at the origin facing +x, 1 m/s, no acceleration limits and instantaneous turns,
so a leg of d metres takes d seconds; actions take 1 s (dummy) or 2 s (load, unload).
"""

from __future__ import annotations

import math

import pytest

from tests.sim.test_scenarios import action, motion, script
from vcran.testing.checks import check_run


def cancel(t, task, motion=None, action=None):
    named = "".join(f'\n{k} = "{v}"' for k, v in (("motion", motion), ("action", action)) if v)
    return f't = {t}\nkind = "cancel"\ntask = "{task}"{named}'


def finished(out, kind):
    """``(t, id)`` of every motion_finished / action_finished event."""
    return [(e["t"], e[kind]) for e in out.of(f"{kind}_finished")]


# --- R13 -------------------------------------------------------------------------------------------------


def test_r13_a_queued_motion_cancelled_before_dispatch_is_never_driven(run_toml):
    out = run_toml(script(
        motion(1, "A", "A_m1", 1, 3, 0, 3),  # a detour that the cancel removes
        cancel(1.5, "A", motion="A_m1"),
        motion(2, "A", "A_m2", 2, 3, 4, 0),
        action(3, "A", "A_a3", 3, 3),
    ))
    assert [(e["t"], e["motion"]) for e in out.of("assignment_cancelled")] == [(1.5, "A_m1")]
    assert finished(out, "motion") == [(7.0, "A_m2")]  # dispatched at 3, straight to (4, 0): 4 s
    assert out.robot()["completed"] == ["A"]
    assert out.robot()["distance"] == 4.0
    assert not out.of("rejected")


def test_r13_an_unreached_point_of_the_driving_path_is_skipped(run_toml):
    out = run_toml(script(
        motion(1, "A", "A_m1", 1, 4, 2, 0), motion(1, "A", "A_m2", 2, 4, 2, 2),
        motion(1, "A", "A_m3", 3, 4, 4, 2), action(1, "A", "A_a4", 4, 4),
        cancel(2, "A", motion="A_m2"),  # while A_m1's leg runs (1 .. 3)
    ))
    # A_m1 reached at 3; then straight from (2, 0) to (4, 2), sqrt(8) s, without passing (2, 2)
    assert finished(out, "motion") == [(3.0, "A_m1"), (pytest.approx(3 + math.sqrt(8)), "A_m3")]
    assert out.robot()["distance"] == pytest.approx(2 + math.sqrt(8))
    assert out.robot()["final_pose"]["x"] == 4.0 and out.robot()["final_pose"]["y"] == 2.0
    assert out.robot()["completed"] == ["A"]


def test_r13_the_running_leg_is_refused_with_a_warning_and_driven(run_toml):
    out = run_toml(script(
        motion(1, "A", "A_m1", 1, 2, 2, 0), action(1, "A", "A_a2", 2, 2),
        cancel(2, "A", motion="A_m1"),
    ))
    (r,) = out.of("rejected")
    assert (r["t"], r["code"], r["severity"], r["task"], r["motion"]) == (2.0, "assignment_running", "warning", "A", "A_m1")
    assert finished(out, "motion") == [(3.0, "A_m1")]
    assert out.robot()["completed"] == ["A"]


def test_r13_every_assignment_cancelled_one_by_one_cancels_the_task(run_toml):
    out = run_toml(script(
        motion(1, "A", "A_m1", 1, 2, 5, 0), action(1, "A", "A_a2", 2, 2),  # A drives 1 .. 6
        motion(2, "B", "B_m1", 1, 2, 1, 0), action(2, "B", "B_a2", 2, 2),  # B waits behind A
        cancel(3, "B", motion="B_m1"), cancel(4, "B", action="B_a2"),
    ))
    assert [e["t"] for e in out.of("assignment_cancelled")] == [3.0, 4.0]
    (c,) = out.of("task_cancelled")
    assert (c["t"], c["task"], c["reason"]) == (4.0, "B", "cancelled")
    assert out.robot()["completed"] == ["A"] and out.robot()["distance"] == 5.0


def test_r13_a_cancel_remembered_for_the_only_assignment_cancels_its_task_on_arrival(run_toml):
    """Found by the fuzzer (the rule checks wanted a cancel_order during the task's life): a partial cancel
    for B_a1 before B exists is remembered; B_a1 arrives, is skipped, and with every position cancelled B
    ends at that instant, reason cancelled; A behind it is untouched."""
    out = run_toml(script(
        cancel(1, "B", action="B_a1"),
        action(2, "B", "B_a1", 1, 1), action(2, "A", "A_a1", 1, 1),
    ))
    assert [(e["t"], e["code"]) for e in out.of("rejected")] == [(1.0, "cancel_unknown_assignment")]
    assert [(e["t"], e["task"]) for e in out.of("task_queued")] == [(2.0, "B"), (2.0, "A")]
    assert [(e["t"], e["task"], e["reason"]) for e in out.of("task_cancelled")] == [(2.0, "B", "cancelled")]
    assert finished(out, "action") == [(3.0, "A_a1")] and out.robot()["completed"] == ["A"]
    assert check_run(out.dir, 30.0, finished=True) == []


# --- R14 -------------------------------------------------------------------------------------------------


def test_r14_last_assignment_at_first_seen_plus_timeout_as_written_is_on_time(run_toml):
    out = run_toml(script(motion(0.577, "A", "A_m1", 1, 2, 1, 0), action(30.577, "A", "A_a2", 2, 2)))
    assert out.robot()["completed"] == ["A"] and not out.of("task_cancelled")


def test_r14_an_assignment_at_the_instant_of_its_tasks_r7_deadline_comes_first(run_toml):
    """docs/determinism.md's tie order: an instant's inbound messages (1) before its R7 deadlines (5).
    A's first assignment at 1 with task_timeout 30: its timer fires at 1 + 30 + R14's 1 µs = 31.000001
    (docs/rules.md, R14 instants). The missing action arriving at that very instant is taken first, so A
    is assembled when its timer fires and runs: the leg to (1, 0) from 31.000001 to 32.000001, the
    dummy to 33.000001. The re-read of A_m1 at 2 (silent, R10) makes the script schedule the action's
    instant after A's timer was set, so the priorities decide the tie, not the order of scheduling."""
    out = run_toml(script(motion(1, "A", "A_m1", 1, 2, 1, 0), motion(2, "A", "A_m1", 1, 2, 1, 0),
                          action(31.000001, "A", "A_a2", 2, 2)))
    assert out.robot()["completed"] == ["A"]
    assert not out.of("task_cancelled") and not out.of("rejected")
    assert finished(out, "action") == [(pytest.approx(33.000001, abs=1e-9), "A_a2")]


def test_r14_an_assignment_just_after_its_tasks_r7_timer_is_too_late(run_toml):
    """The same task with the action 1 µs after the timer (31.000002): A was cancelled at 31.000001."""
    out = run_toml(script(motion(1, "A", "A_m1", 1, 2, 1, 0), action(31.000002, "A", "A_a2", 2, 2)))
    assert [(e["t"], e["reason"]) for e in out.of("task_cancelled")] == [(31.000001, "timeout")]
    assert [(e["t"], e["code"]) for e in out.of("rejected")] == [(31.000002, "task_cancelled")]


def test_r14_a_timeout_at_the_instant_a_leg_ends_stops_the_robot_there(run_toml):
    text = script(
        motion(0, "A", "A_m1", 1, 4, 10, 0), motion(0, "A", "A_m2", 2, 4, 20, 0),
        action(0, "A", "A_a3", 3, 4),  # the action at 4 never comes: A times out at 10
    ).replace("task_timeout = 30.0", "task_timeout = 10.0")
    out = run_toml(text)
    assert finished(out, "motion") == [(10.0, "A_m1")]  # the first leg ends exactly at the deadline
    (c,) = out.of("task_cancelled")
    assert (c["t"], c["reason"]) == (10.000001, "timeout")
    r = out.robot()
    assert (r["final_pose"]["x"], r["final_pose"]["y"], r["distance"]) == (10.0, 0.0, 10.0)  # not 20


def test_r14_a_cancel_just_after_an_action_ends_performs_nothing_more(run_toml):
    out = run_toml(script(
        action(0, "A", "A_a1", 1, 2, "dummy"), action(0, "A", "A_a2", 2, 2, "load"),  # A_a1: 0 .. 1
        cancel(1.0000005, "A"),  # within 1 µs of A_a1's end, when A_a2 began
    ).replace('parts = 3', 'parts = 3\nreach = 100.0'))
    assert finished(out, "action") == [(1.0, "A_a1")]  # A_a2 abandoned: never finished ...
    assert out.summary["stations"]["s1"]["parts"] == 3 and out.robot()["carrying"] == 0  # ... nor performed
    (c,) = out.of("task_cancelled")
    assert (c["t"], c["reason"]) == (1.0000005, "cancelled")


def test_r14_a_cancel_at_the_instant_an_action_ends_dispatches_nothing_more(run_toml):
    out = run_toml(script(action(0, "A", "A_a1", 1, 2), action(0, "A", "A_a2", 2, 2), cancel(1.0, "A")))
    assert finished(out, "action") == [(1.0, "A_a1")]
    assert [(e["t"], e["reason"]) for e in out.of("task_cancelled")] == [(1.0, "cancelled")]


def test_r14_a_pending_cancel_wins_over_the_failure_of_the_running_action(run_toml):
    out = run_toml(script(action(0, "A", "A_a1", 1, 1, "load"), cancel(1, "A")))  # no station in reach
    (f,) = out.of("failed")
    assert (f["t"], f["code"]) == (2.0, "no_station_in_reach")  # still reported
    (c,) = out.of("task_cancelled")
    assert (c["t"], c["reason"]) == (2.0, "cancelled")


def test_r14_a_missing_capability_fails_when_the_action_is_dispatched(run_toml):
    text = script(action(3, "A", "A_a1", 1, 1, "unload")).replace(
        'max_velocity = 1.0', 'max_velocity = 1.0\nactions = ["dummy", "load"]')
    out = run_toml(text)
    (f,) = out.of("failed")
    assert (f["t"], f["code"]) == (3.0, "action_not_capable")  # not 3 + 2 s of unloading
    assert [(e["t"], e["reason"]) for e in out.of("task_cancelled")] == [(3.0, "action_failed")]


#: Found by the fuzzer (tests/testing/test_fuzz_sim.py), as it printed it but for the robot's irrelevant
#: geometry: ``vcran run`` of this crashed (exit 70) with "action 1t1_a2 finished but none was running".
CAPABILITY_CANCEL_SAME_INSTANT = """
[simulation]
seed = 0
duration = 5000.0
until_idle = true
task_timeout = 5.0
[simulation.action_durations]
dummy = 0.5
load = 1.0
unload = 1.5
[[robots]]
id = "robot_1"
pose = [0.0, 0.0, 0.0]
max_velocity = 0.5
actions = ["dummy", "load"]
[[script]]
t = 0.0
robot = "robot_1"
kind = "action"
task = "1t1"
id = "1t1_a1"
seq = [1, 2]
action = "dummy"
[[script]]
t = 0.0
robot = "robot_1"
kind = "cancel"
task = "1t1"
action = "1t1_a1"
[[script]]
t = 0.5
robot = "robot_1"
kind = "action"
task = "1t1"
id = "1t1_a2"
seq = [2, 2]
action = "unload"
[[script]]
t = 0.5
robot = "robot_1"
kind = "cancel"
task = "1t1"
"""


def test_r14_a_cancel_at_the_instant_an_incapable_action_is_dispatched_abandons_it(run_toml):
    """By hand. t=0: 1t1_a1 (position 1 of 2) queues 1t1, m = 0 (TASK > MOTION at once, R6); the partial
    cancel skips 1t1_a1, not dispatched yet (R13). t=0.5: 1t1_a2 completes the assembly (R4/R5):
    MOTION > ACTION, 1t1_a1 is passed over, 1t1_a2 is dispatched. The robot cannot unload, so 1t1_a2
    would fail as it is dispatched (R14), a completion of t=0.5, which comes after that instant's inbound
    messages (docs/determinism.md): the whole-task cancel of t=0.5 finds 1t1_a2 begun at its own instant
    and abandons it (R14): nothing is performed, so nothing fails; 1t1 ends at 0.5, reason cancelled."""
    out = run_toml(CAPABILITY_CANCEL_SAME_INSTANT)
    assert [(e["t"], e["event"], e.get("to", e.get("task"))) for e in out.events] == [
        (0.0, "task_queued", "1t1"), (0.0, "state", "TASK"), (0.0, "state", "MOTION"),
        (0.0, "assignment_cancelled", "1t1"),
        (0.5, "state", "ACTION"), (0.5, "task_cancelled", "1t1"), (0.5, "state", "WAITING"),
    ]
    assert out.of("assignment_cancelled")[0]["action"] == "1t1_a1"
    assert out.of("task_cancelled")[0]["reason"] == "cancelled"
    assert out.robot()["completed"] == [] and out.robot()["errors"] == 0
    assert check_run(out.dir, 5.0, finished=True) == []


def test_r14_an_incapable_action_fails_before_a_cancel_of_a_later_instant(run_toml):
    """The same task with the cancel 1 s later: 1t1_a2 failed at 0.5, as dispatched (R14), so the task
    ended then with reason action_failed, and the cancel of an ended task is a warning (R8)."""
    out = run_toml(CAPABILITY_CANCEL_SAME_INSTANT.replace("t = 0.5\nrobot = \"robot_1\"\nkind = \"cancel\"",
                                                          "t = 1.5\nrobot = \"robot_1\"\nkind = \"cancel\""))
    assert [(e["t"], e["code"]) for e in out.of("failed")] == [(0.5, "action_not_capable")]
    assert [(e["t"], e["reason"]) for e in out.of("task_cancelled")] == [(0.5, "action_failed")]
    assert [(e["t"], e["code"]) for e in out.of("rejected")] == [(1.5, "cancel_finished_task")]
    assert [(e["t"], e["action"], e["ok"]) for e in out.of("action_finished")] == [(0.5, "1t1_a2", False)]


def test_r14_a_battery_running_out_as_an_incapable_action_fails_stops_the_robot_then(run_toml):
    """By hand: 1 Ah drawn at 0.25 Ah/s at rest runs out at exactly t=4, between telemetry ticks (3, 6).
    The action dispatched at 4 fails there (R14), and the robot, empty, stops at 4 too (docs/contract.md §4), not at the
    next tick (6): the failure's zero-length wait (a completion of the instant) must not hide that instant."""
    out = run_toml(script(action(4, "A", "A_a1", 1, 1, "unload")).replace(
        "max_velocity = 1.0", "max_velocity = 1.0\nactions = [\"dummy\"]\n"
        "[robots.battery]\ncapacity = 1.0\nper_idle_second = 0.25",
    ).replace("task_timeout = 30.0", "task_timeout = 30.0\ntelemetry_period = 3.0"))
    assert [(e["t"], e["code"]) for e in out.of("failed")] == [(4.0, "action_not_capable"), (4.0, "battery_empty")]
    assert [(e["t"], e["reason"]) for e in out.of("task_cancelled")] == [(4.0, "action_failed")]
    assert [e["t"] for e in out.of("battery_empty")] == [4.0]
