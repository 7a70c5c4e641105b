"""The reference model's R2 check and the R6 table of the checks, against docs/contract.md worked by hand.

Both are restated in ``vcran.testing`` rather than taken from RanLogic, so that a mistake in RanLogic
shows as a disagreement; these tests pin the restatements themselves to the words of docs/contract.md.
"""

from __future__ import annotations

import pytest

from vcran.core.opil.build import action, motion
from vcran.core.opil.effects import State
from vcran.testing.checks import check_states
from vcran.testing.model import TRANSITIONS, position_problem

W, T, M, A = State.WAITING, State.TASK, State.MOTION, State.ACTION


def test_r6_the_checks_allow_exactly_the_cycle_and_cancels():
    """R6: WAITING -> TASK -> MOTION -> ACTION -> WAITING; cancel from any state to WAITING (from WAITING
    there is nothing to cancel). Six transitions, listed by hand."""
    assert TRANSITIONS == {(W, T), (T, M), (M, A), (A, W), (T, W), (M, W)}


def state(t, frm, to, robot="r"):
    return {"event": "state", "t": t, "robot": robot, "from": frm, "to": to}


def test_r6_check_states_flags_a_transition_outside_the_cycle_and_a_jump():
    ok = [state(1, "WAITING", "TASK"), state(1, "TASK", "MOTION"), state(2, "MOTION", "WAITING"),
          state(3, "WAITING", "TASK"), state(3, "TASK", "WAITING")]
    assert check_states(ok) == []
    skip = [state(1, "WAITING", "TASK"), state(1, "TASK", "ACTION")]  # MOTION skipped
    assert check_states(skip) == ["t=1 r: transition TASK -> ACTION does not exist (R6)"]
    jump = [state(1, "WAITING", "TASK"), state(2, "MOTION", "ACTION")]  # from a state it was not in
    assert check_states(jump) == ["t=2 r: transition from MOTION, but the state was TASK (R6)"]


def mo(pos, length=3):
    return motion("A", f"A_m{pos}", pos, length, pos, 0)


def ac(pos, length=3):
    return action("A", f"A_a{pos}", pos, length)


@pytest.mark.parametrize(("held", "new", "problem"), [
    ({}, mo(1), None),
    ({}, ac(1), None),  # m = 0: actions may start at 1
    ({1: mo(1)}, mo(2, length=4), "length_mismatch"),  # the first assignment fixed length 3
    ({1: mo(1)}, ac(1), "position_taken"),
    ({2: ac(2)}, mo(3), "kind_order"),  # a motion after an action
    ({2: mo(2)}, ac(1), "kind_order"),  # an action just before a motion
    ({3: mo(3)}, ac(1), "kind_order"),  # an action well before a motion
    ({1: mo(1)}, ac(3), None),  # position 2 still open: it may be a motion or an action
    ({1: mo(1), 3: ac(3)}, mo(2), None),  # motions 1..2, action 3
    ({1: mo(1), 3: ac(3)}, ac(2), None),  # motion 1, actions 2..3
    ({3: mo(3)}, mo(1), None),  # motions fill from the front, in any arrival order
])
def test_r2_reference_model_check_by_hand(held, new, problem):
    assert position_problem(held, 3, new) == problem
