"""A hypothesis state machine that drives RanLogic and the reference model side by side (docs/contract.md §3).

Every rule applies one input to the real :class:`~vcran.core.opil.ranlogic.RanLogic` and to the
:class:`~vcran.testing.model.ReferenceRan` and compares what each says must happen. The machine also
plays the driver, as the SimPy model does: it keeps the R7 timers that StartTimer/ClearTimer effects ask
for and fires them in order when time advances, drives the dispatched path leg by leg (dropping the rest
after a StopAfterLeg, R8), and runs one dispatched action at a time. Invariants after every step check
the rules directly on RanLogic's effects and status, independently of the model (module
:mod:`vcran.testing` docs and docs/fuzzing.md).

Run it in a test module::

    from vcran.testing.stateful import RanLogicMachine
    TestRanLogic = RanLogicMachine.TestCase

A failure prints the shrunk steps as Python (``state = RanLogicMachine()``, ``state.send(...)``,
...): paste them into a test function to keep the example as a regression test.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from vcran.testing._extra import require_hypothesis

require_hypothesis(__name__)

from hypothesis import event
from hypothesis import strategies as st
from hypothesis.control import currently_in_test_context
from hypothesis.stateful import Bundle, RuleBasedStateMachine, initialize, invariant, precondition, rule

from vcran.core.opil import build
from vcran.core.opil.effects import (
    Abandon,
    ActionFinished,
    ClearTimer,
    DispatchAction,
    DispatchPath,
    Effect,
    MotionFinished,
    Rejected,
    SkipMotion,
    StartTimer,
    State,
    StateChanged,
    StopAfterLeg,
    TaskCancelled,
    TaskCompleted,
    TaskQueued,
)
from vcran.core.opil.ids import NIL, Id
from vcran.core.opil.messages import ActionAssignment, Assignment, MotionAssignment
from vcran.core.opil.motion_area import motion_area_problem
from vcran.core.opil.ranlogic import RanLogic
from vcran.testing.model import TOLERANCE, TRANSITIONS, ReferenceRan, observe
from vcran.testing.plans import AREA, TaskPlan, task_plans, variants

TIMEOUT = 10.0
#: Time steps: 10.0 lands exactly on a deadline set 10 s earlier (R7's boundary), 1 µs on the instant its
#: timer fires (R14's tolerance), half of it inside the tolerance of a leg's or action's end.
STEPS = (0.0, 1.0, 2.5, 5.0, 10.0, TOLERANCE, TOLERANCE / 2)


def outside_box(m: MotionAssignment) -> str | None:
    """The model's own R12 check: the test areas are axis-aligned boxes."""
    xs, ys = [p[0] for p in m.motion_area.xy()], [p[1] for p in m.motion_area.xy()]
    if xs and not (min(xs) <= m.point.x <= max(xs) and min(ys) <= m.point.y <= max(ys)):
        return "outside"
    return None


@dataclass
class Driver:
    """What a driver holds: R7 timers, the path being driven, the running action, lifetimes seen."""

    timers: dict[Id, float] = field(default_factory=dict)
    legs: list[MotionAssignment] = field(default_factory=list)
    stop: bool = False
    action: ActionAssignment | None = None
    state: State = State.WAITING
    alive: set[Id] = field(default_factory=set)
    paths: dict[Id, int] = field(default_factory=dict)  # task -> motions in its dispatched path
    legs_done: dict[Id, int] = field(default_factory=dict)
    actions_done: dict[Id, int] = field(default_factory=dict)
    last_action: dict[Id, int] = field(default_factory=dict)  # task -> position of its latest action
    began: float = float("-inf")  # when the running leg or action began


class RanLogicMachine(RuleBasedStateMachine):
    """RanLogic against the reference model; see the module docstring."""

    plans = Bundle("plans")
    sent = Bundle("sent")

    def __init__(self) -> None:
        super().__init__()
        self.now = 0.0
        self.driver = Driver()
        self.limit = 10_000
        self.logic = RanLogic("r", task_timeout=TIMEOUT, area_check=motion_area_problem)
        self.model = ReferenceRan(TIMEOUT, area=outside_box)

    @initialize(limit=st.sampled_from([2, 10_000]))
    def configure(self, limit: int) -> None:
        """A small history limit in some runs, so that R9's bound and forgetting are exercised."""
        self.limit = limit
        self.logic = RanLogic("r", task_timeout=TIMEOUT, history_limit=limit, area_check=motion_area_problem)
        self.model = ReferenceRan(TIMEOUT, history_limit=limit, area=outside_box)

    @initialize(target=plans, plan=task_plans())
    def first_plan(self, plan: TaskPlan) -> TaskPlan:
        """One plan from the start, so that every rule is enabled at once."""
        return plan

    # --- inputs -----------------------------------------------------------------------------------------

    @rule(target=plans, plan=task_plans())
    def plan(self, plan: TaskPlan) -> TaskPlan:
        return plan

    @rule(target=sent, plan=plans, pos=st.integers(1, 4), variant=variants())
    def send(self, plan: TaskPlan, pos: int, variant: str) -> Assignment:
        a = plan.assignment(min(pos, plan.length), variant, stamp=self.now)
        self._assign(a)
        return a

    @rule(plan=plans, rotate=st.integers(0, 3), backwards=st.booleans())
    def send_task(self, plan: TaskPlan, rotate: int, backwards: bool) -> None:
        """Every planned assignment of a task at this instant, in an order of its own (R3 must wait)."""
        for pos in plan.order(rotate, backwards):
            self._assign(plan.assignment(pos, stamp=self.now))

    @rule(first=plans, second=plans, split=st.integers(1, 3))
    def interleave(self, first: TaskPlan, second: TaskPlan, split: int) -> None:
        """Two tasks' messages interleaved: ``first`` up to ``split``, all of ``second``, the rest of
        ``first``; the one seen first must run first, whichever is assembled first (R1)."""
        head = min(split, first.length)
        for plan, positions in ((first, range(1, head + 1)), (second, range(1, second.length + 1)),
                                (first, range(head + 1, first.length + 1))):
            for pos in positions:
                self._assign(plan.assignment(pos, stamp=self.now))

    @rule(a=sent)
    def resend(self, a: Assignment) -> None:
        """A polling re-read of something sent before (R10), whatever happened since."""
        self._assign(a)

    @rule(plan=plans, variant=st.sampled_from(["whole"] * 3 + ["motion", "action", "both", "unknown"]),
          pos=st.integers(1, 4))
    def cancel(self, plan: TaskPlan, variant: str, pos: int = 1) -> None:
        """R8: a whole-task cancel, or one for a task never seen; R13: one naming the assignment planned
        at ``pos`` (a motion, an action, or both kinds: the ids may name nothing the task holds)."""
        task = "X" if variant == "unknown" else plan.task
        c = build.cancel(task, motion=f"{task}_m{pos}" if variant in ("motion", "both") else None,
                         action=f"{task}_a{pos + (variant == 'both')}" if variant in ("action", "both") else None)
        self._input(self.logic.on_cancel(self.now, c), self.model.cancel(self.now, c))

    @precondition(lambda self: self.model.current() is not None)
    @rule(which=st.sampled_from(["running", "ahead", "done", "pending"]), pick=st.integers(0, 3))
    def cancel_in_current(self, which: str, pick: int) -> None:
        """R13 where its cases meet: a partial cancel naming one assignment the current task holds — the
        running leg or action, a point of the path still ahead, one reached or performed, or one not
        dispatched yet (any it holds when there is none of that kind). Picked from the model, so the
        choice never depends on the code under test."""
        task = self.model.current()
        assert task is not None
        path, done = task.path or [], task.legs_done
        actions = task.actions[:-1] if task.action_running else task.actions
        groups: dict[str, list[Assignment]] = {
            "running": list[Assignment](path[done:done + 1] if task.driving
                                        else task.actions[-1:] if task.action_running else []),
            "ahead": list[Assignment](path[done + 1:] if task.driving else []),
            "done": [*path[:done], *actions],
            "pending": [a for a in task.slots().values() if not task.dispatched(a)],
        }
        choice = groups[which] or [a for _, a in sorted(task.slots().items())]
        a = choice[pick % len(choice)]
        c = (build.cancel(task.id, motion=a.motion_id) if isinstance(a, MotionAssignment)
             else build.cancel(task.id, action=a.action_id))
        self._input(self.logic.on_cancel(self.now, c), self.model.cancel(self.now, c))

    @rule(attribute=st.sampled_from(["motion_assignment", "action_assignment", "cancel_order"]))
    def malformed(self, attribute: str) -> None:
        self._input(self.logic.on_malformed(self.now, attribute, "value: not an object"), self.model.malformed(self.now))

    @rule(dt=st.sampled_from(STEPS))
    def advance(self, dt: float) -> None:
        """Time passes: fire every due R7 timer at its own instant, in order (as the SimPy model does).

        Timers due exactly at the current instant fire now, those due later up to (not including) the
        new time fire on the way; one due exactly at the new time waits, so inputs of that instant come
        first (the driver's tie order: a task assembled exactly at its deadline is on time).
        """
        target = self.now + dt
        while True:
            due = sorted(((at, i, task) for i, (task, at) in enumerate(self.driver.timers.items())
                          if at < target or at <= self.now), key=lambda x: (x[0], x[1]))
            if not due:
                break
            at, _, task = due[0]
            del self.driver.timers[task]
            self.now = at
            self._step(self.logic.on_timer(at, task), self.model.timer(at, task))
        self.now = target

    @precondition(lambda self: bool(self.driver.legs))
    @rule()
    def finish_leg(self) -> None:
        leg = self.driver.legs.pop(0)
        self.driver.began = self.now  # the next leg, if any
        if self.driver.stop:  # R8: the AGV stops at the end of the running leg
            self.driver.legs.clear()
            self.driver.stop = False
        self._step(self.logic.on_motion_finished(self.now, leg.motion_id),
                   self.model.leg_finished(self.now, leg.motion_id))

    @precondition(lambda self: self.driver.action is not None)
    @rule(ok=st.booleans())
    def finish_action(self, ok: bool) -> None:
        assert self.driver.action is not None
        action, self.driver.action = self.driver.action.action_id, None
        code = "" if ok else "agv_refused"
        self._step(self.logic.on_action_finished(self.now, action, ok, code, "refused"),
                   self.model.action_finished(self.now, action, ok, code))

    # --- invariants -------------------------------------------------------------------------------------

    @invariant()
    def rules_hold(self) -> None:
        """After every step (one invariant, so that printed examples stay short)."""
        self.same_state_and_queue()
        self.current_is_first_seen_first()
        self.timers_match_deadlines()
        self.history_bounded()

    def same_state_and_queue(self) -> None:
        assert self.logic.state is self.model.state, (self.logic.state, self.model.state)
        assert list(self.logic.queue) == [t.id for t in self.model.queue()]
        current = self.model.current()
        assert self.logic.current_task == (current.id if current else NIL)
        assert self.logic.current_motion == self.model.current_motion
        assert self.logic.current_action == self.model.current_action
        assert self.logic.last_finished_motion == self.model.last_motion
        assert self.logic.last_finished_action == self.model.last_action
        assert self.logic.error_count == self.model.errors

    def current_is_first_seen_first(self) -> None:
        """R1, on RanLogic alone: the head of the queue has the smallest (first_seen, arrival)."""
        tasks = list(self.logic.queue.values())
        if tasks:
            assert min(tasks, key=lambda t: (t.first_seen, t.arrival)) is tasks[0]

    def timers_match_deadlines(self) -> None:
        """R7: a timer is pending exactly for each queued, unassembled task whose deadline has not come."""
        expected = self.model.deadlines()
        assert self.driver.timers.keys() == expected.keys()
        assert all(abs(at - expected[task]) < 1e-9 for task, at in self.driver.timers.items())
        for task in self.logic.queue.values():  # on RanLogic alone: overdue tasks are on their way out
            if not task.assembled:
                assert task.deadline + TOLERANCE >= self.now - 1e-9 or task.ending is not None, \
                    f"R7: {task.id!r} not assembled, past its deadline and still queued"

    def history_bounded(self) -> None:
        """R9: the history keeps the latest ``history_limit`` ended ids."""
        assert len(self.logic.history) <= self.limit
        assert list(self.logic.history) == [e.id for e in self.model.history()]

    # --- helpers ----------------------------------------------------------------------------------------

    def _assign(self, a: Assignment) -> None:
        if isinstance(a, MotionAssignment):
            self._input(self.logic.on_motion(self.now, a), self.model.motion(self.now, a))
        else:
            self._input(self.logic.on_action(self.now, a), self.model.action(self.now, a))

    def _input(self, effects: list[Effect], expected: list[tuple]) -> None:
        """An inbound message: besides matching the model, a rejection must change nothing (R2, R12)."""
        if any(isinstance(e, Rejected) and e.code != "cancel_unknown_assignment" for e in effects):
            assert len(effects) == 1, f"a rejection came with other effects: {effects}"
            assert self.logic.version == self._version_before, "a rejected input changed the status"
        self._step(effects, expected)

    def _step(self, effects: list[Effect], expected: list[tuple]) -> None:
        got = observe(effects)
        assert got == expected, f"RanLogic said {got}, the reference model {expected}"
        for obs in got if currently_in_test_context() else ():  # --hypothesis-show-statistics
            event(f"{obs[0]} {obs[1] if obs[0] in ('rejected', 'failed') else ''}".strip())
            if obs[0] == "cancelled":
                event(f"cancelled {obs[2].value}")
        self._check(effects)
        self._version_before = self.logic.version

    _version_before = 0

    def _check(self, effects: list[Effect]) -> None:
        """Rules checked on the effects themselves, and the driver's bookkeeping (module docstring)."""
        d = self.driver
        for e in effects:
            if isinstance(e, StateChanged):
                assert (e.from_, e.to) in TRANSITIONS, f"R6: {e.from_} -> {e.to} does not exist"
                assert e.from_ is d.state, f"R6: state jumped from {d.state} to {e.from_}"
                d.state = e.to
            elif isinstance(e, TaskQueued):
                assert e.task not in d.alive, f"R1: {e.task!r} queued twice"
                d.alive.add(e.task)
                for progress in (d.paths, d.legs_done, d.actions_done, d.last_action):  # a forgotten id starts anew (R9)
                    progress.pop(e.task, None)
            elif isinstance(e, (TaskCompleted, TaskCancelled)):
                assert e.task in d.alive, f"{e.task!r} ended twice, or without being queued"
                d.alive.discard(e.task)
                if isinstance(e, TaskCompleted):
                    assert d.legs_done.get(e.task, 0) == d.paths.get(e.task, 0)
            elif isinstance(e, DispatchPath):
                assert e.task in d.alive, f"R8: path of ended task {e.task!r} dispatched"
                assert not d.legs and d.action is None, "R6: a path dispatched while the AGV is busy"
                assert e.task not in d.paths, f"R6: a second path for {e.task!r}"
                numbers = [m.sequence.sequence_number for m in e.motions]
                assert numbers == sorted(set(numbers)), "R3: the path goes in sequence order"
                d.legs, d.paths[e.task], d.legs_done[e.task] = list(e.motions), len(e.motions), 0
                d.began = self.now
            elif isinstance(e, StopAfterLeg):
                assert d.legs, "R8: stop requested with no leg running"
                d.stop = True
            elif isinstance(e, SkipMotion):
                ahead = [m.motion_id for m in d.legs[1:]]
                assert e.motion in ahead, "R13: only an unreached point, not the running leg, is skipped"
                d.legs = [m for m in d.legs if m.motion_id != e.motion]
                d.paths[e.task] -= 1
            elif isinstance(e, Abandon):
                assert d.legs or d.action is not None, "R14: nothing was running to abandon"
                assert abs(d.began - self.now) <= 2 * TOLERANCE, "R14: only what began at this instant is abandoned"
                d.legs, d.stop, d.action = [], False, None
            elif isinstance(e, MotionFinished):
                d.legs_done[e.task] += 1
            elif isinstance(e, DispatchAction):
                assert e.task in d.alive, f"R8: action of ended task {e.task!r} dispatched"
                assert d.action is None and not d.legs, "R6: an action dispatched while another runs"
                assert d.legs_done.get(e.task, 0) == d.paths.get(e.task, 0), "R6: action before every leg finished"
                task = self.model.find(e.task)
                assert task is not None and task.assembled, "R4: action dispatched before every action arrived"
                pos = e.action.sequence.sequence_number
                assert pos > d.last_action.get(e.task, 0), "R6: actions out of sequence order"
                d.last_action[e.task], d.action, d.began = pos, e.action, self.now
            elif isinstance(e, ActionFinished):
                d.actions_done[e.task] = d.actions_done.get(e.task, 0) + 1
            elif isinstance(e, StartTimer):
                assert e.task not in d.timers and abs(e.at - (self.now + TIMEOUT + TOLERANCE)) < 1e-9
                d.timers[e.task] = e.at
            elif isinstance(e, ClearTimer):
                d.timers.pop(e.task, None)
        assert d.state is self.logic.state, "R6: a state change was not reported"


__all__ = ["RanLogicMachine", "AREA"]
