"""RanLogic, rule by rule (docs/contract.md §3). Pure: no SimPy, inputs are method calls, outputs are effect lists."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vcran.core.opil.build import action, cancel, motion
from vcran.core.opil.codec import decode_attribute, encode_attribute
from vcran.core.opil.effects import (
    ClearTimer,
    DispatchAction,
    DispatchPath,
    Failed,
    MotionFinished,
    Reason,
    Rejected,
    StartTimer,
    State,
    StateChanged,
    StopAfterLeg,
    TaskCancelled,
    TaskCompleted,
    TaskQueued,
)
from vcran.core.opil.ids import Id, id_for
from vcran.core.opil.motion_area import motion_area_problem
from vcran.core.opil.ranlogic import TRANSITIONS, LocalProtocolError, RanLogic

T = id_for


def of(effects, cls):
    return [e for e in effects if isinstance(e, cls)]


def states(effects):
    return [(e.from_.value, e.to.value) for e in of(effects, StateChanged)]


def codes(effects):
    return [e.code for e in of(effects, Rejected)]


def two_motion_task(logic, t0, task="A", load="dummy"):
    """Feed a 3-position task (two motions, one action) at t0, t0+1, t0+2; return all effects."""
    out = logic.on_motion(t0, motion(task, f"{task}_m1", 1, 3, 1, 0))
    out += logic.on_motion(t0 + 1, motion(task, f"{task}_m2", 2, 3, 2, 0))
    out += logic.on_action(t0 + 2, action(task, f"{task}_a1", 3, 3, load))
    return out


def drive_all(logic, now):
    """Report every leg of the current path finished at ``now``."""
    out = []
    while logic.current_motion.uuid != bytes(16):
        out += logic.on_motion_finished(now, logic.current_motion)
    return out


# --- R1 ---------------------------------------------------------------------------------------------------


def test_r1_first_assignment_creates_task_and_makes_it_current():
    logic = RanLogic("r")
    out = logic.on_motion(5.0, motion("A", "A_m1", 1, 2, 1, 0))
    assert of(out, TaskQueued)[0].task == T("A")
    assert states(out) == [("WAITING", "TASK")]
    assert logic.current_task == T("A")
    assert of(out, StartTimer) == [StartTimer(T("A"), 35.000001)]  # first_seen + default timeout + 1 µs (R14)


def test_r1_tasks_run_in_first_seen_order_not_assembly_order():
    logic = RanLogic("r")
    logic.on_motion(1, motion("A", "A_m1", 1, 2, 1, 0))  # A first seen at 1, not yet assembled
    two_motion_task(logic, 2, "B")  # B assembled at 4
    assert list(logic.queue) == [T("A"), T("B")]
    assert logic.current_task == T("A")
    assert logic.state is State.TASK  # B must wait although it is complete
    out = logic.on_action(5, action("A", "A_a1", 2, 2))
    assert of(out, DispatchPath)[0].task == T("A")


# --- R2 ---------------------------------------------------------------------------------------------------


def test_r2_length_is_fixed_by_first_assignment():
    logic = RanLogic("r")
    logic.on_motion(1, motion("A", "A_m1", 1, 3, 1, 0))
    out = logic.on_motion(2, motion("A", "A_m2", 2, 4, 2, 0))
    assert codes(out) == ["length_mismatch"]
    assert len(logic.queue[T("A")].slots) == 1


def test_r2_a_position_holds_one_assignment():
    logic = RanLogic("r")
    logic.on_motion(1, motion("A", "A_m1", 1, 3, 1, 0))
    out = logic.on_motion(2, motion("A", "A_other", 1, 3, 5, 5))
    assert codes(out) == ["position_taken"]
    assert out[0].motion == T("A_other") and out[0].task == T("A")


def test_r2_motions_before_actions():
    logic = RanLogic("r")
    logic.on_action(1, action("A", "A_a1", 2, 3))
    out = logic.on_motion(2, motion("A", "A_m3", 3, 3, 1, 0))
    assert codes(out) == ["kind_order"]
    out = logic.on_action(3, action("A", "A_a0", 1, 3))  # fine: actions may start at 1 (m = 0)
    assert codes(out) == []


def test_r2_rejection_leaves_rest_of_task_untouched():
    logic = RanLogic("r")
    logic.on_motion(1, motion("A", "A_m1", 1, 2, 1, 0))
    before = dict(logic.queue[T("A")].slots)
    logic.on_action(2, action("A", "A_bad", 1, 2))  # position taken
    out = logic.on_action(3, action("A", "A_a1", 2, 2))
    assert logic.queue[T("A")].slots[1] == before[1]
    assert of(out, DispatchPath)


# --- R3, R4, R5 -------------------------------------------------------------------------------------------


def test_r3_path_waits_for_first_action_position():
    logic = RanLogic("r")
    out = logic.on_motion(1, motion("A", "A_m1", 1, 3, 1, 0))
    out += logic.on_motion(2, motion("A", "A_m2", 2, 3, 2, 0))
    assert not of(out, DispatchPath)  # m is unknown until position 3 is an action
    out = logic.on_action(3, action("A", "A_a1", 3, 3))
    (path,) = of(out, DispatchPath)
    assert [m.motion_id for m in path.motions] == [T("A_m1"), T("A_m2")]


def test_r3_out_of_order_motions_dispatch_in_sequence_order():
    logic = RanLogic("r")
    logic.on_action(1, action("A", "A_a1", 3, 3))
    logic.on_motion(2, motion("A", "A_m2", 2, 3, 2, 0))
    out = logic.on_motion(3, motion("A", "A_m1", 1, 3, 1, 0))
    (path,) = of(out, DispatchPath)
    assert [m.sequence.sequence_number for m in path.motions] == [1, 2]


def test_r3_all_motion_task_dispatches_when_every_position_is_a_motion():
    logic = RanLogic("r")
    logic.on_motion(1, motion("A", "A_m1", 1, 2, 1, 0))
    out = logic.on_motion(2, motion("A", "A_m2", 2, 2, 2, 0))
    assert of(out, DispatchPath)
    out = drive_all(logic, 10)
    # empty action phase passes at once (R6)
    assert states(out) == [("MOTION", "ACTION"), ("ACTION", "WAITING")]
    assert of(out, TaskCompleted)


def test_r4_actions_wait_until_every_action_is_received():
    logic = RanLogic("r")
    logic.on_motion(1, motion("A", "A_m1", 1, 3, 1, 0))
    logic.on_action(2, action("A", "A_a1", 2, 3))
    out = drive_all(logic, 5)
    assert logic.state is State.MOTION and not of(out, DispatchAction)  # position 3 missing
    out = logic.on_action(6, action("A", "A_a2", 3, 3))
    assert states(out) == [("MOTION", "ACTION")]
    assert [d.action.action_id for d in of(out, DispatchAction)] == [T("A_a1")]


def test_r4_actions_one_at_a_time_in_sequence_order():
    logic = RanLogic("r")
    logic.on_action(1, action("A", "A_a2", 2, 2))
    out = logic.on_action(2, action("A", "A_a1", 1, 2))
    assert states(out) == [("TASK", "MOTION"), ("MOTION", "ACTION")]  # empty motion phase
    assert [d.action.action_id for d in of(out, DispatchAction)] == [T("A_a1")]
    out = logic.on_action_finished(3, T("A_a1"))
    assert [d.action.action_id for d in of(out, DispatchAction)] == [T("A_a2")]
    out = logic.on_action_finished(4, T("A_a2"))
    assert of(out, TaskCompleted)


def test_r5_assembled_task_clears_its_timer():
    logic = RanLogic("r")
    out = two_motion_task(logic, 1)
    assert of(out, ClearTimer) == [ClearTimer(T("A"))]


# --- R6 ---------------------------------------------------------------------------------------------------


def test_r6_full_cycle_and_nothing_else():
    logic = RanLogic("r")
    out = two_motion_task(logic, 1)
    out += drive_all(logic, 10)
    out += logic.on_action_finished(15, T("A_a1"))
    assert states(out) == [("WAITING", "TASK"), ("TASK", "MOTION"), ("MOTION", "ACTION"), ("ACTION", "WAITING")]
    assert set(states(out)) <= {(a.value, b.value) for a, b in TRANSITIONS}
    assert logic.idle


def test_r6_next_task_starts_right_after_completion():
    logic = RanLogic("r")
    two_motion_task(logic, 1, "A")
    two_motion_task(logic, 4, "B")
    drive_all(logic, 10)
    out = logic.on_action_finished(15, T("A_a1"))
    assert states(out) == [("ACTION", "WAITING"), ("WAITING", "TASK"), ("TASK", "MOTION")]
    assert of(out, DispatchPath)[0].task == T("B")


# --- R7 ---------------------------------------------------------------------------------------------------


def test_r7_queued_task_times_out_at_exactly_its_deadline():
    logic = RanLogic("r", task_timeout=10)
    two_motion_task(logic, 0, "A")
    logic.on_motion(3, motion("B", "B_m1", 1, 2, 1, 0))  # B never assembled, deadline 13
    assert logic.on_timer(12.999, T("B")) == []  # early call: nothing
    out = logic.on_timer(13.0, T("B"))
    assert of(out, TaskCancelled) == [TaskCancelled(T("B"), Reason.TIMEOUT)]
    assert T("B") not in logic.queue and logic.current_task == T("A")


def test_r7_current_task_times_out_after_its_running_leg():
    logic = RanLogic("r", task_timeout=10)
    logic.on_motion(0, motion("A", "A_m1", 1, 3, 1, 0))
    logic.on_action(1, action("A", "A_a1", 2, 3))  # R3 holds (m = 1), R4 does not: 3 is missing
    out = logic.on_timer(10, T("A"))
    assert out == [StopAfterLeg(T("A"))]  # leg A_m1 is running (R8 applies)
    out = logic.on_motion_finished(12, T("A_m1"))
    assert of(out, TaskCancelled) == [TaskCancelled(T("A"), Reason.TIMEOUT)]
    assert states(out) == [("MOTION", "WAITING")]


def test_r7_assembled_task_never_times_out():
    logic = RanLogic("r", task_timeout=10)
    two_motion_task(logic, 0)
    assert logic.on_timer(10, T("A")) == []
    assert logic.current_task == T("A")


# --- R8 ---------------------------------------------------------------------------------------------------


def test_r8_cancel_queued_task_removes_it():
    logic = RanLogic("r")
    two_motion_task(logic, 0, "A")
    two_motion_task(logic, 3, "B")
    out = logic.on_cancel(10, cancel("B"))
    assert of(out, TaskCancelled) == [TaskCancelled(T("B"), Reason.CANCELLED)]
    assert list(logic.queue) == [T("A")] and not states(out)


def test_r8_ran_status_shows_a_queued_task_cancelled_while_the_state_stays():
    """docs/contract.md §8 ran_status after a cancel that changes neither the state nor the arrivals: B leaves the queue
    and shows as cancelled (ran_status is rebuilt only when what it shows changed)."""
    logic = RanLogic("r")
    two_motion_task(logic, 0, "A")
    two_motion_task(logic, 3, "B")
    before = logic.ran_status()
    assert before.state == "MOTION" and before.queue == (T("A"), T("B")) and before.cancelled == ()
    logic.on_cancel(10, cancel("B"))
    after = logic.ran_status()
    assert after.state == "MOTION" and after.queue == (T("A"),) and after.queued == 1
    assert [(end.task_id, end.reason) for end in after.cancelled] == [(T("B"), "cancelled")]


def test_r8_cancel_current_task_waits_for_running_leg_then_next_starts():
    logic = RanLogic("r")
    logic.on_motion(0, motion("A", "A_m1", 1, 4, 1, 0))
    logic.on_motion(0, motion("A", "A_m2", 2, 4, 2, 0))
    logic.on_motion(0, motion("A", "A_m3", 3, 4, 3, 0))
    logic.on_action(0, action("A", "A_a1", 4, 4))
    two_motion_task(logic, 1, "B")
    logic.on_motion_finished(5, T("A_m1"))
    out = logic.on_cancel(6, cancel("A"))
    assert out == [StopAfterLeg(T("A"))]  # A_m2 is running: it finishes
    out = logic.on_motion_finished(8, T("A_m2"))
    assert of(out, MotionFinished)[0].motion == T("A_m2")
    assert of(out, TaskCancelled) == [TaskCancelled(T("A"), Reason.CANCELLED)]
    assert not [d for d in of(out, DispatchPath) if d.task == T("A")]  # A_m3 never dispatched
    assert states(out) == [("MOTION", "WAITING"), ("WAITING", "TASK"), ("TASK", "MOTION")]
    assert of(out, DispatchPath)[0].task == T("B")


def test_r8_cancel_during_action_waits_for_it():
    logic = RanLogic("r")
    logic.on_motion(0, motion("A", "A_m1", 1, 3, 1, 0))
    logic.on_action(0, action("A", "A_a1", 2, 3))
    logic.on_action(0, action("A", "A_a2", 3, 3))
    drive_all(logic, 2)
    assert logic.current_action == T("A_a1")
    assert logic.on_cancel(3, cancel("A")) == []
    out = logic.on_action_finished(4, T("A_a1"))
    assert not of(out, DispatchAction)  # A_a2 never dispatched
    assert of(out, TaskCancelled) == [TaskCancelled(T("A"), Reason.CANCELLED)]


def test_r8_cancel_with_nothing_running_is_immediate():
    logic = RanLogic("r")
    logic.on_motion(0, motion("A", "A_m1", 1, 2, 1, 0))  # TASK: nothing dispatched
    out = logic.on_cancel(1, cancel("A"))
    assert of(out, TaskCancelled) and states(out) == [("TASK", "WAITING")]


def test_r8_cancel_for_unknown_task_is_remembered_and_warned():
    logic = RanLogic("r")
    out = logic.on_cancel(1, cancel("X"))
    (w,) = of(out, Rejected)
    assert w.code == "cancel_unknown_task" and w.severity == "warning" and w.task == T("X")
    out = logic.on_motion(2, motion("X", "X_m1", 1, 1, 1, 0))
    assert codes(out) == ["task_cancelled"]
    assert not logic.queue


def test_r8_nil_ids_in_cancel_mean_whole_task():
    from vcran.core.opil.ids import NIL
    from vcran.core.opil.messages import CancelTask

    logic = RanLogic("r")
    logic.on_motion(0, motion("A", "A_m1", 1, 2, 1, 0))
    out = logic.on_cancel(1, CancelTask(T("A"), NIL, NIL))
    assert of(out, TaskCancelled)


@pytest.mark.parametrize("ending", ["cancel", "timeout"])
def test_r8_an_assignment_for_a_task_whose_cancel_is_pending_is_rejected(ending):
    """R8: the current task's running leg finishes before the task ends; an assignment arriving meanwhile
    is rejected (docs/rules.md: task_cancelled, "or one being cancelled") and changes nothing. R7 hands a
    timed-out current task to R8, so a pending timeout is the same case. Here A_a3 is the piece that
    would complete the task: taken, it would assemble A (a ClearTimer) as if the cancel had not come."""
    logic = RanLogic("r", task_timeout=10)
    logic.on_motion(0, motion("A", "A_m1", 1, 3, 1, 0))
    logic.on_action(0, action("A", "A_a2", 2, 3))  # R3 (m = 1): the leg to (1, 0) runs from 0; 3 is missing
    pending = logic.on_cancel(1, cancel("A")) if ending == "cancel" else logic.on_timer(10, T("A"))
    assert pending == [StopAfterLeg(T("A"))]  # R8: not ended yet, the leg is still running
    errors = logic.error_count
    out = logic.on_action(11, action("A", "A_a3", 3, 3))
    (r,) = of(out, Rejected)
    assert (r.code, r.severity, r.task, r.action) == ("task_cancelled", "error", T("A"), T("A_a3"))
    assert out == [r] and logic.error_count == errors + 1  # nothing else: no ClearTimer, no TaskQueued
    assert sorted(logic.queue[T("A")].slots) == [1, 2]
    out = logic.on_motion_finished(12, T("A_m1"))
    reason = Reason.CANCELLED if ending == "cancel" else Reason.TIMEOUT
    assert of(out, TaskCancelled) == [TaskCancelled(T("A"), reason)] and not of(out, DispatchAction)


# --- R9 ---------------------------------------------------------------------------------------------------


def test_r9_assignment_for_completed_task_is_rejected():
    logic = RanLogic("r")
    two_motion_task(logic, 0)
    drive_all(logic, 5)
    logic.on_action_finished(6, T("A_a1"))
    out = logic.on_motion(7, motion("A", "A_new", 1, 3, 9, 9))
    assert codes(out) == ["task_completed"] and not logic.queue


def test_r9_history_is_bounded():
    logic = RanLogic("r", history_limit=3)
    for i in range(5):
        logic.on_motion(i, motion(f"T{i}", f"T{i}_m", 1, 2, 1, 0))
        logic.on_cancel(i, cancel(f"T{i}"))
    assert list(logic.history) == [T("T2"), T("T3"), T("T4")]
    # forgotten ids start a new task again
    out = logic.on_motion(10, motion("T0", "T0_m", 1, 2, 1, 0))
    assert of(out, TaskQueued)


# --- R10 --------------------------------------------------------------------------------------------------


def test_r10_identical_duplicate_is_silent():
    logic = RanLogic("r")
    m = motion("A", "A_m1", 1, 3, 1, 0)
    logic.on_motion(0, m)
    version = logic.version
    assert logic.on_motion(1, m) == []
    assert logic.version == version and logic.error_count == 0


def test_r10_identical_re_read_after_completion_is_silent():
    logic = RanLogic("r")
    two_motion_task(logic, 0)
    drive_all(logic, 5)
    logic.on_action_finished(6, T("A_a1"))
    assert logic.on_action(7, action("A", "A_a1", 3, 3)) == []  # polling re-reads the attribute
    assert logic.on_cancel(8, cancel("B")) != []  # a new cancel is news
    assert logic.on_cancel(9, cancel("B")) == []  # its re-read is not


def test_r10_new_content_before_dispatch_replaces():
    logic = RanLogic("r")
    logic.on_motion(0, motion("A", "A_m1", 1, 2, 1, 0))
    logic.on_motion(1, motion("A", "A_m1", 1, 2, 7, 7))  # same id, new point
    out = logic.on_action(2, action("A", "A_a1", 2, 2))
    (path,) = of(out, DispatchPath)
    assert path.motions[0].point.x == 7


def test_r10_new_content_after_dispatch_is_rejected():
    logic = RanLogic("r")
    two_motion_task(logic, 0)
    out = logic.on_motion(5, motion("A", "A_m1", 1, 3, 9, 9))
    assert codes(out) == ["already_dispatched"]


def test_r10_replacement_obeys_position_rules():
    logic = RanLogic("r")
    logic.on_motion(0, motion("A", "A_m1", 1, 3, 1, 0))
    logic.on_motion(0, motion("A", "A_m2", 2, 3, 1, 0))
    out = logic.on_motion(1, motion("A", "A_m1", 2, 3, 1, 0))  # moving onto A_m2's position
    assert codes(out) == ["position_taken"]
    assert logic.queue[T("A")].slots[1].motion_id == T("A_m1")


def test_r10_an_action_that_moved_before_dispatch_cannot_move_again_once_the_path_is_dispatched():
    """R10 (docs/rules.md, R10 replacement): new content may move an assignment to a free position until
    the path is dispatched; after that actions keep their position (position_changed). A_a3 moves once
    while nothing is dispatched, then A_a2 completes R3 and the path goes; moving A_a3 back to the still
    free position 4 is refused, and the task finishes with A_a3 where it was."""
    logic = RanLogic("r")
    logic.on_motion(0, motion("A", "A_m1", 1, 4, 1, 0))
    logic.on_action(0, action("A", "A_a3", 4, 4))
    moved = logic.on_action(1, action("A", "A_a3", 3, 4))  # 4 -> 3: R3 does not hold yet (2 is empty)
    assert not of(moved, Rejected) and logic.queue[T("A")].slots[3].action_id == T("A_a3")
    assert of(logic.on_action(2, action("A", "A_a2", 2, 4)), DispatchPath)  # R3: m = 1, the path goes
    out = logic.on_action(3, action("A", "A_a3", 4, 4))  # moving again, to the free position 4
    (r,) = of(out, Rejected)
    assert (r.code, r.task, r.action) == ("position_changed", T("A"), T("A_a3")) and out == [r]
    assert {p: a.action_id for p, a in logic.queue[T("A")].slots.items() if p > 1} == {2: T("A_a2"), 3: T("A_a3")}
    logic.on_action(4, action("A", "A_a4", 4, 4))  # position 4 is still free for its own action
    drive_all(logic, 5)
    performed = []
    while logic.current_action != Id(bytes(16)):
        performed.append(logic.current_action)
        logic.on_action_finished(6, logic.current_action)
    assert performed == [T("A_a2"), T("A_a3"), T("A_a4")]


# --- R12 --------------------------------------------------------------------------------------------------

SQUARE = [(0.0, 0.0), (4.0, 0.0), (4.0, 4.0), (0.0, 4.0)]
TRIANGLE = [(0.0, 0.0), (4.0, 0.0), (0.0, 4.0)]


@pytest.mark.parametrize(("area", "x", "y"), [
    (SQUARE, 2.0, 0.0),  # the middle of the lower edge
    (SQUARE, 0.0, 3.0),  # on the left edge
    (SQUARE, 4.0, 4.0),  # a corner
    (TRIANGLE, 1.5, 2.5),  # on the slanted edge x + y = 4 (exact in binary)
])
def test_r12_a_target_exactly_on_its_motion_areas_boundary_is_inside(area, x, y):
    """R12 rejects a target *outside* a non-empty motion_area: the polygon's outline belongs to it
    (shapely's covers, not contains), so a point drawn on the edge of the area is a valid target."""
    logic = RanLogic("r", area_check=motion_area_problem)
    out = logic.on_motion(0, motion("A", "A_m1", 1, 2, x, y, area=area))
    assert not of(out, Rejected) and of(out, TaskQueued) == [TaskQueued(T("A"))]


@pytest.mark.parametrize(("x", "y"), [(2.0, -0.001), (4.001, 4.0)])
def test_r12_a_target_just_outside_its_motion_area_is_rejected(x, y):
    logic = RanLogic("r", area_check=motion_area_problem)
    out = logic.on_motion(0, motion("A", "A_m1", 1, 2, x, y, area=SQUARE))
    assert codes(out) == ["outside_motion_area"] and not logic.queue


# --- failures and misuse ------------------------------------------------------------------------------------


def test_failed_action_cancels_task_with_reason_and_error():
    logic = RanLogic("r")
    two_motion_task(logic, 0, load="load")
    drive_all(logic, 5)
    out = logic.on_action_finished(6, T("A_a1"), ok=False, code="load_no_part", message="no part")
    (f,) = of(out, Failed)
    assert f.code == "load_no_part" and f.count == 1
    assert of(out, TaskCancelled) == [TaskCancelled(T("A"), Reason.ACTION_FAILED)]


def test_error_count_runs_over_all_errors():
    logic = RanLogic("r")
    logic.on_malformed(0, "motion_assignment", "x: missing")
    out = logic.on_cancel(1, cancel("nope"))
    assert of(out, Rejected)[0].count == 2


def test_time_going_backwards_is_a_local_error():
    logic = RanLogic("r")
    logic.on_motion(5, motion("A", "A_m1", 1, 2, 1, 0))
    with pytest.raises(LocalProtocolError, match="backwards"):
        logic.on_motion(4, motion("A", "A_m2", 2, 2, 1, 0))


def test_completion_nobody_dispatched_is_a_local_error():
    logic = RanLogic("r")
    with pytest.raises(LocalProtocolError, match="no leg was running"):
        logic.on_motion_finished(1, T("x"))


def test_core_imports_neither_simpy_nor_httpx():
    import subprocess
    import sys

    # Every module of the core package (the import contracts check the same statically, in .ci/run).
    code = (
        "import importlib, pkgutil, sys, vcran.core; "
        "[importlib.import_module(m.name) for m in pkgutil.walk_packages(vcran.core.__path__, 'vcran.core.')]; "
        "bad = [m for m in ('simpy', 'httpx') if m in sys.modules]; print(bad); sys.exit(1 if bad else 0)"
    )
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert result.returncode == 0, result.stdout + result.stderr


def test_r10_resend_with_new_header_stamp_is_a_duplicate():
    logic = RanLogic("r")
    logic.on_motion(0, motion("A", "A_m1", 1, 3, 1, 0, stamp=0.0))
    version = logic.version
    assert logic.on_motion(1, motion("A", "A_m1", 1, 3, 1, 0, stamp=1.0)) == []
    assert logic.version == version
    assert logic.on_motion(2, motion("A", "A_m1", 1, 3, 1, 0.5, stamp=2.0)) == []  # new point: replaced
    assert logic.version == version + 1
    assert logic.queue[T("A")].slots[1].point.y == 0.5


@pytest.mark.slow
@settings(max_examples=150)
@given(st.data())
def test_r10_fingerprint_agrees_with_identity(data):
    """Ended tasks keep fingerprints (R9 history): equal exactly when R10 calls two assignments identical."""
    from vcran.core.opil.history import fingerprint
    from vcran.core.opil.tasks import same_content
    from vcran.testing.strategies import action_assignments, motion_assignments

    kind = data.draw(st.sampled_from([motion_assignments, action_assignments]))
    a = data.draw(kind())
    b = data.draw(st.one_of(kind(), st.just(a), st.builds(lambda: _restamped(a)),
                            st.builds(lambda: _zeros_flipped(a))))
    assert (fingerprint(a) == fingerprint(b)) == same_content(a, b)


def test_r10_fingerprint_does_not_depend_on_which_objects_hold_equal_values():
    """pickle memoizes by object identity: one bytes object used for two ids pickled as a reference, two
    equal ones in full, so R10-identical assignments got different fingerprints (a built motion, whose
    point_id and motion_id are one Id, against the same motion decoded from the wire). Found by
    test_r10_fingerprint_agrees_with_identity, which drew it once in a full suite run."""
    from vcran.core.opil.history import fingerprint
    from vcran.core.opil.messages import ActionAssignment, RobotAction, Sequence
    from vcran.core.opil.tasks import same_content

    one, other = bytes.fromhex("11" * 16), bytes.fromhex("11" * 16)
    assert one == other and one is not other
    shared = ActionAssignment(Id(one), Id(one), Sequence(1, 1), RobotAction(5, 0, (), ""))
    separate = ActionAssignment(Id(one), Id(other), Sequence(1, 1), RobotAction(5, 0, (), ""))
    assert same_content(shared, separate) and fingerprint(shared) == fingerprint(separate)
    built = motion("A", "A_m1", 1, 1, 2.0, 0.0)
    decoded = decode_attribute("motion_assignment", encode_attribute("motion_assignment", built))
    assert same_content(built, decoded) and fingerprint(built) == fingerprint(decoded)


def test_r10_a_zero_of_the_other_sign_is_identical_live_and_ended():
    """-0.0 == 0.0 for R10 while the task is queued; the R9 history's fingerprint must agree (issue 13)."""
    from dataclasses import replace

    logic = RanLogic("r", task_timeout=10)
    m = motion("A", "A_m1", 1, 1, 0.0, 2.0)
    flipped = replace(m, point=replace(m.point, x=-0.0))
    logic.on_motion(0.0, m)
    assert logic.on_motion(0.1, flipped) == []  # live: identical (R10)
    drive_all(logic, 1.0)
    assert logic.history.get(T("A")).reason is None  # completed
    assert logic.on_motion(2.0, flipped) == []  # ended: still identical, not rejected (R9 only for new content)


def _zeros_flipped(a):
    """``a`` with the sign of every float zero flipped: R10-identical to ``a``."""
    from dataclasses import fields, is_dataclass, replace

    def flip(v):
        if is_dataclass(v) and not isinstance(v, type):
            return replace(v, **{f.name: flip(getattr(v, f.name)) for f in fields(v) if f.init})
        if isinstance(v, tuple):
            return tuple(flip(x) for x in v)
        return -v if type(v) is float and v == 0 else v

    return flip(a)


def _restamped(a):
    from dataclasses import replace

    from vcran.core.opil.messages import Header, MotionAssignment, Time

    return replace(a, header=Header((a.header.seq + 1) % 2**32, Time(7, 0), "x")) if isinstance(a, MotionAssignment) else a


def test_a_transition_outside_the_state_machine_is_refused_and_emits_nothing():  # R6
    """RanLogic checks every transition against TRANSITIONS (the check and the event share one lookup)."""
    logic = RanLogic("r")
    assert logic.state is State.WAITING and (State.WAITING, State.ACTION) not in TRANSITIONS
    with pytest.raises(AssertionError, match=r"WAITING -> ACTION does not exist \(R6\)"):
        logic._set_state(State.ACTION)
    assert logic.state is State.WAITING and logic._end() == []
    logic._set_state(State.TASK)
    assert logic._end() == [StateChanged(State.WAITING, State.TASK)]
