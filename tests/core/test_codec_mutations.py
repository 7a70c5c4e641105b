"""Mutations of the reference entity: every one is a CodecError naming the precise field path (R12).

Each case mutates one place of a fresh copy of tests/data/opil_robot_entity.json, decodes the attribute
and checks the error's attribute, path and problem. A hypothesis fuzz then mutates random places with
random JSON and checks that nothing but CodecError ever escapes and that the path it names exists.
"""

from __future__ import annotations

import copy
import json
import re
from collections.abc import Callable
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tests.conftest import DATA
from vcran.core.opil.codec import CodecError, decode_attribute, decode_entity, encode_attribute

REFERENCE: dict[str, Any] = json.loads((DATA / "opil_robot_entity.json").read_text())
ATTRIBUTES = [k for k in REFERENCE if k not in ("id", "type")]

MA = "motion_assignment.value"
TASK_UUID = f"{MA}.task_id.value.uuid"
POINT_X = f"{MA}.point.value.x"
AA = "action_assignment.value"
STAMP = "current_motion.value.current_position.value.header.value.stamp"


def tokens(path: str) -> list[str | int]:
    """``a.value.b.value[3]`` -> ``["a", "value", "b", "value", 3]``."""
    return [int(t[1:-1]) if t.startswith("[") else t for t in re.findall(r"\[\d+\]|[^.\[\]]+", path)]


def parent_of(doc: Any, path: str) -> tuple[Any, str | int]:
    *head, last = tokens(path)
    for t in head:
        doc = doc[t]
    return doc, last


def deep(depth: int, leaf: Any = 1) -> Any:
    for _ in range(depth):
        leaf = [leaf]
    return leaf


def set_(path: str, value: Any) -> Callable[[dict[str, Any]], None]:
    def apply(entity: dict[str, Any]) -> None:
        parent, key = parent_of(entity, path)
        parent[key] = value

    return apply


def delete(path: str) -> Callable[[dict[str, Any]], None]:
    def apply(entity: dict[str, Any]) -> None:
        parent, key = parent_of(entity, path)
        del parent[key]

    return apply


def append(path: str, value: Any) -> Callable[[dict[str, Any]], None]:
    def apply(entity: dict[str, Any]) -> None:
        parent, key = parent_of(entity, path)
        parent[key].append(value)

    return apply


def rename(path: str, new: str) -> Callable[[dict[str, Any]], None]:
    def apply(entity: dict[str, Any]) -> None:
        parent, key = parent_of(entity, path)
        parent[new] = parent.pop(key)

    return apply


NAN, INF = float("nan"), float("inf")

# (case id, mutation, error path, fragment of the problem)
CASES: list[tuple[str, Callable[[dict[str, Any]], None], str, str]] = [
    ("drop-field", delete(POINT_X), POINT_X, "missing field of geometry_msgs.Pose2D"),
    ("drop-message", delete(f"{MA}.sequence"), f"{MA}.sequence", "missing field of mars_agent_physical_robot_msgs.MotionAssignment"),
    ("drop-id", delete("cancel_order.value.task_id"), "cancel_order.value.task_id", "missing field"),
    ("drop-uuid", delete(f"{MA}.task_id.value.uuid"), TASK_UUID, "missing field of mars_common_msgs.Id"),
    ("drop-value-member", delete(f"{POINT_X}.value"), POINT_X, "no value member"),
    ("rename-field", rename(POINT_X, "X"), POINT_X, "missing field"),
    ("extra-field", set_(f"{MA}.point.value.z", {"type": "number", "value": 0}), f"{MA}.point.value.z", "unknown field of geometry_msgs.Pose2D"),
    ("string-for-number", set_(f"{POINT_X}.value", "-0.916"), POINT_X, "expected a number, got str"),
    ("bool-for-number", set_(f"{POINT_X}.value", True), POINT_X, "expected a number, got bool"),
    ("null-for-number", set_(f"{POINT_X}.value", None), POINT_X, "expected a number, got NoneType"),
    ("object-for-number", set_(f"{POINT_X}.value", {"value": 1}), POINT_X, "expected a number, got dict"),
    ("nan", set_(f"{POINT_X}.value", NAN), POINT_X, "number must be finite, got nan"),
    ("infinity", set_(f"{POINT_X}.value", INF), POINT_X, "number must be finite, got inf"),
    ("-infinity", set_(f"{MA}.max_velocity.value.linear.value.x.value", -INF), f"{MA}.max_velocity.value.linear.value.x", "finite"),
    ("number-for-bool", set_(f"{MA}.is_waypoint.value", 1), f"{MA}.is_waypoint", "expected a boolean, got int"),
    ("string-for-bool", set_(f"{MA}.use_orientation.value", "false"), f"{MA}.use_orientation", "expected a boolean, got str"),
    ("uuid-15", delete(f"{TASK_UUID}.value[15]"), TASK_UUID, "expected 16 elements (uint8[16]), got 15"),
    ("uuid-17", append(f"{TASK_UUID}.value", {"type": "number", "value": 1}), TASK_UUID, "got 17"),
    ("uuid-empty", set_(f"{TASK_UUID}.value", []), TASK_UUID, "got 0"),
    ("uuid-string", set_(f"{TASK_UUID}.value", "4ce44dbe-a0ba-4d31-9137-f6ef6417fb49"), TASK_UUID, "expected an array of uint8[16], got '4ce44dbe"),
    ("byte-256", set_(f"{TASK_UUID}.value[3].value", 256), f"{TASK_UUID}.value[3]", "256 is outside the uint8 range 0..255"),
    ("byte-minus-1", set_(f"{TASK_UUID}.value[0].value", -1), f"{TASK_UUID}.value[0]", "-1 is outside the uint8 range 0..255"),
    ("byte-fraction", set_(f"{TASK_UUID}.value[5].value", 1.5), f"{TASK_UUID}.value[5]", "expected an integer, got float 1.5"),
    ("byte-bool", set_(f"{TASK_UUID}.value[5].value", False), f"{TASK_UUID}.value[5]", "expected an integer, got bool"),
    ("byte-unwrapped", set_(f"{TASK_UUID}.value[0]", 76), f"{TASK_UUID}.value[0]", "expected an NGSI {type, value} object, got 76"),
    ("description-lone-surrogate", set_(f"{MA}.task_id.value.description.value", "ab\udc00"), f"{MA}.task_id.value.description", "lone surrogate at index 2"),
    ("description-number", set_(f"{MA}.task_id.value.description.value", 5), f"{MA}.task_id.value.description", "expected a string, got int"),
    ("message-as-list", set_(f"{MA}.point.value", [1, 2, 0]), f"{MA}.point", "expected an object for geometry_msgs.Pose2D, got list"),
    ("message-as-string", set_("current_motion.value.current_velocity.value", "fast"), "current_motion.value.current_velocity", "expected an object for geometry_msgs.Twist, got 'fast'"),
    ("message-unwrapped", set_(f"{MA}.point", {"x": 1, "y": 2, "theta": 0}), f"{MA}.point", "no value member"),
    ("field-unwrapped", set_(POINT_X, -0.9), POINT_X, "expected an NGSI {type, value} object, got -0.9"),
    ("wrapper-extra-member", set_(f"{POINT_X}.unit", "m"), POINT_X, "unexpected member 'unit' beside type, value and metadata"),
    ("wrapper-type-number", set_(f"{MA}.point.type", 5), f"{MA}.point", "type must be a string, got 5"),
    ("metadata-not-object", set_("motion_assignment.metadata", "dataType"), "motion_assignment", "metadata must be an object"),
    ("value-not-object", set_("motion_assignment.value", 5), "motion_assignment", "expected an object for mars_agent_physical_robot_msgs.MotionAssignment, got 5"),
    ("attribute-not-object", set_("motion_assignment", [1]), "motion_assignment", "got list"),
    ("attribute-null", set_("cancel_order", None), "cancel_order", "got None"),
    ("array-not-list", set_(f"{MA}.motion_area.value.polygon.value.points.value", {}), f"{MA}.motion_area.value.polygon.value.points", "expected an array of geometry_msgs/Point32[], got dict"),
    ("array-item-bad", set_(f"{MA}.motion_area.value.polygon.value.points.value[2].value.x.value", "a"), f"{MA}.motion_area.value.polygon.value.points.value[2].value.x", "expected a number"),
    ("tuple-value-number", set_(f"{AA}.robot_action.value.attributes.value[0].value.value.value", 3), f"{AA}.robot_action.value.attributes.value[0].value.value", "expected a string"),
    ("deep-list-for-number", set_(f"{POINT_X}.value", deep(100_000)), POINT_X, "expected a number, got list"),
    ("deep-wrappers", set_(f"{MA}.header.value", deep(100_000, {"value": 1})), f"{MA}.header", "expected an object for std_msgs.Header, got list"),
    ("sequence-past-length", set_(f"{AA}.sequence.value.sequence_number.value", 24), f"{AA}.sequence.value.sequence_number", "must be 1..length=23, got 24"),
    ("sequence-zero", set_(f"{AA}.sequence.value.sequence_number.value", 0), f"{AA}.sequence.value.sequence_number", "must be 1..length=23, got 0"),
    ("length-zero", set_(f"{MA}.sequence.value.length.value", 0), f"{MA}.sequence.value.length", "must be at least 1, got 0"),
    ("length-int32-overflow", set_(f"{MA}.sequence.value.length.value", 2**31), f"{MA}.sequence.value.length", "2147483648 is outside the int32 range"),
    ("huge-int", set_(f"{MA}.header.value.seq.value", 10**5000), f"{MA}.header.value.seq", "a 16610-bit integer is outside the uint32 range"),
    ("seq-negative", set_(f"{MA}.header.value.seq.value", -1), f"{MA}.header.value.seq", "-1 is outside the uint32 range"),
    ("float32-overflow", set_("robot_description.value.max_pos_x_vel.value", 1e39), "robot_description.value.max_pos_x_vel", "does not fit a float32"),
    ("nsecs-one-second", set_(f"{STAMP}.value.nsecs.value", 1_000_000_000), f"{STAMP}.value.nsecs", "must be 0..999999999"),
    ("unknown-category", set_(f"{AA}.robot_action.value.category.value", 99), f"{AA}.robot_action.value.category", "unknown action category 99"),
    ("unknown-action-code", set_(f"{AA}.robot_action.value.category.value", 0), f"{AA}.robot_action.value.action", "unknown action code 5 with category 0"),
    ("category-out-of-uint8", set_(f"{AA}.robot_action.value.category.value", 300), f"{AA}.robot_action.value.category", "300 is outside the uint8 range"),
]


@pytest.mark.parametrize(("mutate", "path", "problem"), [c[1:] for c in CASES], ids=[c[0] for c in CASES])
def test_mutation_is_rejected_with_the_field_path(mutate: Callable[[dict[str, Any]], None], path: str, problem: str) -> None:
    entity = copy.deepcopy(REFERENCE)
    mutate(entity)
    attribute = path.split(".")[0]
    with pytest.raises(CodecError) as info:
        decode_attribute(attribute, entity[attribute])
    error = info.value
    assert (error.attribute, error.path) == (attribute, path)
    assert problem in error.problem
    assert str(error) == f"{path}: {error.problem}"
    assert len(str(error)) < 300
    with pytest.raises(CodecError):
        decode_entity(entity)  # nothing is half-decoded: the whole entity is refused


@pytest.mark.parametrize(("mutate", "path", "problem"), [c[1:] for c in CASES if ".value" in c[2]], ids=[c[0] for c in CASES if ".value" in c[2]])
def test_mutation_in_key_values_rendering_has_the_same_path(mutate: Callable[[dict[str, Any]], None], path: str, problem: str) -> None:
    entity = copy.deepcopy(REFERENCE)
    mutate(entity)
    attribute = path.split(".")[0]
    with pytest.raises(CodecError) as info:
        decode_attribute(attribute, entity[attribute]["value"], key_values=True)
    assert info.value.path == path


def test_the_reference_itself_decodes() -> None:
    """The control: without a mutation every attribute decodes (so the cases above test the mutation)."""
    for attribute in ATTRIBUTES:
        decode_attribute(attribute, REFERENCE[attribute])


# --- fuzz: random JSON in random places -----------------------------------------------------------------

json_values = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=5) | st.sampled_from([0, 1, 255, 256, -1, 1e39, 2**31, "\ud800", "%3C"]),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.sampled_from(["type", "value", "metadata", "x", "uuid"]) | st.text("abc", min_size=1, max_size=3), inner, max_size=4),
    max_leaves=12,
)


def places(value: Any, path: str) -> list[str]:
    """Every JSON path inside ``value``, in the codec's path notation."""
    out = [path]
    if isinstance(value, dict):
        for k, v in value.items():
            out += places(v, f"{path}.{k}")
    elif isinstance(value, list):
        for i, v in enumerate(value):
            out += places(v, f"{path}[{i}]")
    return out


def resolves(doc: Any, path: str) -> bool:
    """The path leads to a value in ``doc``, or names a missing member of an object that exists."""
    *head, last = tokens(path)
    try:
        for t in head:
            doc = doc[t]
    except (KeyError, IndexError, TypeError):
        return False
    return isinstance(doc, dict) or (isinstance(doc, list) and isinstance(last, int) and last < len(doc))


@pytest.mark.slow
@settings(suppress_health_check=[HealthCheck.too_slow], max_examples=300)
@given(st.data())
def test_random_mutations_raise_only_codec_errors_naming_a_real_place(data: st.DataObject) -> None:
    attribute = data.draw(st.sampled_from(ATTRIBUTES))
    entity = copy.deepcopy(REFERENCE)
    place = data.draw(st.sampled_from(places(entity[attribute], attribute)))
    if data.draw(st.booleans()) and "." in place and not place.endswith("]"):
        mutate = delete(place)
    else:
        mutate = set_(place, data.draw(json_values))
    if place == attribute:
        entity[attribute] = data.draw(json_values)
    else:
        mutate(entity)
    try:
        message = decode_attribute(attribute, entity[attribute])
    except CodecError as error:
        assert error.attribute == attribute
        attr = entity[attribute]
        normalized = isinstance(attr, dict) and "value" in attr  # else read as keyValues: value is virtual
        assert resolves({attribute: attr if normalized else {"value": attr}}, error.path), error.path
    else:  # the mutation kept it valid (e.g. a wrapper type renamed): it must encode again
        encode_attribute(attribute, message)
