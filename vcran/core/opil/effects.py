"""What RanLogic asks the world to do, and what it reports: frozen, slotted values.

RanLogic never acts; every input returns a list of these, in the order they happen. Commands
(:class:`DispatchPath`, :class:`StopAfterLeg`, :class:`DispatchAction`, :class:`StartTimer`,
:class:`ClearTimer`) are carried out by the SimPy model; events (the rest) are logged to ``events.jsonl``
and, for errors, published as ``ran_error``. Keeping both in one ordered list is what makes a
state transition and the command that caused it impossible to reorder by accident.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass
from typing import Any

from vcran.core.events import Event
from vcran.core.opil.ids import NIL, Id
from vcran.core.opil.messages import ActionAssignment, MotionAssignment
from vcran.core.slots import slot_init


class State(enum.Enum):
    """RanLogic's states (R6)."""

    WAITING = "WAITING"
    TASK = "TASK"
    MOTION = "MOTION"
    ACTION = "ACTION"


class Reason(enum.Enum):
    """Why a task was cancelled (docs/contract.md §8)."""

    TIMEOUT = "timeout"
    CANCELLED = "cancelled"
    ACTION_FAILED = "action_failed"
    #: docs/contract.md §4: the robot stopped on its own (battery, an injected motion failure, a collision).
    BATTERY_EMPTY = "battery_empty"
    MOTION_FAILED = "motion_failed"
    COLLISION = "collision"
    #: docs/contract.md §12: the robot was deadlocked and the scenario cancels its task (``on_deadlock = "cancel"``).
    #: (The last reason a history record's three bits hold: :data:`vcran.core.opil.history._REASONS`.)
    DEADLOCK = "deadlock"


# --- commands -------------------------------------------------------------------------------------------


@slot_init
@dataclass(frozen=True, slots=True)
class DispatchPath:
    """Send every motion of the task to the AGV at once, as one path (R6 MOTION)."""

    task: Id
    motions: tuple[MotionAssignment, ...]


@dataclass(frozen=True, slots=True)
class StopAfterLeg:
    """The current task is being cancelled: finish the running leg, then stop (R8)."""

    task: Id


@dataclass(frozen=True, slots=True)
class SkipMotion:
    """Drop ``motion``'s point from the path being driven; it is not the running leg (R13)."""

    task: Id
    motion: Id


@dataclass(frozen=True, slots=True)
class Abandon:
    """The leg or action of ``task`` that began at this very instant does not happen: a cancel or a
    timeout at the same instant as the end of the previous leg or action stops the robot there (R14).
    The AGV stays where the leg began; AgvAction performs nothing."""

    task: Id


@slot_init
@dataclass(frozen=True, slots=True)
class DispatchAction:
    """Send one action to AgvAction (R6 ACTION: one at a time, in sequence order)."""

    task: Id
    action: ActionAssignment


@slot_init
@dataclass(frozen=True, slots=True)
class StartTimer:
    """Call :meth:`RanLogic.on_timer` for ``task`` at simulated time ``at`` (R7)."""

    task: Id
    at: float


@slot_init
@dataclass(frozen=True, slots=True)
class ClearTimer:
    """The R7 timer of ``task`` no longer matters (assembled or ended)."""

    task: Id


Command = DispatchPath | StopAfterLeg | SkipMotion | Abandon | DispatchAction | StartTimer | ClearTimer

# --- events ---------------------------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class StateChanged(Event):
    NAME = "state"
    from_: State
    to: State

    def fields(self) -> dict[str, Any]:
        # ``_value_``: the member's value as stored; ``.value`` is a Python-level descriptor, and a run
        # logs a few state changes per task.
        return {"from": self.from_._value_, "to": self.to._value_}


@slot_init
@dataclass(frozen=True, slots=True)
class TaskQueued(Event):
    NAME = "task_queued"
    task: Id

    def fields(self) -> dict[str, Any]:
        return {"task": self.task.description or self.task.label}


@slot_init
@dataclass(frozen=True, slots=True)
class TaskCompleted(Event):
    NAME = "task_completed"
    task: Id

    def fields(self) -> dict[str, Any]:
        return {"task": self.task.description or self.task.label}


@dataclass(frozen=True, slots=True)
class TaskCancelled(Event):
    NAME = "task_cancelled"
    task: Id
    reason: Reason

    def fields(self) -> dict[str, Any]:
        return {"task": self.task.description or self.task.label, "reason": self.reason.value}


@slot_init
@dataclass(frozen=True, slots=True)
class MotionFinished(Event):
    NAME = "motion_finished"
    task: Id
    motion: Id

    def fields(self) -> dict[str, Any]:
        return {"task": self.task.description or self.task.label,
                "motion": self.motion.description or self.motion.label}


@slot_init
@dataclass(frozen=True, slots=True)
class ActionFinished(Event):
    NAME = "action_finished"
    task: Id
    action: Id
    ok: bool

    def fields(self) -> dict[str, Any]:
        return {"task": self.task.description or self.task.label,
                "action": self.action.description or self.action.label, "ok": self.ok}


@dataclass(frozen=True, slots=True)
class AssignmentCancelled(Event):
    """R13: one assignment of a live task was cancelled; its position counts as received, it is never
    performed (a motion's point is dropped from the path)."""

    NAME = "assignment_cancelled"
    task: Id
    kind: str  # "motion" or "action"
    assignment: Id

    def fields(self) -> dict[str, Any]:
        return {"task": self.task.label, self.kind: self.assignment.label}


@dataclass(frozen=True, slots=True)
class ErrorReport(Event):
    """Published as ``ran_error``. ``count`` is the robot's running error count including this one."""

    code: str
    message: str
    severity: str = "error"
    task: Id = NIL
    motion: Id = NIL
    action: Id = NIL
    count: int = 0

    def fields(self) -> dict[str, Any]:
        out: dict[str, Any] = {"code": self.code, "severity": self.severity}
        for name in ("task", "motion", "action"):
            ident: Id = getattr(self, name)
            if not ident.is_nil:
                out[name] = ident.label
        out["message"] = self.message
        return out


@dataclass(frozen=True, slots=True)
class Rejected(ErrorReport):
    """An input that was refused (R2, R8, R9, R10, R11, R12); nothing of it was applied."""

    NAME = "rejected"


@dataclass(frozen=True, slots=True)
class Failed(ErrorReport):
    """An action that failed (docs/contract.md §4); the task is cancelled with reason ``action_failed``."""

    NAME = "failed"


@dataclass(frozen=True, slots=True)
class Published(ErrorReport):
    """A ``ran_error`` of the robot's own (docs/contract.md §4: battery, faults, collisions) that only goes on the wire:
    its incident has an event of its own (:mod:`vcran.core.incidents`)."""

    NAME = ""


Effect = Command | Event


class LocalProtocolError(RuntimeError):
    """The driver misused RanLogic (time going backwards, a completion nobody dispatched); a misuse of the
    driver's, never the peer's (h11's LocalProtocolError). :mod:`vcran.core.opil.ranlogic` re-exports it."""
