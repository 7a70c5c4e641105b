"""Build inbound messages from names and numbers: what scenario scripts, tests and users write.

Ids come from names through the stable mapping of :func:`vcran.core.opil.ids.id_for`. Actions are named by kind
(``"load"``, ``"unload"``, ``"dummy"``), encoded with OPIL's categories (10, 20, 5), which is what OPIL's
task planner sends, and ``"charge"``, vcran's extension (category 0, action 3; docs/contract.md §4); a raw
``(category, action)`` pair can be given instead.
"""

from __future__ import annotations

from collections.abc import Callable
from collections.abc import Sequence as Seq
from dataclasses import fields
from functools import lru_cache
from typing import Any, TypeVar

from vcran.core.opil.ids import NIL, NOT_SUPPORTED, Id, fresh_id, id_for
from vcran.core.opil.messages import (
    Accel,
    ActionAssignment,
    ActionKind,
    CancelTask,
    Header,
    Message,
    Motion,
    MotionAssignment,
    Point,
    PolygonStamped,
    Pose,
    Pose2D,
    PoseStamped,
    Quaternion,
    RobotAction,
    Sequence,
    Time,
    Twist,
    Vector3,
)
from vcran.core.slots import unchecked

_header = unchecked(Header)  # seq 0, a valid stamp and "" need no check
_motion_assignment = unchecked(MotionAssignment)
_action_assignment = unchecked(ActionAssignment)

#: The category each kind is sent with (OPIL ``RobotAction`` constants).
CATEGORY_OF: dict[ActionKind, int] = {ActionKind.DUMMY: 5, ActionKind.LOAD: 10, ActionKind.UNLOAD: 20, ActionKind.CHARGE: 200}


def motion(
    task: str | Id,
    name: str | Id,
    seq: int,
    length: int,
    x: float,
    y: float,
    theta: float = 0.0,
    *,
    use_orientation: bool = False,
    is_waypoint: bool | None = None,
    max_velocity: float = 0.0,
    max_acceleration: float = 0.0,
    area: list[tuple[float, float]] | None = None,
    stamp: float = 0.0,
    checked: bool = True,
) -> MotionAssignment:
    """A motion assignment; ``is_waypoint`` defaults to "not the task's last position" (give it
    explicitly for the last motion of a task that has actions: only the caller knows it is last).
    ``checked=False`` skips validation: for repetitions of values already checked once (script cycles)."""
    return (MotionAssignment if checked else _motion_assignment)(
        header=header_at(stamp),
        point_id=_id(name),
        task_id=_id(task),
        motion_id=_id(name),
        point=_pose(float(x), float(y), float(theta)),
        is_waypoint=(seq < length) if is_waypoint is None else is_waypoint,
        use_orientation=use_orientation,
        max_velocity=_twist(float(max_velocity)),
        max_acceleration=_accel(float(max_acceleration)),
        motion_area=_area(tuple(area or ())),
        sequence=_sequence(seq, length),
    )


_Part = TypeVar("_Part")


def _shared(maxsize: int) -> Callable[[Callable[..., _Part]], Callable[..., _Part]]:
    """Share the parts built from the same numbers, told apart by their text.

    ``lru_cache`` keys floats by value: -0.0 equals 0.0 and hashes alike, so it handed back a part built
    with the other sign. A point written as x = -0.0 became x = 0.0, or the reverse, depending on what
    had been built before in the process (another run of a sweep, say): an input changed and a run's
    outputs depending on its neighbours (docs/contract.md §5). ``repr`` tells every two floats apart."""

    def wrap(build: Callable[..., _Part]) -> Callable[..., _Part]:
        memo: dict[str, _Part] = {}

        def shared(*args: Any) -> _Part:
            key = repr(args)
            found = memo.get(key)
            if found is None:
                if len(memo) >= maxsize:
                    memo.clear()
                found = memo[key] = build(*args)
            return found

        return shared

    return wrap


# Messages are immutable, so the parts a script repeats (a cycle's points, limits, areas) are shared:
# building hours of generated assignments stays cheap.
@_shared(maxsize=4096)
def _pose(x: float, y: float, theta: float) -> Pose2D:
    return Pose2D(x, y, theta)


@_shared(maxsize=64)
def _twist(linear: float) -> Twist:
    return Twist(Vector3(linear, 0.0, 0.0), Vector3())


@_shared(maxsize=64)
def _accel(linear: float) -> Accel:
    return Accel(Vector3(linear, 0.0, 0.0), Vector3())


@_shared(maxsize=256)
def _area(points: tuple[tuple[float, float], ...]) -> PolygonStamped:
    return PolygonStamped.from_xy(points)


@lru_cache(maxsize=1024)
def _sequence(number: int, length: int) -> Sequence:
    return Sequence(number, length)


def action(
    task: str | Id,
    name: str | Id,
    seq: int,
    length: int,
    kind: str | ActionKind = ActionKind.DUMMY,
    *,
    category: int | None = None,
    code: int | None = None,
    description: str = "",
    checked: bool = True,
) -> ActionAssignment:
    """An action assignment by kind, or by raw ``category``/``code`` when either is given
    (``checked=False``: as for :func:`motion`)."""
    if category is None and code is None:
        category, code = CATEGORY_OF[ActionKind(kind)], 0
    return (ActionAssignment if checked else _action_assignment)(
        action_id=_id(name),
        task_id=_id(task),
        sequence=_sequence(seq, length),
        robot_action=_robot_action(category or 0, code or 0, description),
    )


@lru_cache(maxsize=256)
def _robot_action(category: int, code: int, description: str) -> RobotAction:
    return RobotAction(category, code, (), description)


def cancel(task: str | Id, *, motion: str | Id | None = None, action: str | Id | None = None) -> CancelTask:
    """A whole-task cancel as OPIL sends it (unused ids "not supported"), or a partial one if named."""
    unused = Id(NIL.uuid[:-1] + b"\x01", NOT_SUPPORTED)
    return CancelTask(
        task_id=_id(task),
        action_id=unused if action is None else _id(action),
        motion_id=unused if motion is None else _id(motion),
    )


#: A point of a task's path: ``(x, y)``, or ``(x, y, theta)`` where theta None means "any heading".
PathPoint = tuple[float, float] | tuple[float, float, float | None]


def task(
    name: str,
    path: Seq[PathPoint],
    actions: Seq[str | ActionKind] = (),
    *,
    max_velocity: float = 0.0,
    stamp: float = 0.0,
    every: float = 0.0,
    checked: bool = True,
) -> list[MotionAssignment | ActionAssignment]:
    """Every assignment of one OPIL task, in sequence order: motions ``{name}_m{i}``, then actions
    ``{name}_a{j}``; ``length`` is the number of both, so the task is assembled once all arrive (R2-R5).

    Only the last point's theta is used (with use_orientation; it is the path's goal, so not a waypoint);
    earlier points are passed through. Motion ``i`` is stamped ``stamp + (i - 1) * every``, the time it
    is meant to be sent. ``checked=False``: as for :func:`motion` (script cycles repeat a checked task).
    """
    if not path and not actions:
        raise ValueError("a task needs at least one point or one action")
    length = len(path) + len(actions)
    out: list[MotionAssignment | ActionAssignment] = []
    for i, point in enumerate(path, start=1):
        x, y = point[0], point[1]
        theta = point[2] if len(point) == 3 else None
        last_with_theta = i == len(path) and theta is not None
        out.append(motion(name, f"{name}_m{i}", i, length, x, y, theta or 0.0, use_orientation=last_with_theta,
                          is_waypoint=i < len(path), max_velocity=max_velocity, stamp=stamp + (i - 1) * every,
                          checked=checked))
    for j, kind in enumerate(actions, start=1):
        out.append(action(name, f"{name}_a{j}", len(path) + j, length, kind, checked=checked))
    return out


class RepeatedTasks:
    """The messages of some tasks built with :func:`task` (checked once, with ``every=0``), ready to be
    built again under other names and one stamp: what a script cycle does for each of its repetitions.

    A repetition differs from the first only in its ids and its header; its points, limits, areas,
    sequence numbers and actions are the first's very objects (messages are immutable). So the fields
    kept are taken from the first once, here, and each message is made again from them, the new ids and
    the header in one positional unchecked constructor call: the ids are the only new work. Rebuilding
    each message by reading seven fields back and passing eleven keywords, a task at a time, was a third
    of expanding a 1000-robot script.
    """

    __slots__ = ("_tasks",)

    def __init__(self, tasks: Seq[Seq[MotionAssignment | ActionAssignment]]) -> None:
        #: per task, per message: the suffix of its id's name, whether it is a motion, the fields kept
        self._tasks: list[list[tuple[str, bool, tuple[Any, ...]]]] = []
        for messages in tasks:
            parts = []
            i = j = 0
            for m in messages:
                if isinstance(m, MotionAssignment):
                    i += 1
                    parts.append((f"_m{i}", True, _kept(m, _MOTION_RENAMED)))
                else:
                    j += 1
                    parts.append((f"_a{j}", False, _kept(m, _ACTION_RENAMED)))
            self._tasks.append(parts)

    def build(self, names: Seq[str], header: Header) -> list[MotionAssignment | ActionAssignment]:
        """Every task's messages in turn, as :func:`task` would build them for the task named ``names[i]``
        with ``header`` (see :func:`header_at`), unchecked: the same as ``task(name, ..., checked=False)``."""
        out: list[MotionAssignment | ActionAssignment] = []
        for name, parts in zip(names, self._tasks, strict=True):
            task_id = fresh_id(name)
            for suffix, is_motion, kept in parts:
                own = fresh_id(name + suffix)
                out.append(_motion_assignment(header, own, task_id, own, *kept) if is_motion
                           else _action_assignment(own, task_id, *kept))
        return out


#: The leading fields of each assignment, the ones a repetition renames or restamps (in field order: the
#: template passes them positionally, followed by the kept ones).
_MOTION_RENAMED = ("header", "point_id", "task_id", "motion_id")
_ACTION_RENAMED = ("action_id", "task_id")


def _kept(message: Message, renamed: tuple[str, ...]) -> tuple[Any, ...]:
    """The fields of ``message`` after ``renamed``, which must be its first ones (checked once per class)."""
    names = _KEPT.get(type(message))
    if names is None:
        every = tuple(f.name for f in fields(message))  # type: ignore[arg-type]
        if every[:len(renamed)] != renamed:
            raise TypeError(f"{type(message).__name__} fields begin {list(every[:len(renamed)])}, not {list(renamed)}")
        names = _KEPT[type(message)] = every[len(renamed):]
    return tuple(getattr(message, name) for name in names)


_KEPT: dict[type, tuple[str, ...]] = {}


def header_at(stamp: float) -> Header:
    """The header of an assignment stamped ``stamp``, as :func:`motion` builds it (unchecked)."""
    return _header(0, Time.from_seconds(stamp), "")


def _id(name: str | Id) -> Id:
    return name if isinstance(name, Id) else id_for(name)


def motion_message(stamp: Time, x: float, y: float, theta: float, v: float, w: float) -> Motion:
    """``current_motion`` of one robot: pose in the map frame and body velocities (docs/contract.md §2)."""
    return Motion(
        PoseStamped(Header(0, stamp, "/map"), Pose(Point(x, y, 0.0), Quaternion.from_yaw(theta))),
        Twist(Vector3(v, 0.0, 0.0), Vector3(0.0, 0.0, w)),
    )
