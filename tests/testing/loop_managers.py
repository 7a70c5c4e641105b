"""Deliberately broken fleet managers (docs/contract.md §9, issue 10): the loop properties must catch each one, and
the CLI must blame the manager, not vcran, for one that raises.

Importable as ``tests.testing.loop_managers:Class`` so that ``vcran fuzz --manager`` can run them too.
"""

from __future__ import annotations

from vcran.core.opil import build
from vcran.core.opil.codec import encode_attribute
from vcran.core.opil.manager import FleetManager
from vcran.core.opil.messages import ActionAssignment
from vcran.core.scenario import Job
from vcran.managers import Dispatcher
from vcran.managers.dispatcher import Trip


class OutOfRange(Dispatcher):
    """Numbers every assignment one past the task's length (sequence_number = length + 1)."""

    def send(self, robot: str, trip: Trip) -> None:
        station, action = (trip.job.pickup, "load") if trip.phase == "pick" else (trip.job.dropoff, "unload")
        name = f"{trip.job.id}_{trip.phase}{trip.tries + 1}"
        for message in build.task(name, [self.fleet.dock(station)], [action]):
            attribute = "action_assignment" if isinstance(message, ActionAssignment) else "motion_assignment"
            value = encode_attribute(attribute, message)
            value["value"]["sequence"]["value"]["sequence_number"]["value"] = message.sequence.length + 1
            self.handle.send_raw(robot, attribute, value)
        trip.task = message.task_id


class NeverReplans(Dispatcher):
    """Forgets a job whose task was cancelled: no retry, no report; the robot is freed for other jobs."""

    def task_cancelled(self, robot: str, trip: Trip, reason: str) -> None:
        self.release(robot)


class ForgetsMotionFailures(Dispatcher):
    """Re-plans after every cancel but a ``motion_failed`` one (docs/contract.md §4): that job is forgotten."""

    def task_cancelled(self, robot: str, trip: Trip, reason: str) -> None:
        if reason == "motion_failed":
            self.release(robot)
        else:
            super().task_cancelled(robot, trip, reason)


class Raising(Dispatcher):
    """A bug in one hook: raises on the first job."""

    def on_job(self, job: object) -> None:
        raise RuntimeError("my bug")


class Exiting(Dispatcher):
    """A manager that ends its process on the first job (``sys.exit`` in a hook)."""

    def on_job(self, job: object) -> None:
        raise SystemExit(3)


class GiveUp(FleetManager):
    """Reports every job failed as it arrives (issue 29 item 6): no task, no evidence."""

    def on_job(self, job: Job) -> None:
        self.handle.job_failed(job, "unassignable")


class NeverSends(FleetManager):
    """Takes every job and does nothing with it: no task is ever sent, no job ever ends."""


class GivesUpAfterThePickup(Dispatcher):
    """Reports a job failed as soon as its pickup completed: a task was sent for it, and none failed."""

    def task_completed(self, robot: str, trip: Trip) -> None:
        self.handle.job_failed(trip.job, "cancelled")
        self.release(robot)
