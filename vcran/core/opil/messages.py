"""Every message the RAN exchanges with a fleet manager, as frozen dataclasses (docs/contract.md §2).

Field names and order follow the ROS messages of OPIL (``mars_agent_physical_robot_msgs``,
``mars_common_msgs``, ``geometry_msgs``, ``std_msgs``) so that the NGSI codec is a mechanical walk over
:func:`vcran.core.opil.schema.specs`. ``RanStatus``, ``TaskEnd`` and ``RanError`` are vcran's own extensions
(``vcran_msgs``). Every message validates itself on construction (:class:`vcran.core.opil.schema.Message`).

One concept in one module longer than 450 lines (issue 30): OPIL's message vocabulary, docs/contract.md §2 as data, one
short class per ROS message and the tables of which attribute carries which (:data:`INBOUND`,
:data:`OUTBOUND`, :data:`RENAMED`); it is read as a reference, a class at a time. The machinery they share
is :mod:`vcran.core.opil.schema`'s, their wire form :mod:`vcran.core.opil.codec`'s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import ClassVar

from vcran.core.actions import ActionKind
from vcran.core.opil.ids import NIL, Id
from vcran.core.opil.schema import (
    Bool,
    Float32,
    Float64,
    Int32,
    Message,
    MessageError,
    String,
    UInt8,
    UInt32,
)
from vcran.core.slots import unchecked

# --- std_msgs / geometry_msgs -------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class Time(Message):
    """ROS time. vcran stamps simulated seconds since the start of the run (docs/wire-format.md)."""

    ROS_TYPE = "Time"
    secs: Int32 = 0
    nsecs: Int32 = 0

    def _check_semantics(self) -> None:
        if not 0 <= self.nsecs < 1_000_000_000:
            raise MessageError("nsecs", f"must be 0..999999999, got {self.nsecs}")

    @classmethod
    def from_seconds(cls, t: float) -> Time:
        """Nearest nanosecond; exact inverse of :meth:`to_seconds` for every stamp it produces."""
        if math.isfinite(t) and abs(t) >= 2**32:  # t * 1e9 may overflow to inf (1e308): say the range instead
            return cls(math.floor(t), 0)  # raises, naming the field
        total = round(t * 1_000_000_000) if math.isfinite(t) else 0
        secs, nsecs = divmod(total, 1_000_000_000)
        if secs <= 2**31 - 1 and secs >= -(2**31):
            return unchecked(cls)(int(secs), int(nsecs))  # in range by construction
        return cls(int(secs), int(nsecs))  # raises, naming the field

    def to_seconds(self) -> float:
        return (self.secs * 1_000_000_000 + self.nsecs) / 1_000_000_000


@dataclass(frozen=True, slots=True)
class Header(Message):
    """A ROS header: sequence number, time stamp and frame of the message it heads."""

    ROS_TYPE = "std_msgs.Header"
    seq: UInt32 = 0
    stamp: Time = field(default_factory=Time)
    frame_id: String = ""


@dataclass(frozen=True, slots=True)
class Vector3(Message):
    """A 3-vector: the linear or angular part of a twist or an acceleration."""

    ROS_TYPE = "geometry_msgs.Vector3"
    x: Float64 = 0.0
    y: Float64 = 0.0
    z: Float64 = 0.0


@dataclass(frozen=True, slots=True)
class Twist(Message):
    """Linear and angular velocity (a motion's limits, a robot's current velocity)."""

    ROS_TYPE = "geometry_msgs.Twist"
    linear: Vector3 = field(default_factory=Vector3)
    angular: Vector3 = field(default_factory=Vector3)


@dataclass(frozen=True, slots=True)
class Accel(Message):
    """Linear and angular acceleration (a motion's limits)."""

    ROS_TYPE = "geometry_msgs.Accel"
    linear: Vector3 = field(default_factory=Vector3)
    angular: Vector3 = field(default_factory=Vector3)


@dataclass(frozen=True, slots=True)
class Pose2D(Message):
    """A pose in the plane: position and heading in radians (a motion's target point)."""

    ROS_TYPE = "geometry_msgs.Pose2D"
    x: Float64 = 0.0
    y: Float64 = 0.0
    theta: Float64 = 0.0


@dataclass(frozen=True, slots=True)
class Point(Message):
    """A point in space (a pose's position)."""

    ROS_TYPE = "geometry_msgs.Point"
    x: Float64 = 0.0
    y: Float64 = 0.0
    z: Float64 = 0.0


@dataclass(frozen=True, slots=True)
class Point32(Message):
    """A point in space in single precision (a polygon's corner)."""

    ROS_TYPE = "geometry_msgs.Point32"
    x: Float32 = 0.0
    y: Float32 = 0.0
    z: Float32 = 0.0


@dataclass(frozen=True, slots=True)
class Quaternion(Message):
    """An orientation; vcran's robots only turn about z (heading ``yaw``)."""

    ROS_TYPE = "geometry_msgs.Quaternion"
    x: Float64 = 0.0
    y: Float64 = 0.0
    z: Float64 = 0.0
    w: Float64 = 1.0

    @classmethod
    def from_yaw(cls, theta: float) -> Quaternion:
        return cls(0.0, 0.0, math.sin(theta / 2.0), math.cos(theta / 2.0))

    def yaw(self) -> float:
        return math.atan2(2.0 * (self.w * self.z + self.x * self.y), 1.0 - 2.0 * (self.y**2 + self.z**2))


@dataclass(frozen=True, slots=True)
class Pose(Message):
    """Position and orientation."""

    ROS_TYPE = "geometry_msgs.Pose"
    position: Point = field(default_factory=Point)
    orientation: Quaternion = field(default_factory=Quaternion)


@dataclass(frozen=True, slots=True)
class PoseStamped(Message):
    """A pose with its header (a robot's current position)."""

    ROS_TYPE = "geometry_msgs.PoseStamped"
    header: Header = field(default_factory=Header)
    pose: Pose = field(default_factory=Pose)


@dataclass(frozen=True, slots=True)
class Polygon(Message):
    """A polygon by its corners (a footprint, a motion area)."""

    ROS_TYPE = "geometry_msgs.Polygon"
    points: tuple[Point32, ...] = ()


@dataclass(frozen=True, slots=True)
class PolygonStamped(Message):
    """A polygon with its header (a robot's footprint, a motion's allowed area)."""

    ROS_TYPE = "geometry_msgs.PolygonStamped"
    header: Header = field(default_factory=Header)
    polygon: Polygon = field(default_factory=Polygon)

    @classmethod
    def from_xy(cls, points: list[tuple[float, float]] | tuple[tuple[float, float], ...]) -> PolygonStamped:
        return cls(Header(), Polygon(tuple(Point32(float(x), float(y), 0.0) for x, y in points)))

    def xy(self) -> list[tuple[float, float]]:
        return [(p.x, p.y) for p in self.polygon.points]


# --- mars_common_msgs / mars_agent_physical_robot_msgs --------------------------------------------------


@dataclass(frozen=True, slots=True)
class Tuple(Message):
    """`mars_common_msgs/Tuple`: a typed key/value attribute of a robot action."""

    ROS_TYPE = "mars_common_msgs.Tuple"
    type: String = ""
    name: String = ""
    value: String = ""


@dataclass(frozen=True, slots=True)
class Sequence(Message):
    """Position of an assignment within its task; numbers start at 1 (R2)."""

    ROS_TYPE = "mars_agent_physical_robot_msgs.Sequence"
    sequence_number: Int32 = 1
    length: Int32 = 1

    def _check_semantics(self) -> None:
        if self.length < 1:
            raise MessageError("length", f"must be at least 1, got {self.length}")
        if not 1 <= self.sequence_number <= self.length:
            raise MessageError(
                "sequence_number", f"must be 1..length={self.length}, got {self.sequence_number}"
            )


#: OPIL ``RobotAction.category`` constants (category first, docs/contract.md §2).
CATEGORY_CODES: dict[int, ActionKind] = {5: ActionKind.DUMMY, 10: ActionKind.LOAD, 20: ActionKind.UNLOAD}
#: The original VC-RAN's action codes, used when ``category`` is 0 (undefined).
ACTION_CODES: dict[int, ActionKind] = {0: ActionKind.DUMMY, 1: ActionKind.LOAD, 2: ActionKind.UNLOAD}
#: vcran's extension codes, outside OPIL's categories and the original VC-RAN's codes (docs/wire-format.md):
#: ``charge`` is category 200, or action 3 with category 0.
EXTENSION_CATEGORIES: dict[int, ActionKind] = {200: ActionKind.CHARGE}
EXTENSION_ACTIONS: dict[int, ActionKind] = {3: ActionKind.CHARGE}
CATEGORY_UNDEFINED = 0


@dataclass(frozen=True, slots=True)
class RobotAction(Message):
    """An action of a task: its category or code, attributes and description (R12 names unknown codes)."""

    ROS_TYPE = "mars_agent_physical_robot_msgs.RobotAction"
    category: UInt8 = CATEGORY_UNDEFINED
    action: UInt8 = 0
    attributes: tuple[Tuple, ...] = ()
    description: String = ""

    @property
    def kind(self) -> ActionKind:
        """The action to perform; raises MessageError (naming the field) for an unknown code (R12)."""
        if self.category != CATEGORY_UNDEFINED:
            try:
                return CATEGORY_CODES.get(self.category) or EXTENSION_CATEGORIES[self.category]
            except KeyError:
                known = ", ".join(str(c) for c in (CATEGORY_UNDEFINED, *CATEGORY_CODES, *EXTENSION_CATEGORIES))
                raise MessageError("category", f"unknown action category {self.category} (known: {known})") from None
        try:
            return ACTION_CODES.get(self.action) or EXTENSION_ACTIONS[self.action]
        except KeyError:
            known = ", ".join(str(c) for c in (*ACTION_CODES, *EXTENSION_ACTIONS))
            raise MessageError("action", f"unknown action code {self.action} with category 0 (known: {known})") from None


@dataclass(frozen=True, slots=True)
class MotionAssignment(Message):
    """One point of a task's path (consumed: ``motion_assignment``)."""

    ROS_TYPE = "mars_agent_physical_robot_msgs.MotionAssignment"
    header: Header = field(default_factory=Header)
    point_id: Id = NIL
    task_id: Id = NIL
    motion_id: Id = NIL
    point: Pose2D = field(default_factory=Pose2D)
    is_waypoint: Bool = False
    use_orientation: Bool = False
    max_velocity: Twist = field(default_factory=Twist)
    max_acceleration: Accel = field(default_factory=Accel)
    motion_area: PolygonStamped = field(default_factory=PolygonStamped)
    sequence: Sequence = field(default_factory=Sequence)


@dataclass(frozen=True, slots=True)
class ActionAssignment(Message):
    """One action of a task (consumed: ``action_assignment``)."""

    ROS_TYPE = "mars_agent_physical_robot_msgs.ActionAssignment"
    action_id: Id = NIL
    task_id: Id = NIL
    sequence: Sequence = field(default_factory=Sequence)
    robot_action: RobotAction = field(default_factory=RobotAction)

    def _check_semantics(self) -> None:
        try:
            self.robot_action.kind
        except MessageError as exc:
            raise exc.within("robot_action") from None

    @property
    def kind(self) -> ActionKind:
        return self.robot_action.kind


@dataclass(frozen=True, slots=True)
class CancelTask(Message):
    """Cancel a whole task (consumed: ``cancel_order``); unused motion/action ids are nil or "not supported"."""

    ROS_TYPE = "mars_agent_physical_robot_msgs.CancelTask"
    task_id: Id = NIL
    action_id: Id = NIL
    motion_id: Id = NIL


@dataclass(frozen=True, slots=True)
class VehicleType(Message):
    """The kind of vehicle, a ROS enumeration code (vcran's robots: 0)."""

    ROS_TYPE = "mars_agent_physical_robot_msgs.VehicleType"
    vehicle_type: UInt8 = 0


@dataclass(frozen=True, slots=True)
class RobotAgentProperties(Message):
    """The robot's description (produced: ``robot_description``, at start and every 60 s)."""

    ROS_TYPE = "mars_agent_physical_robot_msgs.RobotAgentProperties"
    robot_id: Id = NIL
    type: VehicleType = field(default_factory=VehicleType)
    footprint: PolygonStamped = field(default_factory=PolygonStamped)
    min_height: Float32 = 0.0
    max_height: Float32 = 0.0
    payload: Float32 = 0.0
    max_pos_x_vel: Float32 = 0.0
    max_neg_x_vel: Float32 = 0.0
    max_pos_x_acc: Float32 = 0.0
    max_neg_x_acc: Float32 = 0.0
    max_pos_y_vel: Float32 = 0.0
    max_neg_y_vel: Float32 = 0.0
    max_pos_y_acc: Float32 = 0.0
    max_neg_y_acc: Float32 = 0.0
    max_pos_ang_vel: Float32 = 0.0
    max_neg_ang_vel: Float32 = 0.0
    max_pos_ang_acc: Float32 = 0.0
    max_neg_ang_acc: Float32 = 0.0
    velocity_control_sensitivity: Float32 = 0.0
    min_turning_radius: Float32 = 0.0
    batt_capacity: Float32 = 0.0
    batt_max_voltage: Float32 = 0.0
    vendor: String = ""
    action_capability: tuple[RobotAction, ...] = ()
    weight: Float32 = 0.0


@dataclass(frozen=True, slots=True)
class Motion(Message):
    """Pose and velocity (produced: ``current_motion``, every second: the original VC-RAN's "RAN-state")."""

    ROS_TYPE = "mars_agent_physical_robot_msgs.Motion"
    current_position: PoseStamped = field(default_factory=PoseStamped)
    current_velocity: Twist = field(default_factory=Twist)


@dataclass(frozen=True, slots=True)
class AssignmentStatus(Message):
    """What runs now and what finished last (produced: ``assignment_state``, every second)."""

    ROS_TYPE = "mars_agent_physical_robot_msgs.AssignmentStatus"
    current_task_id: Id = NIL
    current_motion_id: Id = NIL
    current_action_id: Id = NIL
    last_finished_motion: Id = NIL
    last_finished_action: Id = NIL
    footprint: PolygonStamped = field(default_factory=PolygonStamped)


# --- vcran extensions -----------------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class TaskEnd(Message):
    """A cancelled task in ``ran_status``: which, why (timeout/cancelled/action_failed) and when."""

    ROS_TYPE = "vcran_msgs.TaskEnd"
    task_id: Id = NIL
    reason: String = ""
    stamp: Time = field(default_factory=Time)


@dataclass(frozen=True, slots=True)
class RanStatus(Message):
    """RanLogic's state and queue, and the robot's load (produced: ``ran_status``, published when it
    changes; vcran extension)."""

    ROS_TYPE = "vcran_msgs.RanStatus"
    state: String = "WAITING"
    current_task_id: Id = NIL
    #: The head of the task queue (current task first), at most ``QUEUE_SHOWN`` ids; ``queued`` is
    #: the queue's full length. Bounded so that no backlog can push an entity past Orion's 1 MB limit.
    queue: tuple[Id, ...] = ()
    queued: UInt32 = 0
    completed: tuple[Id, ...] = ()
    cancelled: tuple[TaskEnd, ...] = ()
    #: The parts the robot carries now (docs/contract.md §2): a fleet manager must see a load that a failed action
    #: left where it was. Last, as a field added to a ROS message goes, so older readers keep their order.
    carrying: UInt32 = 0


@dataclass(frozen=True, slots=True)
class RanError(Message):
    """One rejected input or failure (produced: ``ran_error``, when it happens; vcran extension)."""

    ROS_TYPE = "vcran_msgs.RanError"
    code: String = ""
    severity: String = "error"
    message: String = ""
    task_id: Id = NIL
    motion_id: Id = NIL
    action_id: Id = NIL
    stamp: Time = field(default_factory=Time)
    count: UInt32 = 0


# --- sensor_msgs ----------------------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class BatteryState(Message):
    """The battery (produced: ``battery_state``, docs/contract.md §4), ROS 1 ``sensor_msgs/BatteryState``.

    ``charge`` and ``capacity`` in Ah, ``percentage`` 0..1; vcran fills the fields its battery model
    knows and leaves the rest at ROS's "unknown" values (NaN is not JSON, so 0 stands for unmeasured).
    """

    ROS_TYPE = "sensor_msgs.BatteryState"
    header: Header = field(default_factory=Header)
    voltage: Float32 = 0.0
    current: Float32 = 0.0
    charge: Float32 = 0.0
    capacity: Float32 = 0.0
    design_capacity: Float32 = 0.0
    percentage: Float32 = 0.0
    power_supply_status: UInt8 = 0
    power_supply_health: UInt8 = 0
    power_supply_technology: UInt8 = 0
    present: Bool = True
    cell_voltage: tuple[Float32, ...] = ()
    location: String = ""
    serial_number: String = ""

    STATUS_UNKNOWN: ClassVar[int] = 0
    STATUS_CHARGING: ClassVar[int] = 1
    STATUS_DISCHARGING: ClassVar[int] = 2
    STATUS_NOT_CHARGING: ClassVar[int] = 3
    STATUS_FULL: ClassVar[int] = 4


#: Attribute name -> message type, for both directions (docs/contract.md §2).
INBOUND: dict[str, type[Message]] = {
    "motion_assignment": MotionAssignment,
    "action_assignment": ActionAssignment,
    "cancel_order": CancelTask,
}
OUTBOUND: dict[str, type[Message]] = {
    "robot_description": RobotAgentProperties,
    "current_motion": Motion,
    "assignment_state": AssignmentStatus,
    "ran_status": RanStatus,
    "ran_error": RanError,
    "battery_state": BatteryState,
}
ATTRIBUTES: dict[str, type[Message]] = {**INBOUND, **OUTBOUND}
#: Attributes whose every write reaches subscribers, changed or not (docs/contract.md §2): ``robot_description`` goes out
#: every ``description_period`` so that a planner subscribing late still gets it, but it never changes, and
#: Orion notifies only changes. Live, it is written with Orion's ``options=forcedUpdate``, in a request of
#: its own (the option forces every attribute of a request); a closed loop's link notifies each write.
FORCED_UPDATES: frozenset[str] = frozenset({"robot_description"})
#: Attributes published under another name before vcran took OPIL's own (the OPIL RAN's launch file and the
#: Motion Task Planner's FIROS configuration read ``assignment_state`` and ``battery_state``; docs/contract.md §2, §4).
#: Traces recorded before are read with the new names; a fleet manager naming an old one is told the new.
RENAMED: dict[str, str] = {"assignment_status": "assignment_state", "battery": "battery_state"}

Assignment = MotionAssignment | ActionAssignment
