"""OPIL's fleet manager (docs/contract.md §9): :class:`FleetManager`, what users subclass, and :class:`OpilHandle`, what it acts through.

On top of the shared hooks (:class:`vcran.core.manager.Manager`: ``on_start``, ``on_job``) vcran calls
:meth:`~FleetManager.on_update` for every update of a robot's attribute that Orion would notify:
``current_motion``, ``assignment_state``, ``ran_status``, ``ran_error``, ``robot_description``,
``battery_state``. The manager acts through its :class:`OpilHandle`: it writes motion and action
assignments and cancels (the messages of docs/contract.md §2), reads what Orion holds, and has the shared handle's
time, timers, random generator and job reports. It never sees RanLogic's insides. The same manager
object runs in simulated time (:func:`vcran.simulate`, :mod:`vcran.sim.opil.loop`) and against a real
Orion in wall-clock time (``vcran manage``): only the handle's primitives differ. Pure, like the core.
"""

from __future__ import annotations

import json
import math
import numbers
import random
from collections.abc import Sequence
from typing import Any, ClassVar

from vcran.core.jobs import JobBook
from vcran.core.manager import Fleet, Handle, Manager
from vcran.core.opil import build
from vcran.core.opil.ids import Id
from vcran.core.opil.messages import INBOUND, ActionKind, Message, Motion
from vcran.core.scenario import Job

#: Inbound message type -> the attribute it is written to.
ATTRIBUTE_OF: dict[type[Message], str] = {cls: name for name, cls in INBOUND.items()}


class OpilHandle(Handle):
    """How an OPIL fleet manager acts on the fleet (``vcran.Handle``). Subclasses provide, besides the
    shared primitives :attr:`now` and :meth:`call_at`, the two of OPIL: :meth:`_write` and :meth:`latest`;
    everything else is built on them.
    """

    def __init__(self, fleet: Fleet, jobs: JobBook, rng: random.Random, task_prefix: str = "task_") -> None:
        super().__init__(fleet, jobs, rng)
        self._task_prefix = task_prefix
        self._tasks_sent = 0

    # --- primitives --------------------------------------------------------------------------------------

    def _write(self, robot: str, attribute: str, message: Message | None, raw: Any = None) -> None:
        """Write ``attribute`` of ``robot``'s entity (``message``, or ``raw`` NGSI JSON)."""
        raise NotImplementedError

    def latest(self, robot: str, attribute: str) -> Message | None:
        """The latest value of ``robot``'s ``attribute`` that has reached the manager (what Orion holds,
        as far as the manager can know), or None before the first one."""
        raise NotImplementedError

    # --- built on them -----------------------------------------------------------------------------------

    def send(self, robot: str, message: Message) -> None:
        """Write a MotionAssignment, ActionAssignment or CancelTask to ``robot`` (docs/contract.md §2)."""
        attribute = ATTRIBUTE_OF.get(type(message))
        if attribute is None:
            known = ", ".join(c.__name__ for c in ATTRIBUTE_OF)
            raise TypeError(f"a fleet manager sends {known}; got {type(message).__name__}")
        self._write(self._robot(robot), attribute, message)

    def send_raw(self, robot: str, attribute: str, value: Any) -> None:
        """Write an NGSI attribute as JSON, decoded (and maybe rejected, R12) by the RAN like a live one."""
        if attribute not in INBOUND:
            raise ValueError(f"unknown inbound attribute {attribute!r}; known: {', '.join(INBOUND)}")
        try:  # what no Orion client can send (the live one refuses NaN too): refused here, in the hook
            json.dumps(value, allow_nan=False)
        except (TypeError, ValueError) as exc:
            raise type(exc)(f"send_raw: the value is not JSON: {exc}") from None
        self._write(self._robot(robot), attribute, None, value)

    def cancel(self, robot: str, task: Id | str) -> None:
        """Cancel a whole task on ``robot`` (R8)."""
        self.send(robot, build.cancel(task))

    def send_task(
        self,
        robot: str,
        path: Sequence[build.PathPoint],
        actions: Sequence[str | ActionKind] = (),
        *,
        task: str | None = None,
        job: Job | str | None = None,
        max_velocity: float = 0.0,
        every: float = 0.0,
    ) -> Id:
        """Send a whole OPIL task to ``robot`` and return its id.

        ``path`` is a list of ``(x, y)`` or ``(x, y, theta)`` points (a theta on the last one: end facing
        it), ``actions`` a list of ``"load"``, ``"unload"``, ``"dummy"``, ``"charge"`` (docs/contract.md §4). The task is named ``task``, or
        ``task_1``, ``task_2``, ... in the order sent; its motions ``{task}_m1``, ... and actions
        ``{task}_a1``, ... carry sequence numbers ``1..length`` (:func:`vcran.core.opil.build.task`). With
        ``every`` > 0 the messages go out that many seconds apart (under polling, a write overwritten
        before the RAN reads it is lost). ``job`` records the task as work for that job (a
        ``job_assigned`` event; the job's robot becomes ``robot``).
        """
        self._robot(robot)
        path, actions = _check_task(path, actions)
        if not (every >= 0 and math.isfinite(every)):  # refused before the first message goes out, not after
            raise ValueError(f"send_task: every must be a finite number of seconds >= 0, got {every}")
        name = task if task is not None else f"{self._task_prefix}{self._tasks_sent + 1}"
        messages = build.task(name, path, actions, max_velocity=max_velocity, stamp=self.now, every=every)
        if job is not None:
            self._jobs.assigned(self.now, job, robot, name)
        self._tasks_sent += 1  # only for a task that goes out: a refused one leaves the numbering as it was
        for k, message in enumerate(messages):
            if k == 0 or every == 0:
                self.send(robot, message)
            else:
                self.call_at(self.now + k * every, self.send, robot, message)
        return messages[0].task_id

    def pose(self, robot: str) -> tuple[float, float, float]:
        """``robot``'s latest known pose ``(x, y, theta)``: from ``current_motion``, or its start pose."""
        motion = self.latest(self._robot(robot), "current_motion")
        if isinstance(motion, Motion):
            p = motion.current_position.pose
            return p.position.x, p.position.y, p.orientation.yaw()
        return self.fleet.robot(robot).pose


def _check_task(path: Any, actions: Any) -> tuple[list[Any], list[Any]]:
    """The points of ``path``, each ``(x, y)`` or ``(x, y, theta)``, and the action names, as lists, or a
    clear error naming what is wrong: the task builder would fail deep inside ('tuple index out of range'),
    or take a string apart letter by letter ("'l' is not a valid ActionKind"). Lists, so that any iterable
    of points is a path: a numpy array (whose truth value the builder asked for), a generator (which the
    check here would have used up)."""
    if isinstance(path, str | bytes):
        raise TypeError(f"send_task: path is a list of points (x, y) or (x, y, theta), got the string {path!r}")
    if isinstance(actions, str | bytes):
        raise TypeError(f"send_task: actions is a list of action names, e.g. ['load']; got the string {actions!r}")
    points, kinds = list(path), list(actions)
    for k, point in enumerate(points):
        if not _is_point(point):
            raise ValueError(f"send_task: path[{k}]: expected (x, y) or (x, y, theta), got {point!r}")
    return points, kinds


def _is_point(point: Any) -> bool:
    """Two or three coordinates (a tuple, a list, a numpy row), numbers all but a theta of None."""
    if isinstance(point, str | bytes) or not hasattr(point, "__getitem__") or not hasattr(point, "__len__"):
        return False
    n = len(point)
    return n in (2, 3) and _is_number(point[0]) and _is_number(point[1]) and (n == 2 or point[2] is None
                                                                              or _is_number(point[2]))


def _is_number(value: Any) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


class FleetManager(Manager):
    """An OPIL fleet manager (``vcran.FleetManager``): subclass this and override the hooks you need; the
    defaults do nothing.

    vcran sets :attr:`fleet` and :attr:`handle` before it calls :meth:`on_start`. Hooks run at simulated
    instants in a documented order (docs/determinism.md) and must not block: to wait, schedule a
    callback with ``self.handle.call_later``. :attr:`attributes` says which attributes' updates reach
    :meth:`on_update` (an Orion subscription's attribute list); every update still refreshes
    ``self.handle.latest``. The default is every attribute except ``current_motion``, which each robot
    publishes every second: read positions with ``self.handle.pose(robot)`` when you need them.
    """

    #: Attributes whose updates call :meth:`on_update`; None: all of them.
    attributes: ClassVar[frozenset[str] | None] = frozenset(
        {"assignment_state", "ran_status", "ran_error", "robot_description", "battery_state"})

    handle: OpilHandle

    def on_update(self, robot: str, attribute: str, message: Message, t: float) -> None:
        """Orion notified a new value of ``robot``'s ``attribute``, decoded, at simulated time ``t`` (and
        every periodic write of ``robot_description``, unchanged: live mode forces it through Orion)."""
