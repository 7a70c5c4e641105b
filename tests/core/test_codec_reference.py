"""The codec against ground truth: the OPIL reference entity and what a real Orion 4.7 rendered of it.

The reference (tests/data/opil_robot_entity.json) was written by a real OPIL deployment; the exchanges
file holds the same entity read back from Orion normalized, with options=keyValues, and as
notifications. Decoding must give the values below, and encoding what we decoded must give the
reference back: same structure, wrapper types and metadata (docs/contract.md §2).
"""

from __future__ import annotations

import json
import math
from typing import Any

import pytest

from tests.conftest import DATA
from vcran.core.opil.codec import (
    CodecError,
    decode_attribute,
    decode_entity,
    encode_attribute,
    encode_entity,
    unknown_attributes,
)
from vcran.core.opil.ids import Id
from vcran.core.opil.messages import (
    ATTRIBUTES,
    ActionAssignment,
    ActionKind,
    CancelTask,
    Motion,
    MotionAssignment,
    RobotAgentProperties,
)

REFERENCE: dict[str, Any] = json.loads((DATA / "opil_robot_entity.json").read_text())
EXCHANGES = {
    record["name"]: record
    for record in map(json.loads, (DATA / "orion-4.7-exchanges.jsonl").read_text().splitlines())
}
REFERENCE_ATTRIBUTES = ["action_assignment", "cancel_order", "current_motion", "motion_assignment", "robot_description"]


def uuid_of(attr: dict[str, Any], field: str) -> bytes:
    """The uuid bytes of an Id field, read straight from the reference JSON (not through the codec)."""
    return bytes(item["value"] for item in attr["value"][field]["value"]["uuid"]["value"])


def test_reference_entity_decodes_to_its_real_values() -> None:
    decoded = decode_entity(REFERENCE)
    assert sorted(decoded) == REFERENCE_ATTRIBUTES

    motion = decoded["motion_assignment"]
    assert isinstance(motion, MotionAssignment)
    assert (motion.point.x, motion.point.y, motion.point.theta) == (-0.916000009, -3.119999886, 0.0)
    assert (motion.is_waypoint, motion.use_orientation) == (True, False)
    assert motion.max_velocity.linear.x == 10.0 and motion.max_velocity.angular.z == 1.0
    assert motion.max_acceleration.linear.x == 1.0 and motion.max_acceleration.angular.z == 0.5
    assert motion.motion_area.xy() == [
        (0.034000002, -2.170000076),
        (-1.866000056, -2.170000076),
        (-1.866000056, -4.070000172),
        (0.034000002, -4.070000172),
    ]
    assert (motion.sequence.sequence_number, motion.sequence.length) == (20, 20)
    assert (motion.header.seq, motion.header.stamp.secs, motion.header.stamp.nsecs) == (19, 1572008882, 381286634)
    assert motion.task_id.uuid == uuid_of(REFERENCE["motion_assignment"], "task_id")
    assert motion.task_id.canonical == "4ce44dbe-a0ba-4d31-9137-f6ef6417fb49"
    assert all(isinstance(v, float) for v in (motion.point.theta, motion.max_velocity.linear.y))

    action = decoded["action_assignment"]
    assert isinstance(action, ActionAssignment)
    assert (action.robot_action.category, action.robot_action.action) == (10, 5)
    assert action.kind is ActionKind.LOAD  # category first (docs/contract.md §2)
    assert action.task_id.description == "task pickup at p1: task_1"
    assert action.task_id.canonical == "7e916ede-a8a5-5a53-8d71-1d2d16170184"
    assert action.action_id.uuid == uuid_of(REFERENCE["action_assignment"], "action_id")
    assert (action.sequence.sequence_number, action.sequence.length) == (23, 23)
    assert len(action.robot_action.attributes) == 1

    cancel = decoded["cancel_order"]
    assert isinstance(cancel, CancelTask)
    assert cancel.task_id == Id.parse("05030602-0907-0300-0608-010107040503")
    assert cancel.task_id.description == "Cancel task pickup p1"
    assert cancel.action_id.is_unused and cancel.motion_id.is_unused
    assert cancel.motion_id.octets == [0] * 15 + [1]

    current = decoded["current_motion"]
    assert isinstance(current, Motion)
    assert current.current_position.header.stamp.to_seconds() == 2291.1
    assert current.current_position.header.frame_id == "/map"
    assert current.current_position.pose.position.x == -0.891966949
    assert math.isclose(current.current_position.pose.orientation.yaw(), 0.02194, abs_tol=1e-5)

    robot = decoded["robot_description"]
    assert isinstance(robot, RobotAgentProperties)
    assert robot.vendor == "default"
    assert robot.max_pos_x_vel == 1.100000024 and robot.max_pos_ang_vel == 0.0
    assert robot.footprint.xy()[0] == (0.270000011, 0.349999994)
    assert robot.action_capability == ()
    assert robot.robot_id.octets == [0] * 15 + [1]


@pytest.mark.parametrize("name", REFERENCE_ATTRIBUTES)
def test_encoding_the_decoded_reference_gives_the_reference(name: str) -> None:
    encoded = encode_attribute(name, decode_attribute(name, REFERENCE[name]))
    assert encoded == REFERENCE[name]
    assert same_shape(encoded, REFERENCE[name]) == []


def same_shape(ours: Any, theirs: Any, path: str = "") -> list[str]:
    """Differences beyond ``==``: a number must stay a number and a bool a bool (1 == True in Python)."""
    if isinstance(theirs, dict):
        if not isinstance(ours, dict) or set(ours) != set(theirs):
            return [path]
        return [d for k in theirs for d in same_shape(ours[k], theirs[k], f"{path}.{k}")]
    if isinstance(theirs, list):
        if not isinstance(ours, list) or len(ours) != len(theirs):
            return [path]
        return [d for i, (a, b) in enumerate(zip(ours, theirs)) for d in same_shape(a, b, f"{path}[{i}]")]
    if isinstance(theirs, bool) != isinstance(ours, bool) or isinstance(theirs, str) != isinstance(ours, str):
        return [path]
    return [] if ours == theirs else [path]


def test_keyvalues_rendering_from_a_real_orion_decodes_the_same() -> None:
    key_values = EXCHANGES["get-robot_1-keyValues"]["response"]["body"]
    normalized = EXCHANGES["get-robot_1-normalized"]["response"]["body"]
    expected = decode_entity(REFERENCE)
    for entity, flag in ((key_values, None), (key_values, True), (normalized, None), (normalized, False)):
        decoded = decode_entity(entity, key_values=flag)
        assert decoded == expected
        assert [m.task_id.description for m in (decoded["action_assignment"], decoded["cancel_order"])] == [
            "task pickup at p1: task_1",
            "Cancel task pickup p1",
        ]


def test_attribute_value_endpoint_and_notifications_decode() -> None:
    """``GET .../attrs/<name>/value`` gives the keyValues rendering; notifications are normalized.

    The recording PATCHed only ``sequence_number`` (22, then 31, with ``length`` 20), so those real messages
    break R2 and must be rejected naming the field; the untouched attributes decode.
    """
    value = EXCHANGES["get-after-partial-patch"]["response"]["body"]
    notified = EXCHANGES["notif-patch-cancel_order"]["notification"]["body"]["data"][0]
    assert decode_attribute("cancel_order", notified["cancel_order"]) == decode_entity(REFERENCE)["cancel_order"]
    for attr, number in ((value, 22), (notified["motion_assignment"], 31)):
        with pytest.raises(CodecError) as info:
            decode_attribute("motion_assignment", attr)
        assert info.value.path == "motion_assignment.value.sequence.value.sequence_number"
        assert info.value.problem == f"must be 1..length=20, got {number}"
    with pytest.raises(CodecError):
        decode_entity(notified)  # all or nothing


def test_wrong_rendering_flag_is_a_codec_error() -> None:
    with pytest.raises(CodecError) as info:
        decode_attribute("cancel_order", REFERENCE["cancel_order"], key_values=True)
    assert info.value.path == "cancel_order.value.task_id"
    assert "missing field" in info.value.problem


def test_unknown_attributes_are_skipped_and_listed() -> None:
    entity = dict(REFERENCE, battery_level={"type": "Number", "value": 87.5})
    assert sorted(decode_entity(entity)) == REFERENCE_ATTRIBUTES
    assert unknown_attributes(entity) == ["battery_level"]
    assert unknown_attributes(REFERENCE) == []
    with pytest.raises(CodecError) as info:
        decode_attribute("battery_level", entity["battery_level"])
    assert (info.value.attribute, info.value.path) == ("battery_level", "battery_level")
    assert "unknown attribute" in info.value.problem


def test_encode_entity_matches_the_reference_entity() -> None:
    decoded = decode_entity(REFERENCE)
    entity = encode_entity(REFERENCE["id"], REFERENCE["type"], decoded)
    assert entity == REFERENCE


def test_every_attribute_type_name_comes_from_the_message() -> None:
    for name in REFERENCE_ATTRIBUTES:
        assert REFERENCE[name]["type"] == ATTRIBUTES[name].ROS_TYPE
