"""The fleet-manager interface (SPEC §9): what users subclass, and the handle their manager acts through.

Modelled on SimPy's process functions and pytest's hooks: a few methods with plain arguments, no
framework to learn. vcran calls three hooks on a :class:`FleetManager`:

* :meth:`~FleetManager.on_start` once, before anything else, with ``self.fleet`` and ``self.handle`` set;
* :meth:`~FleetManager.on_job` when a job of the scenario's workload reaches the manager;
* :meth:`~FleetManager.on_update` for every update of a robot's attribute that Orion would notify:
  ``current_motion``, ``assignment_state``, ``ran_status``, ``ran_error``, ``robot_description``.

The manager acts through its :class:`Handle`: it writes motion and action assignments and cancels (the
messages of SPEC §2), schedules callbacks of its own, reads what Orion holds, draws from a seeded random
generator and reports jobs done or failed. It never sees RanLogic's insides. The same manager object
runs in simulated time (:func:`vcran.simulate`, the handle of :mod:`vcran.sim.loop`) and against a real
Orion in wall-clock time: only the handle differs. Everything here is pure (no SimPy, no clock).
"""

from __future__ import annotations

import json
import math
import numbers
import random
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any, ClassVar, NoReturn

from vcran.core import build
from vcran.core.ids import Id
from vcran.core.jobs import JobBook
from vcran.core.messages import INBOUND, ActionKind, Message, Motion
from vcran.core.scenario import Job, LinkSettings, RobotConfig, Scenario, Settings, StationConfig
from vcran.core.traffic.roadmap import Roadmap

#: Inbound message type -> the attribute it is written to.
ATTRIBUTE_OF: dict[type[Message], str] = {cls: name for name, cls in INBOUND.items()}


class ReadOnlyDict(dict[str, float]):
    """A dict that refuses every write: the fleet's ``settings.durations`` (SPEC §9). A dict still, so the
    fleet pickles, deep-copies (a copy read-only too), goes to ``json.dumps`` and ``dataclasses.asdict`` as
    before it was read-only, which a ``MappingProxyType`` could not; ``dict(d)`` is a copy one may change."""

    def _refuse(self, *_args: Any, **_kwargs: Any) -> NoReturn:
        raise TypeError("the fleet is read-only: its settings.durations does not support item assignment "
                        "(dict(self.fleet.settings.durations) is a copy you may change)")

    __setitem__ = __delitem__ = __ior__ = _refuse  # type: ignore[assignment]
    clear = pop = popitem = setdefault = update = _refuse  # type: ignore[assignment]

    def __reduce__(self) -> tuple[type[ReadOnlyDict], tuple[dict[str, float]]]:
        return type(self), (dict(self),)  # not dict's own, which refills the copy item by item


@dataclass(frozen=True)
class Fleet:
    """What a fleet manager is told at the start: the robots, the stations, the settings, the link, and the
    roadmap robots drive on (SPEC §12; None: none, robots drive anywhere)."""

    robots: tuple[RobotConfig, ...]
    stations: tuple[StationConfig, ...]
    settings: Settings
    link: LinkSettings
    roadmap: Roadmap | None = None
    _robots: dict[str, RobotConfig] = field(init=False, repr=False, compare=False)
    _stations: dict[str, StationConfig] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "_robots", {r.id: r for r in self.robots})
        object.__setattr__(self, "_stations", {s.id: s for s in self.stations})

    @classmethod
    def of(cls, scenario: Scenario) -> Fleet:
        """The scenario's fleet, read-only: its one mutable part, ``settings.durations``, is the model's
        too, so a manager writing to it changed the simulated actions and the caller's scenario."""
        durations = ReadOnlyDict(scenario.settings.durations)
        return cls(scenario.robots, scenario.stations, replace(scenario.settings, durations=durations), scenario.link,
                   scenario.roadmap)

    @property
    def robot_ids(self) -> tuple[str, ...]:
        return tuple(self._robots)

    def robot(self, robot_id: str) -> RobotConfig:
        try:
            return self._robots[robot_id]
        except KeyError:
            raise KeyError(f"no robot {robot_id!r} in this fleet") from None

    def station(self, station_id: str) -> StationConfig:
        try:
            return self._stations[station_id]
        except KeyError:
            raise KeyError(f"no station {station_id!r} in this fleet") from None

    def dock(self, station_id: str) -> tuple[float, float, float | None]:
        """Where a robot stands to load or unload at a station: its ``dock``, else its position."""
        s = self.station(station_id)
        return s.dock if s.dock is not None else (s.position[0], s.position[1], None)


class Timer:
    """A callback scheduled with :meth:`Handle.call_at`; :meth:`cancel` stops it if it has not run."""

    __slots__ = ("when", "cancelled")

    def __init__(self, when: float) -> None:
        self.when = when
        self.cancelled = False

    def cancel(self) -> None:
        self.cancelled = True


class Handle:
    """How a fleet manager acts on the fleet. Subclasses (simulated, live) provide the four primitives
    :attr:`now`, :meth:`_write`, :meth:`call_at` and :meth:`latest`; everything else is built on them.

    ``random`` is seeded from the scenario (``random.Random("manager:{seed}")``): draw from it, never
    from the global generator, and a run stays byte-identical (SPEC §5).
    """

    def __init__(self, fleet: Fleet, jobs: JobBook, rng: random.Random, task_prefix: str = "task_") -> None:
        self.fleet = fleet
        self.random = rng
        self._jobs = jobs
        self._task_prefix = task_prefix
        self._tasks_sent = 0

    # --- primitives --------------------------------------------------------------------------------------

    @property
    def now(self) -> float:
        """The current simulated time, in seconds."""
        raise NotImplementedError

    def _write(self, robot: str, attribute: str, message: Message | None, raw: Any = None) -> None:
        """Write ``attribute`` of ``robot``'s entity (``message``, or ``raw`` NGSI JSON)."""
        raise NotImplementedError

    def call_at(self, when: float, fn: Callable[..., Any], *args: Any, **kwargs: Any) -> Timer:
        """Call ``fn(*args, **kwargs)`` at simulated time ``when`` (not before :attr:`now`)."""
        raise NotImplementedError

    def latest(self, robot: str, attribute: str) -> Message | None:
        """The latest value of ``robot``'s ``attribute`` that has reached the manager (what Orion holds,
        as far as the manager can know), or None before the first one."""
        raise NotImplementedError

    # --- built on them -----------------------------------------------------------------------------------

    def call_later(self, delay: float, fn: Callable[..., Any], *args: Any, **kwargs: Any) -> Timer:
        """Call ``fn(*args, **kwargs)`` ``delay`` seconds from now."""
        if delay < 0:
            raise ValueError(f"negative delay {delay}")
        if not math.isfinite(delay):  # NaN passes the test above; inf would never run
            raise ValueError(f"call_later: the delay must be a finite number of seconds, got {delay}")
        return self.call_at(self.now + delay, fn, *args, **kwargs)

    def send(self, robot: str, message: Message) -> None:
        """Write a MotionAssignment, ActionAssignment or CancelTask to ``robot`` (SPEC §2)."""
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
        it), ``actions`` a list of ``"load"``, ``"unload"``, ``"dummy"``, ``"charge"`` (SPEC §4). The task is named ``task``, or
        ``task_1``, ``task_2``, ... in the order sent; its motions ``{task}_m1``, ... and actions
        ``{task}_a1``, ... carry sequence numbers ``1..length`` (:func:`vcran.core.build.task`). With
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

    def job_done(self, job: Job | str) -> None:
        """Report ``job`` completed (a ``job_completed`` event; its lead time ends now)."""
        self._jobs.completed(self.now, job)

    def job_failed(self, job: Job | str, reason: str) -> None:
        """Report ``job`` failed for ``reason`` (a ``job_failed`` event); use one of
        :data:`vcran.core.jobs.FAILURE_REASONS` where one fits (``"timeout"``, ``"action_failed"``, ...)."""
        if not isinstance(reason, str):  # it is written to events.jsonl and JobRecord.reason as a string
            raise TypeError(f"job_failed: reason must be a string, got {type(reason).__name__}")
        self._jobs.failed(self.now, job, reason)

    def _robot(self, robot: str) -> str:
        self.fleet.robot(robot)  # a write to an entity Orion does not hold fails (Orion answers 404)
        return robot


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


class FleetManager:
    """Subclass this and override the hooks you need; the defaults do nothing.

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

    fleet: Fleet
    handle: Handle

    def on_start(self) -> None:
        """The run starts (simulated time 0): ``self.fleet`` and ``self.handle`` are set."""

    def on_job(self, job: Job) -> None:
        """``job`` has arrived: it is the manager's to assign (and to report done or failed)."""

    def on_update(self, robot: str, attribute: str, message: Message, t: float) -> None:
        """Orion notified a new value of ``robot``'s ``attribute``, decoded, at simulated time ``t`` (and
        every periodic write of ``robot_description``, unchanged: live mode forces it through Orion)."""

    def _bind(self, fleet: Fleet, handle: Handle) -> None:
        self.fleet, self.handle = fleet, handle
