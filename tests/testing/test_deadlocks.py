"""The loop property "no deadlock" (docs/contract.md §12, issue 32 item 4; vcran.testing.deadlocks): on event lists written
by hand (the ``deadlock`` events safety fields will raise, robots stuck idle on an open job), and on the
Dispatcher in the corridor with and without its passing bay."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import pytest

import vcran
from tests.sim.test_dispatcher_routing import HEAD_ON, corridor
from vcran.testing.deadlocks import STUCK_BOUND, applies, check_no_deadlock
from vcran.testing.loop import loop_problems


@dataclass
class Run:
    """What the check reads of a vcran.Result: the events, the summary's sim_time, the scenario."""

    events: list[dict[str, Any]]
    end: float = 1000.0
    scenario: Any = None
    summary: dict[str, Any] = field(init=False)

    def __post_init__(self) -> None:
        self.summary = {"sim_time": self.end}


def e(t: float, event: str, robot: str = "", **fields: Any) -> dict[str, Any]:
    return {"t": t, "robot": robot, "event": event, **fields}


def state(t: float, robot: str, old: str, new: str) -> dict[str, Any]:
    return e(t, "state", robot, **{"from": old, "to": new})


def test_s12_every_deadlock_event_is_a_violation():
    # the event safety fields raise (docs/contract.md §12, vcran.core.incidents.Deadlock): robots blocked on one another in a
    # cycle (A waits for B, B for C, C for A), or one past a bound (C, by A and B in its field)
    run = Run([e(11.0, "deadlock", "A", kind="cycle", other="B, C", duration=2.0),
               e(300.0, "deadlock", "C", kind="bound", other="A, B", duration=120.0)])
    assert check_no_deadlock(run) == ["t=11: deadlock (cycle) of A, B, C",
                                      "t=300: deadlock (bound) of C, blocked 120 s by A, B"]
    assert applies(run)


def test_s12_a_robot_stuck_idle_on_an_open_job_past_the_bound():
    # j1's pick task goes to r1 at 0, which runs it (TASK at 0.05, back to WAITING at 10); the job stays open
    # and r1 idle until the end at 1000: 990 s idle on it. With the job done at 500, 490 s.
    events = [e(0.0, "job_arrived", job="j1"), e(0.0, "job_assigned", "r1", job="j1", task="j1_pick1"),
              state(0.05, "r1", "WAITING", "TASK"), state(10.0, "r1", "ACTION", "WAITING")]
    assert check_no_deadlock(Run(events), bound=600.0) == [
        "r1 stood idle from t=10 to t=1000 (990 s > 600 s) on job j1, which was still open and had no cancelled "
        "task to re-plan"]
    done = events + [e(500.0, "job_completed", "r1", job="j1")]
    assert check_no_deadlock(Run(done), bound=600.0) == []
    assert len(check_no_deadlock(Run(done), bound=480.0)) == 1
    assert STUCK_BOUND == 600.0 and not applies(Run(events))  # no roadmap, no deadlock event


def test_s12_a_job_waiting_for_a_new_task_is_the_idle_property_s_not_this_one():
    # r1's task for j1 was cancelled at 10: the job waits for the manager to re-plan it (check_no_idle_while
    # _waiting's business) until a new task goes out, at 900; idle 10..900 on it is not "stuck"
    events = [e(0.0, "job_assigned", "r1", job="j1", task="j1_pick1"), state(0.05, "r1", "WAITING", "TASK"),
              e(10.0, "task_cancelled", "r1", task="j1_pick1", reason="action_failed"),
              state(10.0, "r1", "TASK", "WAITING"), e(900.0, "job_assigned", "r1", job="j1", task="j1_pick2")]
    assert check_no_deadlock(Run(events), bound=100.0) == []
    assert check_no_deadlock(Run(events), bound=99.0) == [  # from the new task on, it is r1's again
        "r1 stood idle from t=900 to t=1000 (100 s > 99 s) on job j1, which was still open and had no cancelled "
        "task to re-plan"]


def test_s12_time_the_manager_cannot_use_the_robot_is_not_stuck():
    # r1 idle on open j1 from 10 to 1000, but its link is down 100..600 and its battery empty 600..950:
    # what is left is 10..100 and 950..1000, both under 100 s
    events = [e(0.0, "job_assigned", "r1", job="j1", task="j1_pick1"), state(0.05, "r1", "WAITING", "TASK"),
              state(10.0, "r1", "ACTION", "WAITING"), e(100.0, "fault", "r1", kind="link_down"),
              e(600.0, "fault_end", "r1", kind="link_down"), e(600.0, "battery_empty", "r1"),
              e(950.0, "battery_swapped", "r1")]
    assert check_no_deadlock(Run(events), bound=100.0) == []
    assert len(check_no_deadlock(Run(events), bound=80.0)) == 1  # 10..100 is 90 s


def test_s12_a_negative_bound_is_refused():
    with pytest.raises(ValueError, match="bound must be a number of seconds >= 0, got -1"):
        check_no_deadlock(Run([]), bound=-1.0)


def test_s12_the_dispatcher_in_the_corridor_without_a_bay_is_stuck_and_says_so():
    """Without the passing bay the reservations never let the two robots swap ends (tests/sim/
    test_dispatcher_routing.py): both stand idle from the end of their loads (2.05) to the end of the run
    (400), each on its open job. With the bay there is nothing to report, and the property is one of the
    loop properties there (the scenario has a roadmap)."""
    stuck = vcran.simulate(corridor(HEAD_ON, bay=False, duration=400.0), manager="vcran.managers:Dispatcher")
    assert check_no_deadlock(stuck, bound=300.0) == [
        f"{robot} stood idle from t=2.05 to t=400 (397.95 s > 300 s) on job {job}, which was still open and had no "
        "cancelled task to re-plan" for robot, job in (("A", "j1"), ("B", "j2"))]
    assert applies(stuck) and any("stood idle" in p for p in loop_problems(stuck, stuck=300.0))
    free = vcran.simulate(corridor(HEAD_ON), manager="vcran.managers:Dispatcher")
    assert check_no_deadlock(free, bound=30.0) == [] and loop_problems(free) == []
    # A's wait in the bay, from 19.10 to its last stretch's landing at 45.10, is the longest: 26 s
    assert [p.split(" (")[0] for p in check_no_deadlock(free, bound=20.0)] == ["A stood idle from t=19.1 to t=45.1"]
