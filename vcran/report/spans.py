"""What each robot did when, rebuilt from ``events.jsonl``: RanLogic state bands and task lifetimes.

The events say when a task was first seen, when it completed or was cancelled, and every state
transition, but not which task a ``state TASK`` transition started. R1 settles it: the current task is
the head of the queue, and the queue runs in first-seen order, which is the order of the
``task_queued`` events. So a task becomes current at the first transition to TASK while it heads the
tasks still pending; the layout colours the path driven between then and its end by that task.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Protocol

from vcran.core.opil.effects import Reason, State

WAITING = State.WAITING.value
STATES = tuple(s.value for s in State)
REASONS = tuple(r.value for r in Reason)
OPEN = "open"


@dataclass(frozen=True, slots=True)
class Band:
    """The robot's RanLogic was in ``state`` from ``start`` to ``end`` (never empty)."""

    state: str
    start: float
    end: float


@dataclass(slots=True)
class TaskSpan:
    """One task's life on one robot.

    ``outcome`` is ``"completed"``, the cancel reason (``timeout``, ``cancelled``, ``action_failed``),
    or ``"open"`` for a task still queued or running when the run ended (``end`` is then the run's end).
    ``started`` is when it became the current task; ``None`` if it never did (cancelled while queued).
    """

    robot: str
    task: str
    queued: float
    started: float | None = None
    end: float = 0.0
    outcome: str = OPEN

    @property
    def completed(self) -> bool:
        return self.outcome == "completed"


@dataclass(slots=True)
class History:
    """A robot's state bands and units of work: OPIL's tasks, or a VDA 5050 vehicle's orders
    (:mod:`vcran.report.vda5050`), whose state lane has its own names and whose idle state is ``idle``."""

    robot: str
    bands: list[Band] = field(default_factory=list)
    tasks: list[TaskSpan] = field(default_factory=list)
    idle: str = WAITING
    #: VDA 5050: orders the vehicle refused (``order_rejected``, §6.6.4); OPIL has no such count (0).
    rejected: int = 0

    @property
    def busy(self) -> float:
        """Seconds not idle: a task (an order) was current, whether assembling, driving or acting."""
        return sum(b.end - b.start for b in self.bands if b.state != self.idle)


class Happenings(Protocol):
    """What histories are built from: a run folder's (:class:`vcran.report.folder.Run`), or a
    ``vcran manage`` folder's, whose robots' events are what the manager heard (:mod:`vcran.report.managed`)."""

    @property
    def protocol(self) -> str: ...  # the scenario's: ``opil`` or ``vda5050``
    @property
    def robot_ids(self) -> tuple[str, ...]: ...
    @property
    def events(self) -> list[dict[str, Any]]: ...
    @property
    def sim_time(self) -> float: ...


def histories(run: Happenings) -> dict[str, History]:
    """Every robot's history, robots in fleet order; events of entities outside the fleet are ignored. A
    VDA 5050 run's are its vehicles' orders (:mod:`vcran.report.vda5050`), read from its events and trace
    (a ``vcran manage --mqtt`` folder: its events only)."""
    if run.protocol == "vda5050":
        from vcran.report.vda5050 import order_histories

        return order_histories(run)
    builders = {rid: _Builder(rid) for rid in run.robot_ids}
    for event in run.events:
        builder = builders.get(event["robot"])
        if builder is not None:
            builder.feed(event)
    return {rid: b.finish(run.sim_time) for rid, b in builders.items()}


class _Builder:
    def __init__(self, robot: str) -> None:
        self.history = History(robot)
        self.state, self.since = WAITING, 0.0
        self.pending: dict[str, TaskSpan] = {}  # open tasks by label, in first-seen order (R1)

    def feed(self, event: dict[str, Any]) -> None:
        t, name = float(event["t"]), event["event"]
        if name == "state":
            self._band_until(t)
            self.state, self.since = event["to"], t
            if self.state == State.TASK.value and self.pending:
                head = next(iter(self.pending.values()))
                if head.started is None:
                    head.started = t
        elif name == "task_queued":
            span = TaskSpan(self.history.robot, event["task"], t)
            self.pending[span.task] = span
            self.history.tasks.append(span)
        elif name in ("task_completed", "task_cancelled"):
            ended = self.pending.pop(event["task"], None)
            if ended is not None:
                ended.end = t
                ended.outcome = "completed" if name == "task_completed" else event["reason"]

    def finish(self, end: float) -> History:
        self._band_until(end)
        for span in self.pending.values():
            span.end = end
        return self.history

    def _band_until(self, t: float) -> None:
        if t > self.since:
            self.history.bands.append(Band(self.state, self.since, t))
