"""Build inbound messages from names and numbers: what scenario scripts, tests and users write.

Ids come from names through the stable mapping of :func:`vcran.core.ids.id_for`. Actions are named by kind
(``"load"``, ``"unload"``, ``"dummy"``), encoded with OPIL's categories (10, 20, 5), which is what OPIL's
task planner sends, and ``"charge"``, vcran's extension (category 0, action 3; SPEC §4); a raw
``(category, action)`` pair can be given instead.
"""

from __future__ import annotations

from collections.abc import Sequence as Seq
from functools import lru_cache

from vcran.core.ids import NIL, NOT_SUPPORTED, Id, fresh_id, id_for
from vcran.core.messages import (
    Accel,
    ActionAssignment,
    ActionKind,
    CancelTask,
    Header,
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
from vcran.core.schema import unchecked

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
        header=_header(0, Time.from_seconds(stamp), ""),
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


# Messages are immutable, so the parts a script repeats (a cycle's points, limits, areas) are shared:
# building hours of generated assignments stays cheap.
@lru_cache(maxsize=4096)
def _pose(x: float, y: float, theta: float) -> Pose2D:
    return Pose2D(x, y, theta)


@lru_cache(maxsize=64)
def _twist(linear: float) -> Twist:
    return Twist(Vector3(linear, 0.0, 0.0), Vector3())


@lru_cache(maxsize=64)
def _accel(linear: float) -> Accel:
    return Accel(Vector3(linear, 0.0, 0.0), Vector3())


@lru_cache(maxsize=256)
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


def repeated(
    messages: list[MotionAssignment | ActionAssignment], name: str, stamp: float
) -> list[MotionAssignment | ActionAssignment]:
    """The messages of :func:`task` (built with ``every=0``) as they would be built again for task ``name``
    stamped ``stamp``: the same as ``task(name, ..., stamp=stamp, checked=False)``, without building
    the shared parts again (script cycles repeat a checked task thousands of times)."""
    header = _header(0, Time.from_seconds(stamp), "")
    task_id = fresh_id(name)
    out: list[MotionAssignment | ActionAssignment] = []
    i = j = 0
    for m in messages:
        if isinstance(m, MotionAssignment):
            i += 1
            motion_id = fresh_id(f"{name}_m{i}")
            out.append(_motion_assignment(
                header=header, point_id=motion_id, task_id=task_id, motion_id=motion_id, point=m.point,
                is_waypoint=m.is_waypoint, use_orientation=m.use_orientation, max_velocity=m.max_velocity,
                max_acceleration=m.max_acceleration, motion_area=m.motion_area, sequence=m.sequence,
            ))
        else:
            j += 1
            out.append(_action_assignment(action_id=fresh_id(f"{name}_a{j}"), task_id=task_id, sequence=m.sequence,
                                          robot_action=m.robot_action))
    return out


def _id(name: str | Id) -> Id:
    return name if isinstance(name, Id) else id_for(name)


def motion_message(stamp: Time, x: float, y: float, theta: float, v: float, w: float) -> Motion:
    """``current_motion`` of one robot: pose in the map frame and body velocities (SPEC §2)."""
    return Motion(
        PoseStamped(Header(0, stamp, "/map"), Pose(Point(x, y, 0.0), Quaternion.from_yaw(theta))),
        Twist(Vector3(v, 0.0, 0.0), Vector3(0.0, 0.0, w)),
    )
