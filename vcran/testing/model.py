"""A reference model of one robot's RanLogic (docs/contract.md §3, R1–R14), small enough to be obviously right.

:class:`vcran.core.opil.ranlogic.RanLogic` is written for speed and for the SimPy model: it keeps incremental
bookkeeping (a position map, ``m``, the next action, a running flag). This model is written for the
reader instead: it stores every accepted assignment of a task as it arrived and recomputes everything
else from that list each time it is asked (the current content of an assignment id is its latest
accepted version; the positions follow from the contents; R3, R4 and R5 are evaluated from the
positions; the queue is sorted by ``(first_seen, arrival)``; the state is derived from the current
task). The only facts it keeps besides the inputs are the ones a driver reports or a rule decides:
which path and actions were dispatched, how many legs and actions finished, and which tasks ended.

Each input method returns the *observations* the rules require, in causal order, as plain tuples;
:func:`observe` turns RanLogic's effects into the same tuples, so a test can compare the two with
``==`` and print a readable difference::

    ran, model = RanLogic("r", task_timeout=10), ReferenceRan(task_timeout=10)
    m = build.motion("A", "A_m1", 1, 1, 2.0, 0.0)
    assert observe(ran.on_motion(0.0, m)) == model.motion(0.0, m)

Observations (``Obs``):

* ``("queued", task)``, ``("completed", task)``, ``("cancelled", task, Reason)``
* ``("path", task, motions)``, ``("stop", task)``, ``("action", task, action)``
* ``("motion_finished", task, motion_id)``, ``("action_finished", task, action_id, ok)``
* ``("rejected", code, task_id)``, ``("failed", code, task_id)``
* ``("assignment_cancelled", task, kind, id)``, ``("skip", task, motion_id)`` (R13), ``("abandon", task)`` (R14)

Timers (StartTimer/ClearTimer) and state changes are not observations: the model exposes them as
views (:meth:`ReferenceRan.deadlines`, :attr:`ReferenceRan.state`) that a test compares with what the
driver holds and with RanLogic's state.

One concept in one module longer than 450 lines (issue 30): the reference model of RanLogic. It mirrors
every rule RanLogic implements, and its worth is that the whole of it can be checked against the rules
(docs/rules.md) in one file, each rule a few lines that recompute from the inputs.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

from vcran.core.opil.effects import (
    Abandon,
    ActionFinished,
    AssignmentCancelled,
    DispatchAction,
    DispatchPath,
    Effect,
    Failed,
    MotionFinished,
    Reason,
    Rejected,
    SkipMotion,
    State,
    StopAfterLeg,
    TaskCancelled,
    TaskCompleted,
    TaskQueued,
)
from vcran.core.opil.ids import NIL, NOT_SUPPORTED, Id
from vcran.core.opil.messages import ActionAssignment, Assignment, CancelTask, MotionAssignment

Obs = tuple[Any, ...]

#: R14: instants closer than this are the same instant; the R7 timer fires this long after the deadline.
TOLERANCE = 1e-6

#: R6 as docs/contract.md words it, for the checks of this package (not imported from RanLogic, so that a wrong
#: table there shows): the cycle WAITING -> TASK -> MOTION -> ACTION -> WAITING, and a cancel from any
#: state but WAITING back to WAITING.
CYCLE = (State.WAITING, State.TASK, State.MOTION, State.ACTION)
TRANSITIONS = frozenset(zip(CYCLE, CYCLE[1:] + CYCLE[:1])) | frozenset((s, State.WAITING) for s in CYCLE[1:])


class DriverError(AssertionError):
    """The test drove the model in a way no real driver may (a completion nobody dispatched)."""


def observe(effects: list[Effect]) -> list[Obs]:
    """RanLogic's effects as the model's observations (timers and state changes left out)."""
    out: list[Obs] = []
    for e in effects:
        if isinstance(e, TaskQueued):
            out.append(("queued", e.task))
        elif isinstance(e, TaskCompleted):
            out.append(("completed", e.task))
        elif isinstance(e, TaskCancelled):
            out.append(("cancelled", e.task, e.reason))
        elif isinstance(e, DispatchPath):
            out.append(("path", e.task, e.motions))
        elif isinstance(e, StopAfterLeg):
            out.append(("stop", e.task))
        elif isinstance(e, DispatchAction):
            out.append(("action", e.task, e.action))
        elif isinstance(e, MotionFinished):
            out.append(("motion_finished", e.task, e.motion))
        elif isinstance(e, ActionFinished):
            out.append(("action_finished", e.task, e.action, e.ok))
        elif isinstance(e, Rejected):
            out.append(("rejected", e.code, e.task))
        elif isinstance(e, Failed):
            out.append(("failed", e.code, e.task))
        elif isinstance(e, AssignmentCancelled):
            out.append(("assignment_cancelled", e.task, e.kind, e.assignment))
        elif isinstance(e, SkipMotion):
            out.append(("skip", e.task, e.motion))
        elif isinstance(e, Abandon):
            out.append(("abandon", e.task))
    return out


# --- rules as small pure functions ----------------------------------------------------------------------


def key(a: Assignment) -> tuple[str, Id]:
    """An assignment's identity: its kind and its id (a motion and an action may share a uuid)."""
    if isinstance(a, MotionAssignment):
        return ("motion", a.motion_id)
    return ("action", a.action_id)


def identical(a: Assignment, b: Assignment) -> bool:
    """R10: same kind, id and content; the ROS header (seq, stamp) does not count."""
    if isinstance(a, MotionAssignment) and isinstance(b, MotionAssignment):
        return replace(a, header=b.header) == b
    return type(a) is type(b) and a == b


def unused(ident: Id) -> bool:
    """R8: nil, or "not supported" as OPIL's planner marks the ids it does not use."""
    return ident == NIL or ident.description == NOT_SUPPORTED


def motions_complete(slots: dict[int, Assignment], length: int) -> int | None:
    """R3: the ``m`` for which positions 1..m are motions and m == length or m+1 is an action."""
    for m in range(length + 1):
        motions = all(isinstance(slots.get(p), MotionAssignment) for p in range(1, m + 1))
        if motions and (m == length or isinstance(slots.get(m + 1), ActionAssignment)):
            return m
    return None


def position_problem(slots: dict[int, Assignment], length: int, a: Assignment) -> str | None:
    """R2 for ``a`` against the other assignments of its task (``slots`` without ``a``'s own id).

    Stated as R2 reads, on the positions the task would hold with ``a``: its length is the task's, no
    position is held twice, and the motions fill a prefix (every motion's position below every action's).
    """
    pos = a.sequence.sequence_number
    if a.sequence.length != length:
        return "length_mismatch"
    if pos in slots:
        return "position_taken"
    held = {**slots, pos: a}
    motions = [p for p, b in held.items() if isinstance(b, MotionAssignment)]
    actions = [p for p, b in held.items() if isinstance(b, ActionAssignment)]
    if motions and actions and max(motions) > min(actions):
        return "kind_order"
    return None


# --- the model --------------------------------------------------------------------------------------------


@dataclass(eq=False)
class ModelTask:
    id: Id
    first_seen: float
    arrival: int
    length: int
    deadline: float
    #: Every accepted assignment, in the order it was accepted (replacements included).
    accepted: list[Assignment] = field(default_factory=list)
    #: The dispatched path (None before R3 holds); R13 removes unreached points from it.
    path: list[MotionAssignment] | None = None
    legs_done: int = 0
    actions: list[ActionAssignment] = field(default_factory=list)  # dispatched, in order
    action_running: bool = False
    ending: Reason | None = None
    cancel: CancelTask | None = None
    timer_fired: bool = False
    #: Assignments cancelled one by one (R13), by key.
    cancelled: set[tuple[str, Id]] = field(default_factory=set)
    #: When the running leg or action began (R14).
    since: float = float("-inf")

    def contents(self) -> dict[tuple[str, Id], Assignment]:
        """The latest accepted version of every assignment id."""
        return {key(a): a for a in self.accepted}

    def slots(self, without: tuple[str, Id] | None = None) -> dict[int, Assignment]:
        return {a.sequence.sequence_number: a for k, a in self.contents().items() if k != without}

    @property
    def assembled(self) -> bool:
        """R5."""
        return len(self.slots()) == self.length

    @property
    def driving(self) -> bool:
        return self.path is not None and self.legs_done < len(self.path)

    def dispatched(self, a: Assignment) -> bool:
        if isinstance(a, MotionAssignment):
            return self.path is not None
        return any(d.action_id == a.action_id for d in self.actions)

    def all_cancelled(self) -> bool:
        """R13: every position holds an assignment cancelled on its own."""
        return len(self.slots()) == self.length and all(key(a) in self.cancelled for a in self.slots().values())

    def why_not_cancellable(self, a: Assignment) -> str | None:
        """R13: a leg driven or running, an action performed or running, cannot be cancelled alone."""
        if isinstance(a, MotionAssignment):
            if self.path is None:
                return None
            ids = [m.motion_id for m in self.path]
            if a.motion_id in ids[: self.legs_done]:
                return "assignment_finished"
            return "assignment_running" if self.driving and ids[self.legs_done] == a.motion_id else None
        if not self.dispatched(a):
            return None
        running = self.action_running and self.actions[-1].action_id == a.action_id
        return "assignment_running" if running else "assignment_finished"


@dataclass(eq=False)
class Ending:
    """A task in the history (R9), or the tombstone of a cancel for an unknown task (R8)."""

    id: Id
    task: ModelTask | None
    reason: Reason | None
    cancel: CancelTask | None


class ReferenceRan:
    """One robot's rules, restated. Same inputs as RanLogic; returns observations (module docstring).

    ``area`` decides R12's motion-area check like RanLogic's ``area_check`` (a reason, or None).
    """

    def __init__(self, task_timeout: float = 30.0, history_limit: int = 10_000, area: Any = None) -> None:
        self.task_timeout = task_timeout
        self.history_limit = history_limit
        self.area = area
        self.tasks: list[ModelTask] = []  # queued, in arrival order
        self.endings: list[Ending] = []  # every ending ever, oldest first
        self.arrivals = 0
        self.errors = 0
        #: R13: cancels of assignments not received yet, (task, key, the cancel), oldest first.
        self.doomed: list[tuple[Id, tuple[str, Id], CancelTask]] = []
        self.last_motion: Id = NIL
        self.last_action: Id = NIL

    # --- views ------------------------------------------------------------------------------------------

    def queue(self) -> list[ModelTask]:
        """R1: queued tasks by first_seen, ties by arrival order."""
        return sorted(self.tasks, key=lambda t: (t.first_seen, t.arrival))

    def current(self) -> ModelTask | None:
        q = self.queue()
        return q[0] if q else None

    @property
    def state(self) -> State:
        """R6, derived from the current task."""
        t = self.current()
        if t is None:
            return State.WAITING
        if t.path is None:
            return State.TASK
        if t.driving or not t.assembled:
            return State.MOTION
        return State.ACTION

    def history(self) -> list[Ending]:
        """R9: the latest ``history_limit`` endings (ids in the history are distinct)."""
        return self.endings[-self.history_limit:]

    def remembered(self, task: Id) -> Ending | None:
        return next((e for e in reversed(self.history()) if e.id == task), None)

    def find(self, task: Id) -> ModelTask | None:
        return next((t for t in self.tasks if t.id == task), None)

    def deadlines(self) -> dict[Id, float]:
        """R7 timers that must be pending, with the instant each fires (R14: the tolerance after the
        deadline): queued, not assembled, not yet fired."""
        return {t.id: t.deadline + TOLERANCE for t in self.tasks if not t.assembled and not t.timer_fired}

    @property
    def current_motion(self) -> Id:
        t = self.current()
        return t.path[t.legs_done].motion_id if t is not None and t.driving and t.path else NIL

    @property
    def current_action(self) -> Id:
        t = self.current()
        return t.actions[-1].action_id if t is not None and t.action_running else NIL

    # --- inputs -----------------------------------------------------------------------------------------

    def motion(self, now: float, m: MotionAssignment) -> list[Obs]:
        if self.area is not None and self.area(m):
            return self._reject("outside_motion_area", m.task_id)
        return self._assignment(now, m)

    def action(self, now: float, a: ActionAssignment) -> list[Obs]:
        return self._assignment(now, a)

    def malformed(self, now: float) -> list[Obs]:
        return self._reject("malformed", NIL)

    def cancel(self, now: float, c: CancelTask) -> list[Obs]:
        named = [k for k in (("motion", c.motion_id), ("action", c.action_id)) if not unused(k[1])]
        task = self.find(c.task_id)
        out: list[Obs] = []
        if task is not None:
            if task.ending is None and named:
                return self._cancel_some(now, task, c, named)
            if task.ending is None:
                self._end(now, task, Reason.CANCELLED, c, out)
            return out
        ended = self.remembered(c.task_id)
        if ended is None and named:  # R13: remembered, skipped when it arrives
            for k in named:
                self._doom(c, k)
            return self._reject("cancel_unknown_assignment", c.task_id)
        if ended is None:
            self.endings.append(Ending(c.task_id, None, Reason.CANCELLED, c))
            return self._reject("cancel_unknown_task", c.task_id)
        if ended.cancel == c:
            return out  # a re-read of the same cancel (R10)
        ended.cancel = c
        return self._reject("cancel_finished_task", c.task_id)

    def _cancel_some(self, now: float, task: ModelTask, c: CancelTask, named: list[tuple[str, Id]]) -> list[Obs]:
        """R13 on a live task: all named assignments are cancelled, or (one refused) none."""
        contents = task.contents()
        found = [contents[k] for k in named if k in contents and k not in task.cancelled]
        for a in found:
            refusal = task.why_not_cancellable(a)
            if refusal is not None:
                return self._reject(refusal, task.id)
        out: list[Obs] = []
        unknown = [k for k in named if k not in contents]
        for k in unknown:
            self._doom(c, k)
        if unknown:
            out += self._reject("cancel_unknown_assignment", task.id)
        for a in found:
            self._cancel_one(task, a, out)
        if found and task.all_cancelled():
            self._end(now, task, Reason.CANCELLED, c, out)
        elif found:
            self._settle(now, out)
        return out

    def _cancel_one(self, task: ModelTask, a: Assignment, out: list[Obs]) -> None:
        task.cancelled.add(key(a))
        out.append(("assignment_cancelled", task.id, *key(a)))
        ahead = [m.motion_id for m in task.path[task.legs_done + 1:]] if task.path is not None else []
        if isinstance(a, MotionAssignment) and a.motion_id in ahead:  # unreached point of the driven path
            assert task.path is not None
            task.path = [m for m in task.path if m.motion_id != a.motion_id]
            out.append(("skip", task.id, a.motion_id))

    def _doom(self, c: CancelTask, k: tuple[str, Id]) -> None:
        self.doomed = [d for d in self.doomed if d[:2] != (c.task_id, k)] + [(c.task_id, k, c)]
        self.doomed = self.doomed[-self.history_limit:]

    def timer(self, now: float, task_id: Id) -> list[Obs]:
        """The driver fires the R7 timer of ``task_id`` at its deadline."""
        out: list[Obs] = []
        task = self.find(task_id)
        if task is None:
            return out
        if abs(now - (task.deadline + TOLERANCE)) > 1e-9:  # R14: the tolerance after the deadline
            raise DriverError(f"timer of {task_id!r} fired at {now}, deadline {task.deadline}")
        task.timer_fired = True
        if not task.assembled and task.ending is None:
            self._end(now, task, Reason.TIMEOUT, None, out, at=task.deadline)
        return out

    def leg_finished(self, now: float, motion_id: Id) -> list[Obs]:
        task = self.current()
        if task is None or not task.driving or task.path is None or task.path[task.legs_done].motion_id != motion_id:
            raise DriverError(f"leg {motion_id!r} finished, but it is not the running leg")
        task.legs_done += 1
        task.since = now
        self.last_motion = motion_id
        out: list[Obs] = [("motion_finished", task.id, motion_id)]
        if task.ending is not None:
            self._finish(now, task, task.ending, task.cancel, out)
        else:
            self._settle(now, out)
        return out

    def action_finished(self, now: float, action_id: Id, ok: bool, code: str = "action_failed") -> list[Obs]:
        task = self.current()
        if task is None or not task.action_running or task.actions[-1].action_id != action_id:
            raise DriverError(f"action {action_id!r} finished, but it is not the running action")
        task.action_running = False
        self.last_action = action_id
        out: list[Obs] = [("action_finished", task.id, action_id, ok)]
        if not ok:  # R14: a pending cancel's reason comes first
            self.errors += 1
            out.append(("failed", code, task.id))
            self._finish(now, task, task.ending or Reason.ACTION_FAILED, task.cancel, out)
        elif task.ending is not None:
            self._finish(now, task, task.ending, task.cancel, out)
        else:
            self._settle(now, out)
        return out

    # --- rules ------------------------------------------------------------------------------------------

    def _assignment(self, now: float, a: Assignment) -> list[Obs]:
        task = self.find(a.task_id)
        out: list[Obs] = []
        if task is None:
            ended = self.remembered(a.task_id)
            if ended is None:  # R1: a new task
                self.arrivals += 1
                task = ModelTask(a.task_id, now, self.arrivals, a.sequence.length, now + self.task_timeout, [a])
                self.tasks.append(task)
                out.append(("queued", task.id))
                self._accepted(now, task, a, out)
                return out
            old = ended.task.contents().get(key(a)) if ended.task is not None else None
            if old is not None and identical(old, a):
                return out  # R10: a polling re-read of an ended task's assignment
            return self._reject("task_completed" if ended.reason is None else "task_cancelled", a.task_id)
        old = task.contents().get(key(a))
        if old is not None and identical(old, a):
            return out  # R10
        if task.ending is not None:
            return self._reject("task_cancelled", a.task_id)
        if key(a) in task.cancelled:
            return self._reject("assignment_cancelled", a.task_id)
        if old is not None and task.dispatched(old):
            return self._reject("already_dispatched", a.task_id)
        if old is not None and task.path is not None and old.sequence.sequence_number != a.sequence.sequence_number:
            return self._reject("position_changed", a.task_id)
        problem = position_problem(task.slots(without=key(a)), task.length, a)
        if problem is not None:
            return self._reject(problem, a.task_id)
        task.accepted.append(a)
        self._accepted(now, task, a, out)
        return out

    def _accepted(self, now: float, task: ModelTask, a: Assignment, out: list[Obs]) -> None:
        """``a`` joined ``task``: a cancel that named it before it came takes effect now (R13)."""
        doomed = next((d for d in self.doomed if d[:2] == (task.id, key(a))), None)
        if doomed is not None:
            self.doomed.remove(doomed)
            self._cancel_one(task, a, out)
            if task.all_cancelled():
                self._end(now, task, Reason.CANCELLED, doomed[2], out)
                return
        self._settle(now, out)

    def _settle(self, now: float, out: list[Obs]) -> None:
        """Let the current task go as far as what was received allows (R3–R6); then the next one."""
        while True:
            task = self.current()
            if task is None or task.ending is not None:
                return
            slots = task.slots()
            if task.path is None:
                m = motions_complete(slots, task.length)
                if m is None:
                    return
                task.path = [slots[p] for p in range(1, m + 1) if key(slots[p]) not in task.cancelled]  # type: ignore[misc]
                if task.path:
                    task.since = now
                    out.append(("path", task.id, tuple(task.path)))
            if task.driving or not task.assembled or task.action_running:
                return
            m = motions_complete(slots, task.length)
            assert m is not None
            waiting = [a for p, a in sorted(slots.items()) if p > m and key(a) not in task.cancelled
                       and not task.dispatched(a)]
            if waiting:
                action = waiting[0]
                assert isinstance(action, ActionAssignment)
                task.actions.append(action)
                task.action_running = True
                task.since = now
                out.append(("action", task.id, action))
                return
            self.tasks.remove(task)
            self.endings.append(Ending(task.id, task, None, None))
            out.append(("completed", task.id))

    def _end(self, now: float, task: ModelTask, reason: Reason, cancel: CancelTask | None, out: list[Obs],
             at: float | None = None) -> None:
        """R7/R8: end now, or once the running leg or action of the current task finishes; R14: a leg or
        action that began at the request's instant ``at`` (default ``now``; within the tolerance) is
        abandoned instead."""
        if task is self.current() and (task.driving or task.action_running):
            if abs((now if at is None else at) - task.since) > TOLERANCE:
                task.ending, task.cancel = reason, cancel
                if task.driving:
                    out.append(("stop", task.id))
                return
            out.append(("abandon", task.id))
        self._finish(now, task, reason, cancel, out)

    def _finish(self, now: float, task: ModelTask, reason: Reason, cancel: CancelTask | None, out: list[Obs]) -> None:
        self.tasks.remove(task)
        self.endings.append(Ending(task.id, task, reason, cancel))
        out.append(("cancelled", task.id, reason))
        self._settle(now, out)

    def _reject(self, code: str, task: Id) -> list[Obs]:
        self.errors += 1
        return [("rejected", code, task)]
