"""RanLogic: one robot's task queue and state machine (docs/contract.md §3, R1–R10 and R12–R14), as a pure object.

Inputs are method calls carrying the simulated time ``now``; outputs are the returned effects
(:mod:`vcran.core.opil.effects`), in order. Nothing here knows SimPy, HTTP or a clock, so the rules can be tested by
calling methods and reading lists, and the same object runs under the scripted, replay and live
transports. The driver's one obligation: deliver :meth:`on_timer` at every :class:`StartTimer` instant
before any input with a later ``now``, and report each dispatched leg and action exactly once.

Tie order inside one instant is the driver's business (docs/determinism.md); RanLogic only requires
``now`` never to decrease. Times are compared with a tolerance of :data:`TOLERANCE` (R14): the R7 timer
asks to fire that long after ``first_seen + task_timeout``, so an input at the deadline as a scenario
writes it is on time whatever binary rounding made of the sum, and a cancel or timeout within that
tolerance of the instant a leg or action began abandons it (:class:`~vcran.core.opil.effects.Abandon`).

One concept, RanLogic's state machine, in one module longer than 450 lines (issue 30): its inputs, cancels
and transitions read and change one robot's state together, and a rule is checked by reading them side by
side. What is not the machine lives beside it: a task under assembly (:mod:`vcran.core.opil.tasks`), what
ended tasks leave (:mod:`vcran.core.opil.history`), the effects it returns (:mod:`vcran.core.opil.effects`).
"""

from __future__ import annotations

from collections import OrderedDict, deque
from collections.abc import Callable
from itertools import islice

from vcran.core.opil.effects import (
    Abandon,
    ActionFinished,
    AssignmentCancelled,
    ClearTimer,
    DispatchAction,
    DispatchPath,
    Effect,
    ErrorReport,
    Failed,
    LocalProtocolError,
    MotionFinished,
    Reason,
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
from vcran.core.opil.history import Ended, History, fingerprint
from vcran.core.opil.ids import NIL, Id
from vcran.core.opil.messages import (
    ActionAssignment,
    Assignment,
    CancelTask,
    MotionAssignment,
    RanStatus,
    TaskEnd,
    Time,
)
from vcran.core.opil.tasks import Task, assignment_id, kind_of, same_content
from vcran.core.slots import unchecked

#: R6 as data: the only transitions that exist. Cancel (any state -> WAITING) is listed explicitly.
TRANSITIONS: frozenset[tuple[State, State]] = frozenset(
    {
        (State.WAITING, State.TASK),
        (State.TASK, State.MOTION),
        (State.MOTION, State.ACTION),
        (State.ACTION, State.WAITING),
        (State.TASK, State.WAITING),
        (State.MOTION, State.WAITING),
    }
)

#: The states as module constants: a member looked up on its Enum class goes through the metaclass (about
#: twice the cost of a global), and the state machine compares states several times per input.
_WAITING, _TASK, _MOTION, _ACTION = State.WAITING, State.TASK, State.MOTION, State.ACTION

#: The one StateChanged event of each of the TRANSITIONS, by member names (an Enum's hash is a Python-level
#: call): a transition is checked and its event found in one lookup. Events are values; building one per
#: transition (four per task, a frozen dataclass's setattr per field) cost more than the lookup.
_STATE_CHANGES = {(a._name_, b._name_): StateChanged(a, b) for a, b in TRANSITIONS}

#: R14: two instants closer than this are the same instant (seconds).
TOLERANCE = 1e-6

#: How many recently completed / cancelled tasks ``ran_status`` shows.
RECENT = 10
#: How many queued task ids ``ran_status`` lists (it also says how many are queued in all).
QUEUE_SHOWN = 50


# Statuses are built from RanLogic's own, already valid state: no re-validation (vcran.core.opil.schema.unchecked).
_ran_status = unchecked(RanStatus)
_task_end = unchecked(TaskEnd)


class RanLogic:
    """The rules of one robot. Construct once per robot; feed it inputs in time order."""

    def __init__(
        self,
        robot: str,
        *,
        task_timeout: float = 30.0,
        history_limit: int = 10_000,
        history_bytes: int = 4 << 20,
        area_check: Callable[[MotionAssignment], str | None] | None = None,
    ) -> None:
        if task_timeout <= 0:
            raise ValueError(f"task_timeout must be positive, got {task_timeout}")
        if history_limit < 1:
            raise ValueError(f"history_limit must be at least 1, got {history_limit}")
        self.robot = robot
        self.task_timeout = task_timeout
        self.history_limit = history_limit
        #: Returns why a motion's target is outside its motion area (R12), or None.
        self._area_check = area_check
        self.state = _WAITING
        #: The tasks in arrival order. A plain dict keeps that order; an OrderedDict hashed each Id again
        #: when it was iterated (``ran_status``), a Python-level call per key (issue 30).
        self.queue: dict[Id, Task] = {}
        #: The queue's first task, the current one (R6), kept as the queue changes (statuses and every input
        #: ask for it, about 26 times per task), and its id: the attribute :attr:`current_task`.
        self._head: Task | None = None
        self.current_task: Id = NIL
        #: Tasks that left the queue so far; with ``_arrivals``, the state and the load the robot gives,
        #: what ``ran_status`` shows is a function of these four (the last one built is kept in ``_status``).
        self._ended = 0
        self._status: tuple[tuple[State, int, int, int], RanStatus] | None = None
        self.history = History(history_limit, history_bytes)
        self.recent_completed: deque[Id] = deque(maxlen=RECENT)
        self.recent_cancelled: deque[TaskEnd] = deque(maxlen=RECENT)
        self.last_finished_motion: Id = NIL
        self.last_finished_action: Id = NIL
        self.error_count = 0
        #: R13 tombstones: (task, kind, id) of assignments cancelled before they arrived, oldest first.
        self.doomed: OrderedDict[tuple[Id, str, Id], CancelTask] = OrderedDict()
        #: Bumped whenever anything ``ran_status`` or ``assignment_state`` shows changes.
        self.version = 0
        #: Why the robot takes no tasks (docs/contract.md §4: "battery_empty"), or "" when it does.
        self.out_of_service = ""
        self._now = float("-inf")
        self._arrivals = 0
        #: The effects of the input being handled, in order (returned by :meth:`_end`).
        self._out: list[Effect] = []

    # --- inputs -----------------------------------------------------------------------------------------

    def on_motion(self, now: float, motion: MotionAssignment) -> list[Effect]:
        self._begin(now)
        problem = self._area_check(motion) if self._area_check else None
        if problem:
            self._reject("outside_motion_area", problem, motion)
        else:
            self._on_assignment(now, motion)
        return self._end()

    def on_action(self, now: float, action: ActionAssignment) -> list[Effect]:
        self._begin(now)
        self._on_assignment(now, action)
        return self._end()

    def on_cancel(self, now: float, cancel: CancelTask) -> list[Effect]:
        self._begin(now)
        self._on_cancel(now, cancel)
        return self._end()

    def on_malformed(self, now: float, attribute: str, detail: str) -> list[Effect]:
        """A payload for this robot that could not be decoded (R12): report it, apply nothing."""
        self._begin(now)
        self._error(Rejected, "malformed", f"{attribute}: {detail}")
        return self._end()

    def on_timer(self, now: float, task_id: Id) -> list[Effect]:
        """The R7 deadline of ``task_id`` is due."""
        self._begin(now)
        task = self.queue.get(task_id)
        if task is not None and not task.assembled and task.ending is None and now >= task.deadline:
            self._end_task(now, task, Reason.TIMEOUT, at=task.deadline)
        return self._end()

    def on_motion_finished(self, now: float, motion_id: Id) -> list[Effect]:
        """The AGV reached the point of ``motion_id`` (the next leg of the current path)."""
        self._begin(now)
        task = self._head
        if task is None or self.state is not _MOTION or not task.route:  # not driving (see _driving)
            raise LocalProtocolError(f"{self.robot}: motion {motion_id.label} finished but no leg was running")
        expected = task.slots[task.route[0]].motion_id  # type: ignore[union-attr]  # the route holds motions
        if expected.uuid != motion_id.uuid:  # Id equality, without its Python-level __eq__
            raise LocalProtocolError(
                f"{self.robot}: motion {motion_id.label} finished, expected {expected.label}"
            )
        task.route.popleft()
        task.since = now  # the next leg, if any, begins now
        self.last_finished_motion = motion_id
        self.version += 1
        self._out.append(MotionFinished(task.id, motion_id))
        if task.ending is not None:
            self._finish_cancel(now, task)
        else:
            self._advance(now)
        return self._end()

    def on_action_finished(
        self, now: float, action_id: Id, ok: bool = True, code: str = "", message: str = ""
    ) -> list[Effect]:
        """AgvAction finished ``action_id``; a failure carries the error ``code`` and ``message`` (docs/contract.md §4)."""
        self._begin(now)
        task = self._head
        if task is None or not task.action_running:
            raise LocalProtocolError(f"{self.robot}: action {action_id.label} finished but none was running")
        running = task.action_at(task.next_action)
        if running.action_id.uuid != action_id.uuid:
            raise LocalProtocolError(
                f"{self.robot}: action {action_id.label} finished, expected {running.action_id.label}"
            )
        task.action_running = False
        task.next_action += 1
        self.last_finished_action = action_id
        self.version += 1
        self._out.append(ActionFinished(task.id, action_id, ok))
        if not ok:  # reported, but a cancel or timeout already pending keeps its reason (R14)
            self._error(Failed, code or "action_failed", message, task.id, NIL, action_id)
            self._finish_cancel(now, task, task.ending or Reason.ACTION_FAILED)
        elif task.ending is not None:
            self._finish_cancel(now, task)
        else:
            self._advance(now)
        return self._end()

    # --- the robot stops on its own (docs/contract.md §4: battery, faults, collisions) -------------------------------

    def on_halt(self, now: float, reason: Reason, code: str, message: str, out_of_service: bool = False) -> list[Effect]:
        """The robot stopped where it is: its running leg or action is over and no completion follows.

        The current task ends now with ``reason`` (or with the reason it was already ending for, R14), and
        the stop is reported as ``code``. ``out_of_service``: every queued task ends too, and assignments of
        new tasks are rejected (code ``reason``) until :meth:`on_service`.
        """
        self._begin(now)
        task = self._head
        self._error(Failed, code, message, task.id if task else NIL, self.current_motion, self.current_action)
        if out_of_service:
            self.out_of_service = reason.value
        for ending in list(self.queue.values()) if out_of_service else [task] if task else []:
            self._cancel_now(now, ending, ending.ending or reason, ending.cancel)
        if task is not None:
            self._start_next(now)
        return self._end()

    def on_service(self, now: float) -> list[Effect]:
        """The robot takes tasks again (battery swapped or charged)."""
        self._begin(now)
        self.out_of_service = ""
        return self._end()

    def count_error(self) -> int:
        """Count one ``ran_error`` the model publishes itself (a docs/contract.md §4 incident); returns the running count."""
        self.error_count += 1
        return self.error_count

    # --- status -----------------------------------------------------------------------------------------

    @property
    def current_motion(self) -> Id:
        task = self._head
        if task is None or self.state is not _MOTION or not task.route:  # not driving (see _driving)
            return NIL
        return assignment_id(task.slots[task.route[0]])

    @property
    def current_action(self) -> Id:
        task = self._head
        if task is None or not task.action_running:
            return NIL
        return task.action_at(task.next_action).action_id

    def ran_status(self, carrying: int = 0) -> RanStatus:
        """The status as published, with the parts the robot ``carrying`` (the AGV's, not RanLogic's to
        know). Built again only when what it shows changed: the state, the queue (a task arrived or
        ended) or the load; telemetry asks for it whenever anything of the robot changed."""
        key = (self.state, self._arrivals, self._ended, carrying)
        cached = self._status
        if cached is not None and cached[0] == key:
            return cached[1]
        status = _ran_status(
            state=self.state._value_,
            current_task_id=self.current_task,
            queue=tuple(islice(self.queue, QUEUE_SHOWN)),
            queued=len(self.queue),
            completed=tuple(self.recent_completed),
            cancelled=tuple(self.recent_cancelled),
            carrying=carrying,
        )
        self._status = (key, status)
        return status

    @property
    def idle(self) -> bool:
        return self.state is _WAITING and not self.queue

    # --- assignments (R1, R2, R9, R10) ------------------------------------------------------------------

    def _on_assignment(self, now: float, a: Assignment) -> None:
        task = self.queue.get(a.task_id)
        if task is None:
            ended = self.history.get(a.task_id)
            if ended is None and self.out_of_service:
                self._reject(self.out_of_service, f"robot is out of service ({self.out_of_service}): no new tasks [§4]", a)
            elif ended is None:
                self._new_task(now, a)
            elif not ended.has_identical(a):
                code = "task_completed" if ended.reason is None else "task_cancelled"
                self._reject(code, f"task {a.task_id.label} was already {_how(ended)} [R9]", a)
            return
        pos = task.lookup(a)
        if pos is not None and same_content(task.slots[pos], a):
            return  # R10: an identical re-read (polling, notifications carrying every attribute)
        if task.ending is not None:
            self._reject("task_cancelled", f"task {task.id.label} is being cancelled [R8]", a)
            return
        if pos is not None and pos in task.skipped:
            self._reject("assignment_cancelled", f"{kind_of(a)} {assignment_id(a).label} was cancelled [R13]", a)
            return
        if pos is not None and task.dispatched(pos):
            self._reject("already_dispatched", f"{kind_of(a)} {assignment_id(a).label} was already dispatched [R10]", a)
            return
        if pos is not None and task.m is not None and pos != a.sequence.sequence_number:
            self._reject("position_changed", f"{kind_of(a)} {assignment_id(a).label} cannot move once the path is dispatched [R10]", a)
            return
        problem = task.position_problem(a, pos)
        if problem is not None:
            self._reject(problem[0], problem[1], a)
            return
        task.put(a, pos)
        self.version += 1
        self._settle(now, task, a)
        if task.assembled:  # R5 (the task may have ended meanwhile: R13 skips can finish it at once)
            self._out.append(ClearTimer(task.id))

    def _new_task(self, now: float, a: Assignment) -> None:
        """R1: the first assignment of an unseen task id creates it; first_seen = now."""
        self._arrivals += 1
        task = Task(a.task_id, now, self._arrivals, a.sequence.length, now + self.task_timeout)
        task.put(a, None)
        self.queue[task.id] = task
        if self._head is None:
            self._head, self.current_task = task, task.id
        self.version += 1
        self._out.append(TaskQueued(task.id))
        if not task.assembled:
            # R14: the timer waits out the tolerance, so an input at the deadline is on time; rounded
            # to the nanosecond so that the instant reads as the scenario would write it.
            self._out.append(StartTimer(task.id, round(task.deadline + TOLERANCE, 9)))
        if len(self.queue) == 1:
            self._set_state(_TASK)
        self._settle(now, task, a)

    def _settle(self, now: float, task: Task, a: Assignment) -> None:
        """After ``a`` was accepted: skip it if a cancel named it before it arrived (R13), then let the
        task go as far as it can."""
        cancel = self.doomed.pop((task.id, kind_of(a), assignment_id(a)), None) if self.doomed else None
        if cancel is not None:
            self._skip(task, a.sequence.sequence_number)
            if len(task.skipped) == task.length:
                self._end_task(now, task, Reason.CANCELLED, cancel)
                return
        if task is self._head:
            self._advance(now)

    # --- cancel (R8) ------------------------------------------------------------------------------------

    def _on_cancel(self, now: float, c: CancelTask) -> None:
        named = [(kind, ident) for kind, ident in (("motion", c.motion_id), ("action", c.action_id))
                 if not ident.is_unused]
        task = self.queue.get(c.task_id)
        if task is not None:
            if task.ending is not None:
                return  # already ending, whole: the earlier reason stands
            if named:
                self._partial_cancel(now, task, c, named)
            else:
                self._end_task(now, task, Reason.CANCELLED, c)
            return
        ended = self.history.get(c.task_id)
        if ended is None and named:
            for kind, ident in named:
                self._doom(c, kind, ident)
            self._error(
                Rejected, "cancel_unknown_assignment",
                f"cancel for {_named(named)} of unknown task {c.task_id.label}: remembered, "
                "skipped if it arrives [R13]", c.task_id, *_ids(named), severity="warning",
            )
        elif ended is None:
            self._remember(c.task_id, Ended.of(None, Reason.CANCELLED, now, c))
            self._error(
                Rejected, "cancel_unknown_task",
                f"cancel for unknown task {c.task_id.label}: remembered, its assignments will be rejected [R8]",
                c.task_id, severity="warning",
            )
        elif not ended.same_cancel(c):
            ended.cancel = fingerprint(c)
            self.history.replace(c.task_id, ended)
            self._error(
                Rejected, "cancel_finished_task", f"cancel for task {c.task_id.label}, already {_how(ended)} [R8]",
                c.task_id, *_ids(named), severity="warning",
            )

    def _partial_cancel(self, now: float, task: Task, c: CancelTask, named: list[tuple[str, Id]]) -> None:
        """R13: cancel the named assignments of a live task, all or (if one cannot be) none."""
        positions: list[int] = []
        unknown: list[tuple[str, Id]] = []
        for kind, ident in named:
            pos = task.where.get((kind, ident.uuid))
            if pos is None:
                unknown.append((kind, ident))
            elif pos not in task.skipped:  # else cancelled already: a re-read
                refusal = task.refusal(pos)
                if refusal is not None:
                    self._error(Rejected, refusal[0], refusal[1], task.id, *_ids(named), severity="warning")
                    return
                positions.append(pos)
        for kind, ident in unknown:
            self._doom(c, kind, ident)
        if unknown:
            self._error(
                Rejected, "cancel_unknown_assignment",
                f"cancel for {_named(unknown)} of task {task.id.label}, not received: remembered, "
                "skipped if it arrives [R13]", task.id, *_ids(unknown), severity="warning",
            )
        if not positions:
            return
        for pos in positions:
            self._skip(task, pos)
        self.version += 1
        if len(task.skipped) == task.length:  # every assignment cancelled: the task is (R13)
            self._end_task(now, task, Reason.CANCELLED, c)
        elif task is self._head:
            self._advance(now)

    def _skip(self, task: Task, pos: int) -> None:
        """R13: the assignment at ``pos`` counts as received and is never performed."""
        task.skipped.add(pos)
        a = task.slots[pos]
        self._out.append(AssignmentCancelled(task.id, kind_of(a), assignment_id(a)))
        if pos in task.route:  # a point of the path being driven, not yet reached
            task.route.remove(pos)
            self._out.append(SkipMotion(task.id, assignment_id(a)))

    def _doom(self, c: CancelTask, kind: str, ident: Id) -> None:
        """R13: remember a cancel for an assignment not received yet, bounded like the history (R9)."""
        key = (c.task_id, kind, ident)
        self.doomed[key] = c
        self.doomed.move_to_end(key)
        while len(self.doomed) > self.history_limit:
            self.doomed.popitem(last=False)

    def _end_task(
        self, now: float, task: Task, reason: Reason, cancel: CancelTask | None = None, at: float | None = None
    ) -> None:
        """Cancel ``task`` now if nothing of it runs, else once its running leg or action finishes (R8).

        ``at`` is the instant the request is about (the deadline for a timeout; ``now`` for a cancel): a
        leg or action that began within :data:`TOLERANCE` of it is abandoned instead (R14)."""
        if task is not self._head:
            self._cancel_now(now, task, reason, cancel)
            return
        driving = self._driving(task)
        if driving or task.action_running:
            if abs((now if at is None else at) - task.since) > TOLERANCE:
                task.ending = reason
                task.cancel = cancel
                if driving:
                    self._out.append(StopAfterLeg(task.id))
                return
            self._out.append(Abandon(task.id))
        self._finish_cancel(now, task, reason, cancel)

    def _finish_cancel(
        self, now: float, task: Task, reason: Reason | None = None, cancel: CancelTask | None = None
    ) -> None:
        reason = reason or task.ending or Reason.CANCELLED
        cancel = cancel or task.cancel
        self._cancel_now(now, task, reason, cancel)
        self._start_next(now)

    def _cancel_now(self, now: float, task: Task, reason: Reason, cancel: CancelTask | None) -> None:
        self._dequeue(task)
        self._remember(task.id, Ended.of(task, reason, now, cancel))
        self.recent_cancelled.append(_task_end(task.id, reason.value, Time.from_seconds(now)))
        self.version += 1
        if not task.assembled:
            self._out.append(ClearTimer(task.id))
        self._out.append(TaskCancelled(task.id, reason))

    # --- the state machine (R3-R6) ----------------------------------------------------------------------

    def _advance(self, now: float) -> None:
        """Move the current task as far as what has been received allows."""
        task = self._head
        assert task is not None
        if self.state is _TASK:
            m = task.motion_count()
            if m is None:
                return
            task.m = m
            task.next_action = m + 1
            path = range(1, m + 1)
            task.route.extend([p for p in path if p not in task.skipped] if task.skipped else path)
            self._set_state(_MOTION)
            if task.route:
                task.since = now
                self._out.append(DispatchPath(task.id, task.path()))
        if self.state is _MOTION:
            if task.route or not task.actions_complete():
                return
            self._set_state(_ACTION)
        if self.state is _ACTION and not task.action_running:
            if task.skipped:
                task.skip_cancelled_actions()
            if task.next_action <= task.length:
                task.action_running = True
                task.since = now
                self.version += 1
                self._out.append(DispatchAction(task.id, task.action_at(task.next_action)))
            else:
                self._complete(now, task)

    def _complete(self, now: float, task: Task) -> None:
        self._dequeue(task)
        self._remember(task.id, Ended.of(task, None, now))
        self.recent_completed.append(task.id)
        self.version += 1
        self._out.append(TaskCompleted(task.id))
        self._start_next(now)

    def _start_next(self, now: float) -> None:
        if self.state is not _WAITING:
            self._set_state(_WAITING)
        if self.queue:
            self._set_state(_TASK)
            self._advance(now)

    def _set_state(self, to: State) -> None:
        change = _STATE_CHANGES.get((self.state._name_, to._name_))
        if change is None:
            raise AssertionError(f"{self.robot}: transition {self.state.value} -> {to.value} does not exist (R6)")
        self._out.append(change)
        self.state = to
        self.version += 1

    # --- helpers ----------------------------------------------------------------------------------------

    def _driving(self, task: Task) -> bool:
        """The AGV is on a leg of ``task``'s path (``task`` being the current task)."""
        return self.state is _MOTION and bool(task.route)

    def _dequeue(self, task: Task) -> None:
        del self.queue[task.id]
        self._ended += 1
        if task is self._head:
            self._head = head = next(iter(self.queue.values()), None)
            self.current_task = head.id if head is not None else NIL

    def _remember(self, task_id: Id, ended: Ended) -> None:
        """R9: keep the latest ``history_limit`` ended task ids (and no more than ``history_bytes``)."""
        self.history.remember(task_id, ended)

    def _reject(self, code: str, message: str, a: Assignment) -> None:
        motion = a.motion_id if isinstance(a, MotionAssignment) else NIL
        action = a.action_id if isinstance(a, ActionAssignment) else NIL
        self._error(Rejected, code, message, a.task_id, motion, action)

    def _error(
        self,
        cls: type[ErrorReport],
        code: str,
        message: str,
        task: Id = NIL,
        motion: Id = NIL,
        action: Id = NIL,
        severity: str = "error",
    ) -> None:
        self.error_count += 1
        self._out.append(cls(code, message, severity, task, motion, action, self.error_count))

    def _begin(self, now: float) -> None:
        if now < self._now:
            raise LocalProtocolError(f"{self.robot}: time went backwards from {self._now} to {now}")
        self._now = now

    def _end(self) -> list[Effect]:
        out, self._out = self._out, []
        return out


def _named(named: list[tuple[str, Id]]) -> str:
    return " and ".join(f"{kind} {ident.label}" for kind, ident in named)


def _ids(named: list[tuple[str, Id]]) -> tuple[Id, Id]:
    """(motion, action) ids for an error report."""
    found = dict(named)
    return found.get("motion", NIL), found.get("action", NIL)


def _how(ended: Ended) -> str:
    return "completed" if ended.reason is None else f"cancelled, reason {ended.reason.value}"
