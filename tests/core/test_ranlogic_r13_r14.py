"""R13 (partial cancel) and R14 (instants and reasons), rule by rule on the pure RanLogic (docs/contract.md §3).

Every expectation is derived by hand from the text of docs/contract.md: which positions a task has, what runs when, and
what the rule says must happen next.
"""

from __future__ import annotations

from tests.core.test_ranlogic import of
from vcran.core.opil.build import action, cancel, motion
from vcran.core.opil.effects import (
    Abandon,
    ActionFinished,
    AssignmentCancelled,
    ClearTimer,
    DispatchAction,
    DispatchPath,
    Failed,
    Reason,
    Rejected,
    SkipMotion,
    StartTimer,
    StopAfterLeg,
    TaskCancelled,
    TaskCompleted,
)
from vcran.core.opil.ids import NIL, id_for
from vcran.core.opil.ranlogic import TOLERANCE, RanLogic

T = id_for


def warnings(effects):
    return [(e.code, e.severity) for e in of(effects, Rejected)]


def path_of(effects):
    (d,) = of(effects, DispatchPath)
    return [m.motion_id.description for m in d.motions]


def four_position_task(logic, t, task="A"):
    """Motions 1..3 to x = 1, 2, 3 and one dummy action at 4, all at ``t``: the path goes out at once."""
    out = []
    for i in (1, 2, 3):
        out += logic.on_motion(t, motion(task, f"{task}_m{i}", i, 4, i, 0))
    return out + logic.on_action(t, action(task, f"{task}_a4", 4, 4))


# --- R13: not yet dispatched ------------------------------------------------------------------------------


def test_r13_a_motion_cancelled_before_dispatch_is_dropped_from_the_path():
    logic = RanLogic("r")
    logic.on_motion(0, motion("A", "A_m1", 1, 3, 1, 0))
    logic.on_motion(0, motion("A", "A_m2", 2, 3, 2, 0))
    out = logic.on_cancel(1, cancel("A", motion="A_m1"))
    assert out == [AssignmentCancelled(T("A"), "motion", T("A_m1"))]  # no error, the task lives on
    out = logic.on_action(2, action("A", "A_a3", 3, 3))  # R3 holds: positions 1, 2 motions, 3 an action
    assert path_of(out) == ["A_m2"]  # the cancelled point is not driven
    out = logic.on_motion_finished(5, T("A_m2"))
    assert of(out, DispatchAction)[0].action.action_id == T("A_a3")


def test_r13_a_cancelled_action_is_never_performed():
    logic = RanLogic("r")
    logic.on_action(0, action("A", "A_a1", 1, 2))  # no motions: A_a1 runs at once
    logic.on_action(0, action("A", "A_a2", 2, 2))
    assert logic.current_action == T("A_a1")
    out = logic.on_cancel(1, cancel("A", action="A_a2"))
    assert out == [AssignmentCancelled(T("A"), "action", T("A_a2"))]
    out = logic.on_action_finished(2, T("A_a1"))
    assert not of(out, DispatchAction)  # A_a2 skipped ...
    assert of(out, TaskCompleted) == [TaskCompleted(T("A"))]  # ... and the task completes (R13: counts as received)


def test_r13_cancelled_position_counts_as_received_for_r3_to_r5():
    """A task whose only missing piece is cancelled: its position counts as received."""
    logic = RanLogic("r")
    logic.on_action(0, action("B", "B_a1", 1, 1))  # B runs first, so A waits in the queue
    logic.on_motion(0, motion("A", "A_m1", 1, 2, 1, 0))
    logic.on_action(0, action("A", "A_a2", 2, 2))
    logic.on_cancel(1, cancel("A", motion="A_m1"))
    out = logic.on_action_finished(2, T("B_a1"))
    assert not of(out, DispatchPath)  # A's path is empty: MOTION passes at once (R6)
    assert of(out, DispatchAction)[0].action.action_id == T("A_a2")


# --- R13: on the path being driven --------------------------------------------------------------------------


def test_r13_an_unreached_point_of_the_driving_path_is_skipped_after_the_running_leg():
    logic = RanLogic("r")
    four_position_task(logic, 0)
    assert logic.current_motion == T("A_m1")
    out = logic.on_cancel(1, cancel("A", motion="A_m2"))
    assert out == [AssignmentCancelled(T("A"), "motion", T("A_m2")), SkipMotion(T("A"), T("A_m2"))]
    logic.on_motion_finished(2, T("A_m1"))
    assert logic.current_motion == T("A_m3")  # A_m2's point is not driven
    out = logic.on_motion_finished(4, T("A_m3"))
    assert of(out, DispatchAction)[0].action.action_id == T("A_a4")


def test_r13_the_running_leg_cannot_be_cancelled():
    logic = RanLogic("r")
    four_position_task(logic, 0)
    out = logic.on_cancel(1, cancel("A", motion="A_m1"))
    assert warnings(out) == [("assignment_running", "warning")] and len(out) == 1
    (w,) = out
    assert (w.task, w.motion, w.action) == (T("A"), T("A_m1"), NIL)
    assert logic.current_motion == T("A_m1")


def test_r13_a_reached_point_or_a_performed_action_cannot_be_cancelled():
    logic = RanLogic("r")
    four_position_task(logic, 0)
    logic.on_motion_finished(1, T("A_m1"))
    assert warnings(logic.on_cancel(2, cancel("A", motion="A_m1"))) == [("assignment_finished", "warning")]
    logic.on_motion_finished(3, T("A_m2"))
    logic.on_motion_finished(4, T("A_m3"))
    assert warnings(logic.on_cancel(5, cancel("A", action="A_a4"))) == [("assignment_running", "warning")]
    logic.on_action_finished(6, T("A_a4"))
    out = logic.on_cancel(7, cancel("A", action="A_a4"))  # the task completed: R8's finished-task warning
    assert warnings(out) == [("cancel_finished_task", "warning")]


def test_r13_one_refused_id_in_a_cancel_refuses_the_whole_cancel():
    """R12's "nothing is applied partially", for a cancel naming a motion and an action."""
    logic = RanLogic("r")
    four_position_task(logic, 0)
    before = logic.version
    out = logic.on_cancel(1, cancel("A", motion="A_m1", action="A_a4"))  # A_m1 runs
    assert warnings(out) == [("assignment_running", "warning")] and len(out) == 1
    assert logic.version == before
    logic.on_motion_finished(2, T("A_m1"))
    logic.on_motion_finished(3, T("A_m2"))
    logic.on_motion_finished(4, T("A_m3"))
    assert logic.current_action == T("A_a4")  # still performed


def test_r13_cancelling_every_assignment_one_by_one_cancels_the_task():
    logic = RanLogic("r")
    logic.on_action(0, action("B", "B_a1", 1, 1))  # B runs; A waits in the queue
    logic.on_motion(0, motion("A", "A_m1", 1, 2, 1, 0))
    logic.on_action(0, action("A", "A_a2", 2, 2))
    assert not of(logic.on_cancel(1, cancel("A", motion="A_m1")), TaskCancelled)
    out = logic.on_cancel(2, cancel("A", action="A_a2"))
    assert of(out, TaskCancelled) == [TaskCancelled(T("A"), Reason.CANCELLED)]
    assert list(logic.queue) == [T("B")]
    assert logic.history.get(T("A")).reason is Reason.CANCELLED


def test_r13_a_cancelled_assignment_cannot_be_replaced_but_its_re_read_is_silent():
    logic = RanLogic("r")
    logic.on_action(0, action("B", "B_a1", 1, 1))
    m = motion("A", "A_m1", 1, 2, 1, 0)
    logic.on_motion(0, m)
    logic.on_cancel(1, cancel("A", motion="A_m1"))
    assert logic.on_motion(2, m) == []  # R10: identical re-read
    assert logic.on_cancel(2, cancel("A", motion="A_m1")) == []  # the cancel re-read too
    out = logic.on_motion(3, motion("A", "A_m1", 1, 2, 5, 5))
    assert [e.code for e in of(out, Rejected)] == ["assignment_cancelled"]


def test_r13_unknown_ids_are_reported_remembered_and_skipped_on_arrival():
    logic = RanLogic("r")
    logic.on_action(0, action("B", "B_a1", 1, 1))
    out = logic.on_cancel(1, cancel("A", action="A_a2"))  # task A never seen
    assert warnings(out) == [("cancel_unknown_assignment", "warning")]
    assert out[0].action == T("A_a2") and out[0].task == T("A")
    assert T("A") not in logic.history  # only that assignment is doomed, not the task (R8 tombstone)
    logic.on_motion(2, motion("A", "A_m1", 1, 2, 1, 0))
    out = logic.on_action(3, action("A", "A_a2", 2, 2))
    assert of(out, AssignmentCancelled) == [AssignmentCancelled(T("A"), "action", T("A_a2"))]
    assert not of(out, Rejected) and of(out, ClearTimer)  # assembled (R5): its timer goes
    out = logic.on_action_finished(4, T("B_a1"))
    assert path_of(out) == ["A_m1"]
    out = logic.on_motion_finished(5, T("A_m1"))
    assert of(out, TaskCompleted) == [TaskCompleted(T("A"))]  # A_a2 never performed


def test_r13_unknown_id_of_a_queued_task_is_remembered_too():
    logic = RanLogic("r")
    logic.on_motion(0, motion("A", "A_m1", 1, 2, 1, 0))
    out = logic.on_cancel(1, cancel("A", action="A_a2"))
    assert warnings(out) == [("cancel_unknown_assignment", "warning")]
    out = logic.on_action(2, action("A", "A_a2", 2, 2))
    assert path_of(out) == ["A_m1"]
    out = logic.on_motion_finished(3, T("A_m1"))
    assert not of(out, DispatchAction) and of(out, TaskCompleted)


def test_r13_partial_cancel_of_a_task_being_cancelled_changes_nothing():
    logic = RanLogic("r")
    four_position_task(logic, 0)
    logic.on_cancel(1, cancel("A"))  # whole task: ends after A_m1
    assert logic.on_cancel(2, cancel("A", motion="A_m3")) == []


# --- R14: tolerance --------------------------------------------------------------------------------------


def test_r14_deadline_timer_waits_out_the_tolerance():
    """0.577 + 30 is not 30.577 in binary; the timer fires after 30.577 + 1 µs, as written in decimal."""
    logic = RanLogic("r", task_timeout=30)
    out = logic.on_motion(0.577, motion("A", "A_m1", 1, 2, 1, 0))
    assert 0.577 + 30 != 30.577  # the rounding the rule is about
    assert of(out, StartTimer) == [StartTimer(T("A"), 30.577001)]
    out = logic.on_action(30.577, action("A", "A_a2", 2, 2))  # "as the scenario writes it": on time
    assert of(out, ClearTimer) == [ClearTimer(T("A"))] and not of(out, Rejected)


def test_r14_an_input_within_the_tolerance_after_the_deadline_is_on_time():
    logic = RanLogic("r", task_timeout=10)
    logic.on_motion(0, motion("A", "A_m1", 1, 2, 1, 0))
    out = logic.on_action(10.0000009, action("A", "A_a2", 2, 2))
    assert not of(out, Rejected) and of(out, ClearTimer)


def driving_unassembled(logic):
    """Task A of length 4: motions 1, 2 and the action at 3 at t = 0, so the path [A_m1, A_m2] goes out
    (R3); the action at 4 never comes, so A is not assembled and its deadline stands (R7)."""
    logic.on_motion(0, motion("A", "A_m1", 1, 4, 1, 0))
    logic.on_motion(0, motion("A", "A_m2", 2, 4, 2, 0))
    out = logic.on_action(0, action("A", "A_a3", 3, 4))
    assert path_of(out) == ["A_m1", "A_m2"]


def test_r14_a_timeout_at_the_instant_a_leg_ends_stops_the_robot_there():
    logic = RanLogic("r", task_timeout=10)
    driving_unassembled(logic)
    logic.on_motion_finished(10.0, T("A_m1"))  # the leg ends at the deadline; A_m2 begins
    assert logic.current_motion == T("A_m2")
    out = logic.on_timer(10.000001, T("A"))
    assert out[0] == Abandon(T("A"))  # A_m2 does not happen: the robot stays at A_m1's point
    assert of(out, TaskCancelled) == [TaskCancelled(T("A"), Reason.TIMEOUT)]
    assert not of(out, StopAfterLeg) and logic.current_task == NIL


def test_r14_a_timeout_two_microseconds_after_a_leg_began_waits_for_its_end():
    logic = RanLogic("r", task_timeout=10)
    driving_unassembled(logic)
    logic.on_motion_finished(10.0 - 2 * TOLERANCE, T("A_m1"))  # A_m2 began 2 µs before the deadline
    out = logic.on_timer(10.000001, T("A"))
    assert out == [StopAfterLeg(T("A"))]  # R8: it runs to its end, nothing after it
    out = logic.on_motion_finished(11.0, T("A_m2"))
    assert of(out, TaskCancelled) == [TaskCancelled(T("A"), Reason.TIMEOUT)]


def test_r14_a_cancel_at_the_instant_an_action_ends_stops_there():
    logic = RanLogic("r")
    logic.on_action(0, action("A", "A_a1", 1, 2))
    logic.on_action(0, action("A", "A_a2", 2, 2))
    out = logic.on_action_finished(5.0, T("A_a1"))
    assert of(out, DispatchAction)[0].action.action_id == T("A_a2")  # began at 5.0
    out = logic.on_cancel(5.0, cancel("A"))
    assert out[0] == Abandon(T("A"))
    assert of(out, TaskCancelled) == [TaskCancelled(T("A"), Reason.CANCELLED)]
    assert not of(out, ActionFinished) and logic.last_finished_action == T("A_a1")


def test_r14_a_cancel_two_microseconds_after_an_action_began_waits_for_it():
    logic = RanLogic("r")
    logic.on_action(0, action("A", "A_a1", 1, 2))
    logic.on_action(0, action("A", "A_a2", 2, 2))
    logic.on_action_finished(5.0, T("A_a1"))
    assert logic.on_cancel(5.000002, cancel("A")) == []  # R8: A_a2 runs to its end
    out = logic.on_action_finished(6.0, T("A_a2"))
    assert of(out, TaskCancelled) == [TaskCancelled(T("A"), Reason.CANCELLED)]


# --- R14: the first reason wins --------------------------------------------------------------------------


def test_r14_cancel_pending_while_the_running_action_fails_ends_cancelled():
    logic = RanLogic("r")
    logic.on_action(0, action("A", "A_a1", 1, 1, "load"))
    assert logic.on_cancel(1, cancel("A")) == []  # pending: A_a1 runs
    out = logic.on_action_finished(5, T("A_a1"), ok=False, code="load_no_part", message="no part")
    assert [f.code for f in of(out, Failed)] == ["load_no_part"]  # the failure is still reported
    assert of(out, TaskCancelled) == [TaskCancelled(T("A"), Reason.CANCELLED)]


def test_r14_timeout_pending_while_a_cancel_arrives_ends_timeout():
    """(No action runs while a timeout is pending: actions go only once the task is assembled, R4, R7.)"""
    logic = RanLogic("r", task_timeout=10)
    driving_unassembled(logic)
    assert logic.on_timer(10.000001, T("A")) == [StopAfterLeg(T("A"))]  # pending: A_m1 runs
    assert logic.on_cancel(11, cancel("A")) == []
    out = logic.on_motion_finished(12, T("A_m1"))
    assert of(out, TaskCancelled) == [TaskCancelled(T("A"), Reason.TIMEOUT)]
