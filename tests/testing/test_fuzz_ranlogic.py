"""Model-based stateful fuzzing of RanLogic (docs/contract.md §3, R1–R10, R12) against the reference model.

The machine lives in :mod:`vcran.testing.stateful` so that users can run it too; this module runs it
under the active hypothesis profile (``vcran`` by default, ``vcran-deep`` for campaigns; docs/fuzzing.md).
"""

from __future__ import annotations

import pytest

from vcran.core.opil.effects import Reason
from vcran.core.opil.ids import id_for
from vcran.testing.plans import TaskPlan
from vcran.testing.stateful import RanLogicMachine

TestRanLogicAgainstModel = pytest.mark.slow(RanLogicMachine.TestCase)


# Shrunk examples pasted verbatim from failures of the machine against deliberate mutations of RanLogic
# (docs/fuzzing.md): they stay as regression tests of the rule each mutation broke.


def test_r7_timer_at_exactly_the_deadline_cancels():
    """Mutation ``now > task.deadline`` in on_timer: the deadline instant must cancel (R7)."""
    state = RanLogicMachine()
    state.configure(limit=2)
    plans_0 = state.first_plan(plan=TaskPlan(task='A', length=1, motions=0))  # noqa: F841 - pasted verbatim from hypothesis
    plans_1 = state.plan(plan=TaskPlan(task='A', length=2, motions=0))
    state.send(plan=plans_1, pos=1, variant='planned')
    state.advance(dt=10.0)
    state.advance(dt=0.0)
    state.rules_hold()
    state.teardown()


def test_r8_cancel_while_driving_stops_after_the_running_leg():
    """Mutation "cancel at once even while a leg runs": R8 wants StopAfterLeg, then the cancel. (The
    advance step was added by hand when R14 came: a cancel at the instant the path went out abandons it.)"""
    state = RanLogicMachine()
    state.configure(limit=2)
    plans_0 = state.first_plan(plan=TaskPlan(task='A', length=1, motions=1))
    state.send_task(backwards=False, plan=plans_0, rotate=0)
    state.advance(dt=1.0)
    state.cancel(plan=plans_0, variant='whole')
    state.rules_hold()
    state.finish_leg()
    state.rules_hold()
    state.teardown()


def test_r10_reread_of_a_failed_tasks_assignment_is_silent():
    """Mutation "reject every assignment of an ended task": an identical re-read stays silent (R10)."""
    state = RanLogicMachine()
    state.configure(limit=2)
    plans_0 = state.first_plan(plan=TaskPlan(task='A', length=1, motions=0))
    sent_0 = state.send(plan=plans_0, pos=1, variant='planned')
    state.finish_action(ok=False)
    state.resend(a=sent_0)
    state.rules_hold()
    state.teardown()


# Targeted examples for the two mutations the ``ci`` profile found in only some seeds (issue 13 item 7):
# written as machine steps, so that they check RanLogic against the reference model the way the fuzzing does.


def test_r14_a_cancel_pending_while_the_action_fails_ends_cancelled():
    """Mutation "the failure's reason wins over a pending cancel" (found in 8 of 10 ci seeds): the cancel
    came first, so the task ends ``cancelled`` (R14); the failure is still reported, as a second error."""
    state = RanLogicMachine()
    state.configure(limit=2)
    plans_0 = state.first_plan(plan=TaskPlan(task='A', length=1, motions=0))
    state.send(plan=plans_0, pos=1, variant='planned')  # the action goes out at once
    state.advance(dt=1.0)
    state.cancel(plan=plans_0, variant='whole')  # pending: the action runs to its end (R8)
    state.rules_hold()
    state.finish_action(ok=False)
    state.rules_hold()
    assert state.logic.history.get(id_for('A')).reason is Reason.CANCELLED
    state.teardown()


def test_r2_an_action_just_before_a_planned_motion_is_rejected():
    """Mutation "an action may sit before a motion" (found in 2 of 10 ci seeds): a motion holds position 2,
    an action arrives for position 1 — R2 rejects it (kind_order), the task keeps waiting for its motion."""
    state = RanLogicMachine()
    state.configure(limit=2)
    plans_0 = state.first_plan(plan=TaskPlan(task='A', length=2, motions=2))
    state.send(plan=plans_0, pos=2, variant='planned')
    state.send(plan=plans_0, pos=1, variant='other_kind')
    state.rules_hold()
    assert state.logic.error_count == 1
    state.send(plan=plans_0, pos=1, variant='planned')  # the motion it waited for: the path goes out
    state.rules_hold()
    assert len(state.driver.legs) == 2
    state.teardown()
