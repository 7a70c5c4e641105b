"""docs/contract.md §12 deadlock: cycles of robots stopped on one another, robots blocked longer than a bound, and the
deterministic report (robots in wait order from the first in fleet order, the instant)."""

from __future__ import annotations

import pytest

from vcran.core.traffic.deadlock import BOUND, CYCLE, Deadlock, WaitFor


def test_head_on_robots_deadlock_when_both_have_stopped() -> None:
    """The corridor (docs/robots.md): both blocked at 9, both stopped at 11: deadlock at 11, not 9."""
    w = WaitFor()
    assert w.block(0, 1, 9.0) is None and w.block(1, 0, 9.0) is None
    assert w.stopped(0, 11.0) is None  # robot 1 still brakes: it might yet leave robot 0's field
    assert w.stopped(1, 11.0) == Deadlock(11.0, CYCLE, (0, 1), 11.0)
    assert w.stopped(1, 11.0) is None  # reported once


def test_a_cycle_is_told_in_wait_order_from_its_first_robot() -> None:
    w = WaitFor()
    for robot, other in ((3, 7), (7, 5), (5, 3)):
        w.block(robot, other, 1.0)
    assert w.stopped(7, 2.0) is None and w.stopped(3, 2.5) is None
    assert w.stopped(5, 3.0) == Deadlock(3.0, CYCLE, (3, 7, 5), 3.0)


def test_the_shortest_cycle_through_the_closing_robot_is_reported() -> None:
    w = WaitFor()
    for robot, other in ((0, 2), (2, 3), (3, 0), (0, 1), (1, 0)):
        w.block(robot, other, 0.0)
    for robot in (1, 2, 3):
        assert w.stopped(robot, 1.0) is None
    assert w.stopped(0, 2.0) == Deadlock(2.0, CYCLE, (0, 1), 2.0)


def test_a_wait_that_closes_a_cycle_among_robots_at_rest() -> None:
    w = WaitFor()
    w.block(0, 1, 0.0)
    w.stopped(0, 1.0)
    w.block(1, 2, 1.0)
    w.stopped(1, 2.0)
    w.block(2, 5, 2.0)
    w.stopped(2, 3.0)
    assert w.block(2, 0, 4.0) == Deadlock(4.0, CYCLE, (0, 1, 2), 4.0)  # 2 now waits for 0 as well


def test_a_cycle_that_dissolves_while_braking_is_no_deadlock() -> None:
    # robots crossing: each caught the other, robot 1 drove on out of robot 0's field while braking
    w = WaitFor()
    w.block(0, 1, 5.0)
    w.block(1, 0, 5.0)
    w.unblock(0, 1)
    assert w.stopped(1, 6.0) is None and w.stopped(0, 6.0) is None


def test_a_robot_blocked_longer_than_the_bound() -> None:
    w = WaitFor(bound=30.0)
    w.block(2, 4, 5.0)
    w.block(2, 1, 6.0)
    assert w.deadline(2) == 35.0 and w.overdue(2, 34.0) is None
    assert w.overdue(2, 35.0) == Deadlock(35.0, BOUND, (2,), 5.0, (1, 4))
    assert w.overdue(2, 36.0) is None and w.deadline(2) is None  # once per spell
    w.unblock(2, 4)
    w.unblock(2, 1)  # the spell ends; a new one starts at 40
    w.block(2, 4, 40.0)
    assert w.overdue(2, 35.0) is None and w.deadline(2) == 70.0  # the old timer finds nothing


def test_robots_of_a_reported_cycle_are_not_reported_again_past_the_bound() -> None:
    w = WaitFor(bound=10.0)
    w.block(0, 1, 0.0)
    w.block(1, 0, 0.0)
    w.stopped(0, 1.0)
    assert w.stopped(1, 1.0) is not None
    assert w.deadline(0) is None and w.overdue(0, 10.0) is None


def test_the_bound_must_be_positive() -> None:
    with pytest.raises(ValueError, match="bound must be positive"):
        WaitFor(bound=0.0)
