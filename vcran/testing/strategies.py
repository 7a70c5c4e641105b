"""Hypothesis strategies for vcran's messages, for vcran's tests and for users fuzzing a fleet manager.

:func:`messages_of` walks :func:`vcran.core.opil.schema.specs`, so every message type gets a strategy and a new
field is generated as soon as it is declared. Values cover each ROS type's whole range (int32 limits,
float32 limits, empty and non-ASCII strings, Orion's forbidden characters and ``%`` sequences), because
the codec must carry every valid message. Cross-field rules are respected where a message enforces them
(:func:`times`, :func:`sequences`, the known action codes of an ActionAssignment).
"""

from __future__ import annotations

from collections.abc import Callable
from functools import cache
from typing import Any, TypeVar, cast

from vcran.testing._extra import require_hypothesis

require_hypothesis(__name__)

from hypothesis import strategies as st

from vcran.core.opil.ids import Id
from vcran.core.opil.messages import (
    ACTION_CODES,
    ATTRIBUTES,
    CATEGORY_CODES,
    CATEGORY_UNDEFINED,
    ActionAssignment,
    AssignmentStatus,
    CancelTask,
    Motion,
    MotionAssignment,
    RanError,
    RanStatus,
    RobotAction,
    RobotAgentProperties,
    Sequence,
    Time,
)
from vcran.core.opil.schema import FLOAT32_MAX, INT_RANGES, FieldSpec, Message, specs

M = TypeVar("M", bound=Message)

#: Fragments that stress the Orion escape: every forbidden character, ``%`` and escape look-alikes.
_TRICKY = ["<", ">", '"', "'", "=", ";", "(", ")", "%", "%25", "%3C", "%3c", "%2", "%%", "/", "&", "?", "#"]


def ros_strings(max_size: int = 12) -> st.SearchStrategy[str]:
    """Any text, with Orion's forbidden characters and percent sequences mixed in often."""
    fragment = st.one_of(st.text(max_size=4), st.sampled_from(_TRICKY))
    return st.lists(fragment, max_size=max_size // 2).map("".join)


def primitives(ros: str) -> st.SearchStrategy[Any]:
    """Every valid value of a ROS primitive type (``float64``, ``uint8``, ``string``, ...). Floats are
    often signed zeros: 0.0 and -0.0 are equal numbers but different bytes (R9/R10)."""
    zeros = st.sampled_from([0.0, -0.0])
    if ros == "float64":
        return st.one_of(zeros, st.floats(allow_nan=False, allow_infinity=False))
    if ros == "float32":
        return st.one_of(zeros, st.floats(min_value=-FLOAT32_MAX, max_value=FLOAT32_MAX))
    if ros in INT_RANGES:
        lo, hi = INT_RANGES[ros]
        return st.integers(lo, hi)
    if ros == "string":
        return ros_strings()
    if ros == "bool":
        return st.booleans()
    raise ValueError(f"no strategy for ROS primitive {ros!r}")


def ids() -> st.SearchStrategy[Id]:
    """Any id: sixteen arbitrary bytes (nil included) and any description."""
    nil_or_any = st.one_of(st.just(bytes(16)), st.binary(min_size=16, max_size=16))
    return st.builds(Id, nil_or_any, st.one_of(st.just(""), ros_strings()))


def times() -> st.SearchStrategy[Time]:
    """Any valid ROS time: int32 seconds (negative too) and nanoseconds below one second."""
    lo, hi = INT_RANGES["int32"]
    return st.builds(Time, st.integers(lo, hi), st.integers(0, 999_999_999))


def sequences() -> st.SearchStrategy[Sequence]:
    """A valid position in a task: ``1 <= sequence_number <= length`` (R2)."""
    lengths = st.one_of(st.integers(1, 30), st.integers(1, INT_RANGES["int32"][1]))
    return lengths.flatmap(lambda n: st.builds(Sequence, st.integers(1, n), st.just(n)))


def robot_actions(known_only: bool = True) -> st.SearchStrategy[RobotAction]:
    """A RobotAction; with ``known_only`` its code is one vcran can perform (docs/contract.md §2 action codes)."""
    if not known_only:
        return cast(st.SearchStrategy[RobotAction], _generic(RobotAction))
    codes = st.one_of(
        st.tuples(st.sampled_from(sorted(CATEGORY_CODES)), primitives("uint8")),
        st.tuples(st.just(CATEGORY_UNDEFINED), st.sampled_from(sorted(ACTION_CODES))),
    )
    attributes = _field({s.name: s for s in specs(RobotAction)}["attributes"])
    return st.builds(
        lambda code, attrs, description: RobotAction(code[0], code[1], attrs, description),
        codes,
        attributes,
        primitives("string"),
    )


def messages_of(cls: type[M]) -> st.SearchStrategy[M]:
    """Any valid message of type ``cls``, derived from its field specs."""
    special = _CLASS_STRATEGIES.get(cls)
    return cast(st.SearchStrategy[M], special() if special else _generic(cast(type, cls)))


@cache
def _generic(cls: type[Message]) -> st.SearchStrategy[Message]:
    kwargs = {}
    for spec in specs(cls):
        override = _OVERRIDES.get((cls, spec.name))
        kwargs[spec.name] = override() if override else _field(spec)
    return st.builds(cls, **kwargs)


def _field(spec: FieldSpec) -> st.SearchStrategy[Any]:
    if spec.kind == "prim":
        return primitives(spec.ros)
    if spec.kind == "id":
        return ids()
    if spec.kind == "msg":
        return messages_of(cast(type[Message], spec.cls))
    if spec.cls is None:
        item = primitives(spec.ros[:-2])
    else:
        item = ids() if spec.cls is Id else messages_of(spec.cls)
    return st.lists(item, max_size=4).map(tuple)


#: Messages with cross-field rules, and fields that must hold more than their type allows.
_CLASS_STRATEGIES: dict[type[Message], Callable[[], st.SearchStrategy[Any]]] = {Time: times, Sequence: sequences}
_OVERRIDES: dict[tuple[type[Message], str], Callable[[], st.SearchStrategy[Any]]] = {
    (ActionAssignment, "robot_action"): robot_actions,
}


# --- one named strategy per RAN attribute (docs/contract.md §2) ------------------------------------------------------


def motion_assignments() -> st.SearchStrategy[MotionAssignment]:
    return messages_of(MotionAssignment)


def action_assignments() -> st.SearchStrategy[ActionAssignment]:
    return messages_of(ActionAssignment)


def cancel_tasks() -> st.SearchStrategy[CancelTask]:
    return messages_of(CancelTask)


def robot_descriptions() -> st.SearchStrategy[RobotAgentProperties]:
    return messages_of(RobotAgentProperties)


def motions() -> st.SearchStrategy[Motion]:
    return messages_of(Motion)


def assignment_statuses() -> st.SearchStrategy[AssignmentStatus]:
    return messages_of(AssignmentStatus)


def ran_statuses() -> st.SearchStrategy[RanStatus]:
    return messages_of(RanStatus)


def ran_errors() -> st.SearchStrategy[RanError]:
    return messages_of(RanError)


def attribute_messages() -> st.SearchStrategy[tuple[str, Message]]:
    """An attribute name of docs/contract.md §2 with a message of its type, every attribute equally likely."""
    return st.sampled_from(sorted(ATTRIBUTES)).flatmap(lambda name: st.tuples(st.just(name), messages_of(ATTRIBUTES[name])))
