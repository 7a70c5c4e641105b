"""The reference fleet manager: a plain dispatcher (docs/contract.md §9). docs/loop.md walks through it.

* Jobs wait in a queue: higher ``priority`` first, then in arrival order (plain FIFO when no job has a
  priority).
* Whenever a job waits and a robot is idle, the job at the head goes to the idle robot nearest (in a
  straight line, from its latest known pose) to the job's pickup; a tie goes to the robot listed first.
* A job is two OPIL tasks on that robot: drive to the pickup's dock and ``load``; when that task has
  completed, drive to the drop-off's dock and ``unload``. When the second completes, the job is done.
* How a task ended comes from the robot's ``ran_status``: the ids of recently completed tasks, and of
  cancelled ones with the reason (``timeout``, ``action_failed``, ``cancelled``; docs/contract.md §4's
  ``motion_failed``, ``collision``, ``battery_empty``).
* A cancelled task costs the job one try. The retry waits ``retry_after`` seconds, doubled for each
  further try (10, 20, 40 s by default): a pickup at an empty station fails within seconds, and
  retrying at once would burn every try before the station produces a part. A failed pickup frees the
  robot at once (it may take other jobs meanwhile) and puts the job back in the queue at its old place
  when the wait is over. A cancelled task moved no part (docs/contract.md §4: a failed load or unload moves nothing):
  a failed drop-off leaves the part on board, so it is sent again to the same robot. After ``max_tries``
  cancelled tasks the job is reported failed.
* Batteries (docs/contract.md §4): a robot without a job whose published charge is below ``charge_below`` (a
  fraction) drives to the nearest ``charger`` station and charges to full instead of taking jobs. A
  robot on a job finishes it first. A robot that ran empty is out of service until its battery is
  swapped (a ``battery_state`` update at or above ``charge_below`` again): its pickup goes back to the queue,
  and its drop-off waits for the swap (the part is on board), or fails ``battery_empty`` at once when
  the robot's battery is never swapped. A task refused because the robot was already out of service
  (a ``ran_error`` ``battery_empty`` naming it) counts as cancelled ``battery_empty``.
* Only robots configured to ``load`` and ``unload`` get jobs. A job that no robot can ever take (none is
  so configured, or each ran empty and is never swapped) is reported failed ``unassignable`` when it
  would be dispatched: on arrival, or when its back-off ends.
* A robot with a part on board (``ran_status``'s ``carrying``) is never sent to pick up. A part it could
  not deliver (its drop-off failed ``max_tries`` times, or it started loaded) is returned first: unloaded
  at the station nearest to the robot that has not refused it (chargers and the failed drop-off left out),
  one task each (``return{n}_{robot}``); when every station refused it, the robot keeps it and takes no
  more jobs (an operator must unload it).
* Routing (docs/contract.md §12): with ``routing = "roadmap"`` (the default, ``"auto"``, when the scenario has a
  roadmap) robots drive the roadmap's shortest routes under node reservations, one task per stretch
  (:mod:`vcran.managers.routing`); ``"straight"`` sends them straight to the dock, as without a roadmap,
  to show what goes wrong in traffic.
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Callable
from dataclasses import dataclass

from vcran.core.opil.ids import Id
from vcran.core.opil.manager import FleetManager
from vcran.core.opil.messages import BatteryState, Message, RanStatus
from vcran.core.scenario import Job
from vcran.managers.routing import BATTERY_EMPTY, COMPLETED, Router, task_outcome

PICKUP, DROPOFF = "pick", "drop"
UNASSIGNABLE = "unassignable"
ROUTINGS = ("auto", "roadmap", "straight")
Point = tuple[float, float, float | None]  # x, y, theta (a pose, or a dock)


@dataclass(slots=True)
class Trip:
    """A job on its way: which phase it is in, the task running for it, and how many tasks it lost."""

    job: Job
    arrival: int
    phase: str = PICKUP
    task: Id | str | None = None  # on a roadmap, the name of the router's errand
    tries: int = 0

    @property
    def order(self) -> tuple[int, int]:
        return -self.job.priority, self.arrival


class Dispatcher(FleetManager):
    """FIFO jobs, nearest idle robot, re-planning after a cancelled task (with back-off), failure after
    ``max_tries``, charging below ``charge_below``, routes on the roadmap (``routing``)."""

    attributes = frozenset({"ran_status", "ran_error", "battery_state", "assignment_state"})

    def __init__(self, max_tries: int = 3, retry_after: float = 10.0, charge_below: float = 0.3,
                 routing: str = "auto") -> None:
        if max_tries < 1:
            raise ValueError(f"max_tries must be at least 1, got {max_tries}")
        if retry_after < 0:
            raise ValueError(f"retry_after must not be negative, got {retry_after}")
        if not 0.0 <= charge_below < 1.0:
            raise ValueError(f"charge_below is a fraction of capacity in [0, 1), got {charge_below}")
        if routing not in ROUTINGS:
            raise ValueError(f"routing is one of {', '.join(ROUTINGS)}; got {routing!r}")
        self.max_tries, self.retry_after, self.charge_below = max_tries, retry_after, charge_below
        self.routing = routing

    def on_start(self) -> None:
        self.queue: list[Trip] = []                      # jobs waiting for a robot, head first
        self.movers = [r for r in self.fleet.robot_ids if self.fleet.robot(r).moves_parts]  # may get jobs
        self.load = {r: self.fleet.robot(r).carrying for r in self.fleet.robot_ids}  # parts on board, as published
        self.idle: list[str] = [r for r in self.movers if not self.load[r]]  # robots without a job, fleet order
        self.trips: dict[str, Trip] = {}                 # robot -> the job it works on
        self._rank = {robot: i for i, robot in enumerate(self.fleet.robot_ids)}
        self._arrivals = 0
        self.chargers = [s.id for s in self.fleet.stations if s.charger]
        self.charging: dict[str, Id | str] = {}          # robot -> its charge task
        self.out: set[str] = set()                       # robots whose battery ran empty, until swapped
        self.level: dict[str, float] = {}                # robot -> its latest published percentage
        self._charges = 0
        self.returning: dict[str, tuple[str, Id | str]] = {}  # robot -> (station, task) returning a part there
        self.refused: dict[str, set[str]] = {}           # robot -> stations that refused the part it carries
        self.keeping: set[str] = set()                   # robots keeping a part no station took
        self._returns = 0
        if self.routing == "roadmap" or (self.routing == "auto" and self.fleet.roadmap is not None):
            self.router: Router | None = Router(self.fleet, self.handle, self.free)
        else:
            self.router = None
        for robot in self.movers:
            if self.load[robot]:
                self.return_part(robot)

    def on_job(self, job: Job) -> None:
        self._arrivals += 1
        bisect.insort(self.queue, Trip(job, self._arrivals), key=lambda trip: trip.order)
        self.dispatch()

    def on_update(self, robot: str, attribute: str, message: Message, t: float) -> None:
        if isinstance(message, BatteryState):
            self.battery_changed(robot, message.percentage)
            return
        if isinstance(message, RanStatus):
            self.load[robot] = message.carrying
        trip = self.trips.get(robot)
        if self.router is not None:
            outcome = self.router.update(robot, message)  # the errand's, and the robot's progress on the way
        else:
            task = trip.task if trip is not None else self.charging.get(robot) or self.returning.get(robot, ("", None))[1]
            outcome = task_outcome(message, task) if isinstance(task, Id) else None
        if outcome is None:
            return
        if robot in self.returning:
            self.return_ended(robot, outcome)
        elif trip is None:
            self.charge_ended(robot, outcome)
        elif outcome == COMPLETED:
            self.task_completed(robot, trip)
        else:
            self.task_cancelled(robot, trip, outcome)

    # --- decisions ----------------------------------------------------------------------------------------

    def dispatch(self) -> None:
        """Give waiting jobs to idle robots, head of the queue first; when no robot is left that could ever
        take them, report them failed (``unassignable``)."""
        if self.queue and all(self.lost(robot) for robot in self.movers):
            for trip in self.queue:
                self.handle.job_failed(trip.job, UNASSIGNABLE)
            self.queue.clear()
        while self.queue and self.idle:
            trip = self.queue.pop(0)
            robot = self.nearest_idle(trip.job.pickup)
            self.idle.remove(robot)
            self.trips[robot] = trip
            self.send(robot, trip)

    def nearest_idle(self, station: str) -> str:
        """The idle robot nearest to ``station``'s dock; of equals, the robot listed first."""
        return _nearest(self.idle, self.fleet.dock(station), self.handle.pose)

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
        if reason == BATTERY_EMPTY:
            self.out.add(robot)
        stranded = trip.phase == DROPOFF and self.lost(robot)
        if trip.tries >= self.max_tries or stranded:
            self.handle.job_failed(trip.job, reason)  # the last task's reason; the event counts the tasks
            if trip.phase == DROPOFF:
                self.refused[robot] = {trip.job.dropoff}  # the part, still on board, is returned elsewhere
            self.release(robot)
            return
        wait = self.retry_after * 2 ** (trip.tries - 1)
        if trip.phase == DROPOFF:
            if robot not in self.out:  # else it goes when the battery is swapped (battery_changed)
                self.handle.call_later(wait, self.send, robot, trip)  # the robot still carries the part
        else:
            self.release(robot)
            self.handle.call_later(wait, self.requeue, trip)

    def battery_changed(self, robot: str, percentage: float) -> None:
        """A ``battery_state`` update: an idle robot running low goes to charge; an empty one swapped is back."""
        self.level[robot] = percentage
        if robot in self.out:
            if percentage >= self.charge_below:  # swapped for a charged battery
                self.out.discard(robot)
                if self.router is not None:
                    self.router.resume(robot)  # drives on to the end of the route it stopped on
                trip = self.trips.get(robot)
                if trip is not None:
                    self.send(robot, trip)  # the drop-off that waited for the swap
                else:
                    self.available(robot)
        elif robot in self.idle and self.low(robot) and self.chargers:
            self.idle.remove(robot)
            self.charge(robot)

    def charge_ended(self, robot: str, outcome: str) -> None:
        """Full (or the charge failed: then back to work, and to a charger again when next free and low)."""
        del self.charging[robot]
        if outcome == BATTERY_EMPTY:
            self.out.add(robot)  # ran empty on the way: back when swapped
        elif outcome == COMPLETED:
            self.available(robot)
        else:
            self.idle_again(robot)

    def low(self, robot: str) -> bool:
        return self.level.get(robot, 1.0) < self.charge_below

    def return_ended(self, robot: str, outcome: str) -> None:
        """The part went back (the robot may work again), or that station refused it: the next one."""
        station, _ = self.returning.pop(robot)
        if outcome == COMPLETED:
            self.refused.pop(robot, None)
        elif outcome == BATTERY_EMPTY:
            self.out.add(robot)  # it tries again when its battery is swapped
            return
        else:
            self.refused.setdefault(robot, set()).add(station)
        self.available(robot)

    def lost(self, robot: str) -> bool:
        """Out of service for good: its battery ran empty and is never swapped."""
        battery = self.fleet.robot(robot).battery
        return robot in self.out and (battery is None or battery.swap_after is None)

    def free(self, robot: str) -> bool:
        """The robot has no work of the Dispatcher's (the router may park it out of the way)."""
        return not (robot in self.trips or robot in self.charging or robot in self.returning or robot in self.out)

    def requeue(self, trip: Trip) -> None:
        """``trip``'s wait after a failed pickup is over: back in the queue at its old place."""
        bisect.insort(self.queue, trip, key=lambda t: t.order)
        self.dispatch()

    # --- actions ------------------------------------------------------------------------------------------

    def go(self, robot: str, station: str, action: str, name: str, job: Job | None = None) -> Id | str:
        """Send ``robot`` to ``station``'s dock to perform ``action`` there: one task straight to the dock,
        or the router's errand along the roadmap (one task per stretch); the task's id, or the errand's name."""
        if self.router is None:
            return self.handle.send_task(robot, [self.fleet.dock(station)], [action], task=name, job=job)
        self.router.go(robot, station, action, name, job)
        return name

    def send(self, robot: str, trip: Trip) -> None:
        """One errand for the trip's phase: to the station's dock, then load or unload there."""
        station, action = (trip.job.pickup, "load") if trip.phase == PICKUP else (trip.job.dropoff, "unload")
        trip.task = self.go(robot, station, action, f"{trip.job.id}_{trip.phase}{trip.tries + 1}", trip.job)

    def charge(self, robot: str) -> None:
        """Send ``robot`` to the charger nearest to it, to charge to full."""
        self._charges += 1
        station = _nearest(self.chargers, self.handle.pose(robot), self.fleet.dock)
        self.charging[robot] = self.go(robot, station, "charge", f"charge{self._charges}_{robot}")

    def return_part(self, robot: str) -> None:
        """Unload the part on board at the station nearest to ``robot`` that has not refused it; none left:
        the robot keeps it and takes no more jobs."""
        refused = self.refused.get(robot, set())
        stations = [s.id for s in self.fleet.stations if not s.charger and s.id not in refused]
        if not stations:
            self.keeping.add(robot)  # an operator must unload it; the jobs wait for the other robots
            return
        self._returns += 1
        station = _nearest(stations, self.handle.pose(robot), self.fleet.dock)
        self.returning[robot] = station, self.go(robot, station, "unload", f"return{self._returns}_{robot}")

    def release(self, robot: str) -> None:
        """``robot`` has no job any more."""
        del self.trips[robot]
        self.available(robot)

    def available(self, robot: str) -> None:
        """``robot`` is free: to a charger when its battery is low, else idle; nothing while it is empty."""
        if robot in self.out:
            return
        if self.low(robot) and self.chargers:
            self.charge(robot)
        else:
            self.idle_again(robot)

    def idle_again(self, robot: str) -> None:
        """Back among the idle ones (in fleet order), and maybe the next job; a part on board goes back first."""
        if self.load[robot]:
            self.return_part(robot)
            return
        bisect.insort(self.idle, robot, key=self._rank.__getitem__)
        self.dispatch()
        if self.router is not None:
            self.router.advance()  # an idle robot in another's way is parked


def _nearest(candidates: list[str], point: Point, where: Callable[[str], Point]) -> str:
    """The candidate whose place is nearest to ``point`` in a straight line (min keeps the first of equals)."""
    return min(candidates, key=lambda c: math.hypot(where(c)[0] - point[0], where(c)[1] - point[1]))

