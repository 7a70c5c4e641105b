"""Jobs as a run records them: arrival, assignment, outcome, and the fleet KPIs they add up to (docs/contract.md §9).

The fleet manager decides what happens to a job; this book only writes down what the run saw (a job
reaching the manager) and what the manager reported through its handle (a task sent for the job, the job
done or failed), as ``job_*`` events and, at the end, :class:`JobRecord` rows and the ``jobs`` section of
``summary.json``. A report that makes no sense (a job done twice, or one that never arrived) is the
manager's bug and raises :class:`JobError` at once, naming the job.

A VDA 5050 job's task is an order: how an order ended, read from one event (:func:`order_end`), is defined
here, in the shared core, because the waiting spans below need it and the shared core imports no protocol;
VDA 5050's order-by-order reading (:mod:`vcran.core.vda5050.outcomes`: ``vcran report``, ``vcran sweep``)
calls it.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # a type only: the job book serves both protocols, and the scenario module still imports OPIL's
    from vcran.core.scenario import Job

COMPLETED, FAILED, OPEN = "completed", "failed", "open"

#: Why a job failed, as a manager reports it: a task's cancellation reason (docs/contract.md §8: ``timeout``,
#: ``cancelled``, ``action_failed``; reserved for the realism issue: ``battery_empty``,
#: ``motion_failed``, ``collision``; docs/contract.md §12: ``deadlock``) or ``unassignable`` (no robot can take it). A
#: manager may report a reason of its own; these are the ones vcran's dispatcher and report use.
FAILURE_REASONS = ("timeout", "cancelled", "action_failed", "battery_empty", "motion_failed", "collision",
                   "deadlock", "unassignable")

#: ``log(t, robot, event, fields)``: one line of ``events.jsonl``.
Log = Callable[[float, str, str, dict[str, Any]], None]


class JobError(ValueError):
    """A fleet manager reported a job that is unknown or already ended."""


@dataclass(frozen=True, slots=True)
class JobRecord:
    """What became of one job.

    ``robot`` is the robot of the last task sent for it ("" if none was); ``outcome`` is
    ``"completed"``, ``"failed"`` or ``"open"`` (the run ended first); ``ended`` is when the manager
    reported it done or failed; ``tasks`` names every task sent for it, in order.
    """

    job: Job
    robot: str = ""
    outcome: str = OPEN
    ended: float | None = None
    reason: str = ""
    tasks: tuple[str, ...] = ()

    @property
    def id(self) -> str:
        return self.job.id

    @property
    def lead_time(self) -> float | None:
        """Seconds from arrival to completion; None unless completed."""
        return self.ended - self.job.t if self.outcome == COMPLETED and self.ended is not None else None

    @property
    def late(self) -> bool:
        """Completed after its deadline (a job without one is never late)."""
        deadline = self.job.deadline
        return self.outcome == COMPLETED and deadline is not None and self.ended is not None and self.ended > deadline


class JobBook:
    """Every job that reached the fleet manager, in arrival order."""

    def __init__(self, log: Log) -> None:
        self._log = log
        self._records: dict[str, JobRecord] = {}
        self.open = 0

    def arrived(self, t: float, job: Job) -> None:
        if job.id in self._records:
            raise JobError(f"job {job.id!r} arrived twice")
        self._records[job.id] = JobRecord(job)
        self.open += 1
        self._log(t, "", "job_arrived", {"job": job.id, "pickup": job.pickup, "dropoff": job.dropoff,
                                         "priority": job.priority, "deadline": job.deadline})

    def assigned(self, t: float, job: Job | str, robot: str, task: str) -> None:
        record = self._open(job, "assign a task to")
        self._records[record.id] = replace(record, robot=robot, tasks=(*record.tasks, task))
        self._log(t, robot, "job_assigned", {"job": record.id, "task": task})

    def completed(self, t: float, job: Job | str) -> None:
        record = self._open(job, "complete")
        self._end(replace(record, outcome=COMPLETED, ended=t))
        self._log(t, record.robot, "job_completed", {"job": record.id, "lead_time": t - record.job.t})

    def failed(self, t: float, job: Job | str, reason: str) -> None:
        record = self._open(job, "fail")
        self._end(replace(record, outcome=FAILED, ended=t, reason=reason))
        self._log(t, record.robot, "job_failed", {"job": record.id, "reason": reason, "tasks": len(record.tasks)})

    def records(self) -> tuple[JobRecord, ...]:
        return tuple(self._records.values())

    def summary(self, sim_time: float) -> dict[str, Any]:
        """The ``jobs`` section of summary.json (docs/outputs.md defines each figure)."""
        records = self._records.values()
        leads = sorted(r.lead_time for r in records if r.lead_time is not None)
        done = len(leads)
        return {
            "arrived": len(self._records),
            "completed": done,
            "failed": sum(r.outcome == FAILED for r in records),
            "open": self.open,
            "late": sum(r.late for r in records),
            "done_per_hour": done * 3600.0 / sim_time if sim_time > 0 else 0.0,
            "lead_time": {
                "mean": sum(leads) / done, "p50": quantile(leads, 0.5), "p95": quantile(leads, 0.95),
                "max": leads[-1],
            } if leads else None,
        }

    def _open(self, job: Job | str, what: str) -> JobRecord:
        if isinstance(job, str):
            key = job
        elif isinstance(getattr(job, "id", None), str) and hasattr(job, "dropoff"):  # a Job, known by its fields
            key = job.id
        else:
            raise TypeError(f"a job is a vcran.Job or its id, got {type(job).__name__}")
        record = self._records.get(key)
        if record is None:
            raise JobError(f"cannot {what} job {key!r}: no such job has arrived")
        if record.outcome != OPEN:
            raise JobError(f"cannot {what} job {key!r}: it already {record.outcome} at t={record.ended}")
        return record

    def _end(self, record: JobRecord) -> None:
        self._records[record.id] = record
        self.open -= 1


#: How a VDA 5050 order ends besides ``completed`` and the halts, as :func:`order_end` names it: the vehicle
#: refused it, or one of its actions FAILED.
REJECTED, ACTION_FAILED = "rejected", "action_failed"


@dataclass(frozen=True, slots=True)
class OrderEnd:
    """What one event of a VDA 5050 run says about how order ``order_id`` ended (:func:`order_end`).

    ``how``: ``completed``, ``cancelled`` or the halt that gave it up (``battery_empty``, ``motion_failed``,
    ``collision``, ``deadlock``), from its ``order_ended``; :data:`REJECTED` from an ``order_rejected``; or
    :data:`ACTION_FAILED`, from an ``actionFailed`` error naming it: the order goes on and ends later, then
    counts as ended with an action failed if it ended ``completed``. ``order_id``: None when the event
    names no order (an ``order_ended`` logged without it; its vehicle's current order is meant).
    """

    order_id: str | None
    how: str

    @property
    def unsuccessful(self) -> bool:
        return self.how != COMPLETED


def order_end(event: dict[str, Any]) -> OrderEnd | None:
    """How a VDA 5050 order ended, as ``event`` (one of ``events.jsonl``, docs/vda5050.md) records it, or
    None when it records no end: the one definition of an order's outcome, which the loop properties
    (:func:`order_unsuccessful`), ``vcran report`` and ``vcran sweep``
    (:class:`vcran.core.vda5050.outcomes.OrderLog`) read. An action's failure is an ``actionFailed`` error
    whose ``orderId`` reference names the order (only an order's action has one; an instant action's
    failure names none)."""
    kind = event["event"]
    if kind == "order_ended" or kind == "order_rejected":
        order = event.get("order_id")
        return OrderEnd(order if isinstance(order, str) else None,
                        str(event.get("how")) if kind == "order_ended" else REJECTED)
    if kind == "error_raised":
        error = event.get("error")
        if not isinstance(error, dict) or error.get("errorType") != "actionFailed":
            return None
        for ref in error.get("errorReferences") or ():
            if isinstance(ref, dict) and ref.get("referenceKey") == "orderId":
                order = ref.get("referenceValue")
                return OrderEnd(order, ACTION_FAILED) if isinstance(order, str) else None
    return None


def order_unsuccessful(event: dict[str, Any]) -> str | None:
    """The orderId of a VDA 5050 order that ``event`` records ending without success (:func:`order_end`),
    else None: the vehicle refused it (``order_rejected``), gave it up or had it cancelled (``order_ended``
    other than ``completed``), or one of its actions FAILED (the order itself then ends ``completed``). An
    order is a VDA 5050 job's task (``job_assigned``)."""
    end = order_end(event)
    return end.order_id if end is not None and end.unsuccessful else None


def waiting_spans(events: list[dict[str, Any]], end: float) -> list[tuple[str, float, float]]:
    """``(job, from, to)`` from a closed-loop run's events (docs/outputs.md): a job waits for a robot
    from its arrival, and again from its latest task's cancellation (a VDA 5050 order's unsuccessful end,
    :func:`order_unsuccessful`), until the manager sends a task for it or reports it ended; a span still
    open at ``end`` ends there. The loop property "no robot idles while a job waits"
    (:mod:`vcran.testing.loop`) and the report's fleet figure both count this way."""
    since: dict[str, float] = {}
    latest: dict[tuple[str, str], str] = {}  # (robot, task) -> job, for the job's latest task
    spans = []

    def stop(job: str, t: float) -> None:
        start = since.pop(job, None)
        if start is not None:
            spans.append((job, start, t))

    for e in events:
        kind = e["event"]
        if kind == "job_arrived":
            since[e["job"]] = e["t"]
        elif kind == "job_assigned":
            stop(e["job"], e["t"])
            for key in [k for k, j in latest.items() if j == e["job"]]:
                del latest[key]
            latest[(e["robot"], e["task"])] = e["job"]
        elif kind in ("job_completed", "job_failed"):
            stop(e["job"], e["t"])
            for key in [k for k, j in latest.items() if j == e["job"]]:
                del latest[key]
        else:
            task = e["task"] if kind == "task_cancelled" else order_unsuccessful(e)
            job = latest.pop((e["robot"], task), None) if task is not None else None
            if job is not None:
                since[job] = e["t"]
    spans += [(job, start, end) for job, start in since.items()]
    return spans


def quantile(ordered: list[float], q: float) -> float:
    """The ``q`` quantile of sorted values, interpolating linearly between the two nearest ranks (the
    definition numpy and pandas use by default): rank ``q * (n - 1)`` counted from 0."""
    if not ordered:
        raise ValueError("quantile of no values")
    h = q * (len(ordered) - 1)
    lo = math.floor(h)
    hi = min(lo + 1, len(ordered) - 1)
    return ordered[lo] + (h - lo) * (ordered[hi] - ordered[lo])
