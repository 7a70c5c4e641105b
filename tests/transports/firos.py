"""The planner side of OPIL's FIROS bridge, as iml130/firos at 8b581f3 does it, with OPIL's own NGSI encoder
(``fiwareobjectconverter==0.1.1`` on PyPI): what tests/transports/test_firos.py drives vcran with (issue 29
item 3; docs/contract.md §2).

What FIROS does, and where (``firos/include/`` of iml130/firos at 8b581f3):

- **writing** (``pubsub/contextbroker/cbPublisher.py``, ``CbPublisher.publish``): a ROS message is encoded
  with ``ObjectFiwareConverter.obj2Fiware({"type", "id", topic: msg}, ind=0, dataTypeDict=...,
  ignorePythonMetaData=True)``, where ``dataTypeDict`` maps the topic to ``rosMsg2Dict`` of the message
  class (``ros/topicHandler.py``), and only that topic is sent, with ``POST /v2/entities/<id>/attrs``;
- **subscribing** (``pubsub/contextbroker/cbSubscriber.py``): one subscription per robot and topic
  (``condition.attrs`` and ``notification.attrs`` that one attribute, ``expires`` ``subscription_length``
  = 300 s ahead as ``%Y-%m-%dT%H:%M:%S.00Z``, ``throttling`` 0, a notification URL without a path), renewed
  in a thread of its own: POST a new subscription, DELETE the old one (its ``Location``), wait
  ``subscription_length * subscription_refresh_delay`` (0.9: 270 s; here a short period);
- **receiving** (``CBServer.CBHandler.do_POST``): ``data[0]`` of each notification, every attribute but
  ``id``/``type`` decoded with ``ObjectFiwareConverter.fiware2Obj(json, obj, setAttr=True,
  useMetaData=False)``; it reaches ROS only if the attribute's ``type`` is the topic's ROS type with ``/``
  as ``.`` (``RosTopicHandler.publish``), nested messages rebuilt from their dotted ``type`` names
  (``instantiateROSMessage``). It answers 204.

One difference to bridge: FIROS 8b581f3 bundles the converter at commit 38d9367 of
iml130/FiwareObjectConverter, whose ``ObjectToJson/entityAttribute.py`` writes a ROS message's type as
``_type.replace("/", ".")`` ("Fiware does not allow a '/'"); the PyPI release writes ``_type`` as it is. The
message classes here carry the dotted name, so the package writes what FIROS wrote.

The message definitions are written from the ``.msg`` files, not from vcran: ``mars_agent_physical_robot_msgs``
and ``mars_common_msgs`` of iml130/mod.sw.tp.mtp at df0639b (``Physical-Agents/mars_agent_physical_robot_msgs/
msg``, ``mars_common_msgs/msg``); ``std_msgs``, ``geometry_msgs`` and ``sensor_msgs/BatteryState`` of ROS 1
Melodic (ros/common_msgs 1.12.7, before Noetic added temperatures); ``time`` as genpy's ``Time`` (``secs``,
``nsecs``, both int32); ``vcran_msgs`` from docs/wire-format.md (docs/contract.md §2's table).
"""

from __future__ import annotations

import json
import threading
import time
from http.server import BaseHTTPRequestHandler, HTTPServer
from typing import Any

import httpx
from fiwareobjectconverter.object_fiware_converter import ObjectFiwareConverter

F64, F32 = "float64", "float32"
ID = "mars_common_msgs/Id"
HEADER = "std_msgs/Header"
MRP = "mars_agent_physical_robot_msgs"

#: ROS type -> its fields in .msg order (name, ROS type).
MSG: dict[str, list[tuple[str, str]]] = {
    "time": [("secs", "int32"), ("nsecs", "int32")],
    HEADER: [("seq", "uint32"), ("stamp", "time"), ("frame_id", "string")],
    "geometry_msgs/Vector3": [("x", F64), ("y", F64), ("z", F64)],
    "geometry_msgs/Twist": [("linear", "geometry_msgs/Vector3"), ("angular", "geometry_msgs/Vector3")],
    "geometry_msgs/Accel": [("linear", "geometry_msgs/Vector3"), ("angular", "geometry_msgs/Vector3")],
    "geometry_msgs/Pose2D": [("x", F64), ("y", F64), ("theta", F64)],
    "geometry_msgs/Point": [("x", F64), ("y", F64), ("z", F64)],
    "geometry_msgs/Point32": [("x", F32), ("y", F32), ("z", F32)],
    "geometry_msgs/Quaternion": [("x", F64), ("y", F64), ("z", F64), ("w", F64)],
    "geometry_msgs/Pose": [("position", "geometry_msgs/Point"), ("orientation", "geometry_msgs/Quaternion")],
    "geometry_msgs/PoseStamped": [("header", HEADER), ("pose", "geometry_msgs/Pose")],
    "geometry_msgs/Polygon": [("points", "geometry_msgs/Point32[]")],
    "geometry_msgs/PolygonStamped": [("header", HEADER), ("polygon", "geometry_msgs/Polygon")],
    ID: [("uuid", "uint8[16]"), ("description", "string")],
    "mars_common_msgs/Tuple": [("type", "string"), ("name", "string"), ("value", "string")],
    f"{MRP}/Sequence": [("sequence_number", "int32"), ("length", "int32")],
    f"{MRP}/RobotAction": [("category", "uint8"), ("action", "uint8"), ("attributes", "mars_common_msgs/Tuple[]"),
                           ("description", "string")],
    f"{MRP}/MotionAssignment": [
        ("header", HEADER), ("point_id", ID), ("task_id", ID), ("motion_id", ID), ("point", "geometry_msgs/Pose2D"),
        ("is_waypoint", "bool"), ("use_orientation", "bool"), ("max_velocity", "geometry_msgs/Twist"),
        ("max_acceleration", "geometry_msgs/Accel"), ("motion_area", "geometry_msgs/PolygonStamped"),
        ("sequence", f"{MRP}/Sequence")],
    f"{MRP}/ActionAssignment": [("action_id", ID), ("task_id", ID), ("sequence", f"{MRP}/Sequence"),
                                ("robot_action", f"{MRP}/RobotAction")],
    f"{MRP}/CancelTask": [("task_id", ID), ("action_id", ID), ("motion_id", ID)],
    f"{MRP}/VehicleType": [("vehicle_type", "uint8")],
    f"{MRP}/RobotAgentProperties": [
        ("robot_id", ID), ("type", f"{MRP}/VehicleType"), ("footprint", "geometry_msgs/PolygonStamped"),
        *((name, F32) for name in (
            "min_height", "max_height", "payload", "max_pos_x_vel", "max_neg_x_vel", "max_pos_x_acc",
            "max_neg_x_acc", "max_pos_y_vel", "max_neg_y_vel", "max_pos_y_acc", "max_neg_y_acc", "max_pos_ang_vel",
            "max_neg_ang_vel", "max_pos_ang_acc", "max_neg_ang_acc", "velocity_control_sensitivity",
            "min_turning_radius", "batt_capacity", "batt_max_voltage", "weight")),
        ("vendor", "string"), ("action_capability", f"{MRP}/RobotAction[]")],
    f"{MRP}/Motion": [("current_position", "geometry_msgs/PoseStamped"), ("current_velocity", "geometry_msgs/Twist")],
    f"{MRP}/AssignmentStatus": [("current_task_id", ID), ("current_motion_id", ID), ("current_action_id", ID),
                                ("last_finished_motion", ID), ("last_finished_action", ID),
                                ("footprint", "geometry_msgs/PolygonStamped")],
    "sensor_msgs/BatteryState": [
        ("header", HEADER), *((name, F32) for name in (
            "voltage", "current", "charge", "capacity", "design_capacity", "percentage")),
        ("power_supply_status", "uint8"), ("power_supply_health", "uint8"), ("power_supply_technology", "uint8"),
        ("present", "bool"), ("cell_voltage", "float32[]"), ("location", "string"), ("serial_number", "string")],
    "vcran_msgs/TaskEnd": [("task_id", ID), ("reason", "string"), ("stamp", "time")],
    "vcran_msgs/RanStatus": [("state", "string"), ("current_task_id", ID), ("queue", f"{ID}[]"), ("queued", "uint32"),
                             ("completed", f"{ID}[]"), ("cancelled", "vcran_msgs/TaskEnd[]"), ("carrying", "uint32")],
    "vcran_msgs/RanError": [("code", "string"), ("severity", "string"), ("message", "string"), ("task_id", ID),
                            ("motion_id", ID), ("action_id", ID), ("stamp", "time"), ("count", "uint32")],
}

#: The attributes of docs/contract.md §2 and their ROS types: the MTP's FIROS configuration
#: (mod_sw_tp/firos_config/robots.json) names the first five; action_assignment is the RAN's.
TOPICS: dict[str, str] = {
    "assignment_state": f"{MRP}/AssignmentStatus",
    "current_motion": f"{MRP}/Motion",
    "robot_description": f"{MRP}/RobotAgentProperties",
    "cancel_order": f"{MRP}/CancelTask",
    "motion_assignment": f"{MRP}/MotionAssignment",
    "action_assignment": f"{MRP}/ActionAssignment",
    "ran_status": "vcran_msgs/RanStatus",
    "ran_error": "vcran_msgs/RanError",
    "battery_state": "sensor_msgs/BatteryState",
}
PUBLISHED = ("assignment_state", "current_motion", "robot_description", "ran_status", "ran_error", "battery_state")

_INTEGERS = {"uint8", "int8", "uint16", "int16", "uint32", "int32", "uint64", "int64"}


# --- ROS messages, as genpy generates them --------------------------------------------------------------


class Time:
    """genpy's ``Time``: ``__slots__`` and ``_slot_types``, no ``_type`` (the converter names it ``Time``)."""

    __slots__ = ("secs", "nsecs")
    _slot_types = ("int32", "int32")

    def __init__(self, secs: int = 0, nsecs: int = 0) -> None:
        self.secs, self.nsecs = secs, nsecs


class RosMessage:
    """A generated ROS message class: ``__slots__`` (the fields), ``_slot_types`` and ``_type``."""

    __slots__: tuple[str, ...] = ()
    _slot_types: tuple[str, ...] = ()
    _type = ""

    def __init__(self, **fields: Any) -> None:
        unknown = set(fields) - set(self.__slots__)
        assert not unknown, f"{self._type} has no field {unknown}"
        for name, ros_type in zip(self.__slots__, self._slot_types):
            setattr(self, name, fields[name] if name in fields else default(ros_type))


_CLASSES: dict[str, type[RosMessage]] = {}


def message_class(ros_type: str) -> type[RosMessage]:
    if ros_type not in _CLASSES:
        fields = MSG[ros_type]
        _CLASSES[ros_type] = type(ros_type.split("/")[1], (RosMessage,), {
            "__slots__": tuple(name for name, _ in fields), "_slot_types": tuple(t for _, t in fields),
            "_type": ros_type.replace("/", "."),  # what FIROS's bundled converter writes (module docstring)
        })
    return _CLASSES[ros_type]


def ros(ros_type: str, **fields: Any) -> RosMessage:
    return message_class(ros_type)(**fields)


def default(ros_type: str) -> Any:
    """A field's value in a freshly constructed message, as genpy sets it (``uint8[16]`` is bytes)."""
    if ros_type == "time":
        return Time()
    if ros_type.startswith("uint8["):
        return bytes(int(ros_type[6:-1] or 0))
    if ros_type.endswith("]"):
        return []
    if ros_type in MSG:
        return ros(ros_type)
    return {"string": "", "bool": False}.get(ros_type, 0.0 if ros_type.startswith("float") else 0)


def ros_msg_to_dict(message: Any) -> dict[str, Any]:
    """FIROS's ``rosMsg2Dict`` (ros/topicHandler.py): the message's slot types, nested ones as dicts."""
    out: dict[str, Any] = {}
    for key, slot_type in zip(message.__slots__, message._slot_types):
        attr = getattr(message, key)
        out[key] = ros_msg_to_dict(attr) if hasattr(attr, "__slots__") else slot_type
    return out


def ngsi_attribute(robot: str, topic: str, message: RosMessage, context_type: str = "ROBOT") -> str:
    """``CbPublisher.publish``: the body of ``POST /v2/entities/<robot>/attrs`` that writes ``topic``."""
    entity = {"type": context_type, "id": robot, topic: message}
    data_types = {topic: ros_msg_to_dict(message_class(TOPICS[topic])())}
    complete = ObjectFiwareConverter.obj2Fiware(entity, ind=0, dataTypeDict=data_types, ignorePythonMetaData=True)
    return json.dumps({topic: json.loads(complete)[topic]})


# --- checking what comes back ---------------------------------------------------------------------------


def check_fields(value: Any, ros_type: str, path: str) -> None:
    """``value``, as the converter decodes it, holds exactly the fields of ``ros_type``, all the way down."""
    if ros_type.endswith("]"):
        base, size = ros_type[:ros_type.index("[")], ros_type[ros_type.index("[") + 1:-1]
        assert isinstance(value, list), f"{path}: expected an array, got {value!r}"
        assert not size or len(value) == int(size), f"{path}: expected {size} elements, got {len(value)}"
        for i, item in enumerate(value):
            check_fields(item, base, f"{path}[{i}]")
    elif ros_type in MSG:
        assert isinstance(value, dict), f"{path}: expected a {ros_type}, got {value!r}"
        expected = [name for name, _ in MSG[ros_type]]
        assert sorted(value) == sorted(expected), f"{path}: fields {sorted(value)}, {ros_type} has {sorted(expected)}"
        for name, field_type in MSG[ros_type]:
            check_fields(value[name], field_type, f"{path}.{name}")
    elif ros_type in _INTEGERS:
        assert type(value) is int, f"{path}: expected an integer, got {value!r}"
    elif ros_type.startswith("float"):
        assert type(value) in (int, float), f"{path}: expected a number, got {value!r}"
    else:
        assert type(value) is {"string": str, "bool": bool}[ros_type], f"{path}: expected a {ros_type}, got {value!r}"


def check_types(wrapper: dict[str, Any], ros_type: str, path: str) -> None:
    """The NGSI ``type`` of ``wrapper`` and of every nested message is its ROS type with ``.`` for ``/``:
    what ``RosTopicHandler.publish`` checks and ``instantiateROSMessage`` loads classes by."""
    if ros_type.endswith("]"):
        assert wrapper["type"] == "array", f"{path}: type {wrapper['type']!r}"
        for i, item in enumerate(wrapper["value"]):
            check_types(item, ros_type[:ros_type.index("[")], f"{path}[{i}]")
    elif ros_type == "time":
        assert wrapper["type"] == "Time", f"{path}: type {wrapper['type']!r}"
    elif ros_type in MSG:
        assert wrapper["type"] == ros_type.replace("/", "."), f"{path}: type {wrapper['type']!r}, not {ros_type}"
        for name, field_type in MSG[ros_type]:
            check_types(wrapper["value"][name], field_type, f"{path}.{name}")


def decode(data: dict[str, Any], topic: str) -> Any:
    """``CBHandler.do_POST``: the converter's decoding of one attribute of a notified entity."""

    class TypeValue:  # FIROS's stub object
        pass

    obj = TypeValue()
    ObjectFiwareConverter.fiware2Obj(json.dumps(data), obj, setAttr=True, useMetaData=False)
    return getattr(obj, topic)


# --- the planner ----------------------------------------------------------------------------------------


class Planner:
    """FIROS on the planner's side: it writes assignments and cancels, subscribes to each published
    attribute of one robot in a thread of its own that renews the subscription every ``renew`` seconds,
    and decodes every notification. ``received`` holds ``(subscription id, topic, NGSI attribute, decoded)``."""

    SUBSCRIPTION_LENGTH = 300  # cbSubscriber.py: subscription_length

    def __init__(self, orion: str, robot: str, topics: tuple[str, ...] = PUBLISHED, *, renew: float = 1.0) -> None:
        self.orion, self.robot, self.topics, self.renew = orion, robot, topics, renew
        self.received: list[tuple[str, str, dict[str, Any], Any]] = []
        self.created: list[tuple[str, str]] = []  # (topic, subscription id), in creation order
        self.current: dict[str, str] = {}  # topic -> its subscription's Location
        self.errors: list[str] = []
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._server = HTTPServer(("127.0.0.1", 0), self._handler())
        self._threads = [threading.Thread(target=self._server.serve_forever, daemon=True)]
        self._threads += [threading.Thread(target=self._subscription_loop, args=(t,), daemon=True) for t in topics]

    def start(self) -> Planner:
        for thread in self._threads:
            thread.start()
        return self

    def stop(self) -> None:
        """``CbSubscriber.unsubscribe``: stop listening, delete the current subscriptions."""
        self._stop.set()
        for thread in self._threads[1:]:
            thread.join(timeout=10)
        self._server.shutdown()
        self._server.server_close()
        for location in self.current.values():
            httpx.delete(self.orion + location)

    def write(self, topic: str, message: RosMessage) -> None:
        response = httpx.post(f"{self.orion}/v2/entities/{self.robot}/attrs", content=ngsi_attribute(
            self.robot, topic, message), headers={"Content-Type": "application/json"})
        assert response.status_code == 204, f"{topic}: {response.status_code} {response.text}"

    def got(self, topic: str) -> list[tuple[str, Any]]:
        """(subscription id, decoded value) of every notification of ``topic`` so far."""
        with self._lock:
            return [(sid, value) for sid, t, _, value in self.received if t == topic]

    # --- cbSubscriber.py ------------------------------------------------------------------------------

    def _subscription_body(self, topic: str) -> str:
        expires = time.strftime("%Y-%m-%dT%H:%M:%S.00Z", time.gmtime(time.time() + self.SUBSCRIPTION_LENGTH))
        return json.dumps({
            "subject": {"entities": [{"id": self.robot, "type": "ROBOT"}], "condition": {"attrs": [topic]}},
            "notification": {"http": {"url": f"http://127.0.0.1:{self._server.server_address[1]}"}, "attrs": [topic]},
            "expires": expires,
            "throttling": 0,
        })

    def _subscription_loop(self, topic: str) -> None:
        while not self._stop.is_set():
            response = httpx.post(f"{self.orion}/v2/subscriptions", content=self._subscription_body(topic),
                                  headers={"Content-Type": "application/json"})
            if response.status_code != 201:
                self.errors.append(f"subscribe {topic}: {response.status_code} {response.text}")
                return
            location = response.headers["Location"]
            with self._lock:
                self.created.append((topic, location.rsplit("/", 1)[1]))
                old, self.current[topic] = self.current.get(topic), location
            if old is not None:
                gone = httpx.delete(self.orion + old)
                if gone.status_code != 204:
                    self.errors.append(f"unsubscribe {old}: {gone.status_code}")
            self._stop.wait(self.renew)

    # --- CBServer.CBHandler -----------------------------------------------------------------------------

    def _handler(self) -> type[BaseHTTPRequestHandler]:
        planner = self

        class CBHandler(BaseHTTPRequestHandler):
            protocol_version = "HTTP/1.0"

            def do_POST(self) -> None:  # noqa: N802
                received = json.loads(self.rfile.read(int(self.headers["Content-Length"])))
                data = received["data"][0]
                for topic in data:
                    if topic in ("id", "type"):
                        continue
                    try:
                        value = decode(data, topic)
                    except Exception as exc:  # noqa: BLE001 - a decoding failure is the finding
                        planner.errors.append(f"{topic}: the converter cannot decode it: {exc!r}")
                        continue
                    with planner._lock:
                        planner.received.append((received["subscriptionId"], topic, data[topic], value))
                self.send_response(204)
                self.end_headers()

            def log_message(self, *args: object) -> None:
                pass

        return CBHandler
