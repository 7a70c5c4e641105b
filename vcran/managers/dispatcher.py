"""The reference fleet manager: a plain dispatcher (SPEC §9). docs/loop.md walks through it.

* Jobs wait in a queue: higher ``priority`` first, then in arrival order (plain FIFO when no job has a
  priority).
* Whenever a job waits and a robot is idle, the job at the head goes to the idle robot nearest (in a
  straight line, from its latest known pose) to the job's pickup; a tie goes to the robot listed first.
* A job is two OPIL tasks on that robot: drive to the pickup's dock and ``load``; when that task has
  completed, drive to the drop-off's dock and ``unload``. When the second completes, the job is done.
* How a task ended comes from the robot's ``ran_status``: the ids of recently completed tasks, and of
  cancelled ones with the reason (``timeout``, ``action_failed``, ``cancelled``, ...).
* A cancelled task costs the job one try. The retry waits ``retry_after`` seconds, doubled for each
  further try (10, 20, 40 s by default): a pickup at an empty station fails within seconds, and
  retrying at once would burn every try before the station produces a part. A failed pickup frees the
  robot at once (it may take other jobs meanwhile) and puts the job back in the queue at its old place
  when the wait is over; a failed drop-off is sent again to the same robot, which still carries the
  part. After ``max_tries`` cancelled tasks the job is reported failed.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass

from vcran.core.ids import Id
from vcran.core.manager import FleetManager
from vcran.core.messages import Message, RanStatus
from vcran.core.scenario import Job

PICKUP, DROPOFF = "pick", "drop"


@dataclass(slots=True)
class Trip:
    """A job on its way: which phase it is in, the task running for it, and how many tasks it lost."""

    job: Job
    arrival: int
    phase: str = PICKUP
    task: Id | None = None
    tries: int = 0

    @property
    def order(self) -> tuple[int, int]:
        return -self.job.priority, self.arrival


class Dispatcher(FleetManager):
    """FIFO jobs, nearest idle robot, re-planning after a cancelled task (with back-off), failure after
    ``max_tries``."""

    attributes = frozenset({"ran_status"})

    def __init__(self, max_tries: int = 3, retry_after: float = 10.0) -> None:
        if max_tries < 1:
            raise ValueError(f"max_tries must be at least 1, got {max_tries}")
        if retry_after < 0:
            raise ValueError(f"retry_after must not be negative, got {retry_after}")
        self.max_tries, self.retry_after = max_tries, retry_after

    def on_start(self) -> None:
        self.queue: list[Trip] = []                      # jobs waiting for a robot, head first
        self.idle: list[str] = list(self.fleet.robot_ids)  # robots without a job, in fleet order
        self.trips: dict[str, Trip] = {}                 # robot -> the job it works on
        self._rank = {robot: i for i, robot in enumerate(self.fleet.robot_ids)}
        self._arrivals = 0

    def on_job(self, job: Job) -> None:
        self._arrivals += 1
        bisect.insort(self.queue, Trip(job, self._arrivals), key=lambda trip: trip.order)
        self.dispatch()

    def on_update(self, robot: str, attribute: str, message: Message, t: float) -> None:
        trip = self.trips.get(robot)
        if trip is None or trip.task is None or not isinstance(message, RanStatus):
            return
        if trip.task in message.completed:
            self.task_completed(robot, trip)
            return
        for ended in message.cancelled:
            if ended.task_id == trip.task:
                self.task_cancelled(robot, trip, ended.reason)
                return

    # --- decisions ----------------------------------------------------------------------------------------

    def dispatch(self) -> None:
        """Give waiting jobs to idle robots, head of the queue first."""
        while self.queue and self.idle:
            trip = self.queue.pop(0)
            robot = self.nearest_idle(trip.job.pickup)
            self.idle.remove(robot)
            self.trips[robot] = trip
            self.send(robot, trip)

    def nearest_idle(self, station: str) -> str:
        x, y, _ = self.fleet.dock(station)

        def distance(robot: str) -> float:
            rx, ry, _ = self.handle.pose(robot)
            return math.hypot(rx - x, ry - y)

        return min(self.idle, key=distance)  # min keeps the first of equals: the robot listed first

    def task_completed(self, robot: str, trip: Trip) -> None:
        if trip.phase == PICKUP:
            trip.phase = DROPOFF
            self.send(robot, trip)
        else:
            self.handle.job_done(trip.job)
            self.release(robot)

    def task_cancelled(self, robot: str, trip: Trip, reason: str) -> None:
        trip.tries += 1
        trip.task = None
        if trip.tries >= self.max_tries:
            self.handle.job_failed(trip.job, reason)  # the last task's reason; the event counts the tasks
            self.release(robot)
            return
        wait = self.retry_after * 2 ** (trip.tries - 1)
        if trip.phase == DROPOFF:
            self.handle.call_later(wait, self.send, robot, trip)  # the robot still carries the part
        else:
            self.release(robot)
            self.handle.call_later(wait, self.requeue, trip)

    def requeue(self, trip: Trip) -> None:
        """``trip``'s wait after a failed pickup is over: back in the queue at its old place."""
        bisect.insort(self.queue, trip, key=lambda t: t.order)
        self.dispatch()

    # --- actions ------------------------------------------------------------------------------------------

    def send(self, robot: str, trip: Trip) -> None:
        """One task for the trip's phase: the path to the station's dock, then load or unload there."""
        station, action = (trip.job.pickup, "load") if trip.phase == PICKUP else (trip.job.dropoff, "unload")
        name = f"{trip.job.id}_{trip.phase}{trip.tries + 1}"
        trip.task = self.handle.send_task(robot, [self.fleet.dock(station)], [action], task=name, job=trip.job)

    def release(self, robot: str) -> None:
        """``robot`` has no job any more: back among the idle ones (in fleet order), and maybe the next job."""
        del self.trips[robot]
        bisect.insort(self.idle, robot, key=self._rank.__getitem__)
        self.dispatch()
