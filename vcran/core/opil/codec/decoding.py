"""Decoding FIROS-wrapped NGSI values into messages: strict on structure and values, lenient on names.

Every field is a ``{"type", "value", "metadata"}`` wrapper. Its ``type`` may be any string or absent,
and ``metadata`` any object: the schema already fixes each field's type, and fleet managers spell these
names differently (``number``/``Number``/``float64``, ``geometry_msgs.Pose2D``/``geometry_msgs/Pose2D``).
Everything else is checked: a missing or unknown field, a value of the wrong JSON kind, a number out of
its ROS range or not finite, a uuid not of 16 bytes 0..255, and the messages' own cross-field rules
(R2 sequence, action codes). A problem travels out as a :class:`Fault` whose path is built on the way
out, so the happy path never formats a string; the decoder walks the schema, never the input, so its
recursion depth is that of the message types whatever the input's nesting.
"""

from __future__ import annotations

import re
import sys
from collections.abc import Callable
from typing import Any, cast

from vcran.core.opil.codec.strings import unescape_string
from vcran.core.opil.ids import Id
from vcran.core.opil.schema import (
    FLOAT32_MAX,
    INT_RANGES,
    FieldSpec,
    Message,
    MessageError,
    check_primitive,
    short_repr,
    specs,
)

ID_TYPE = "mars_common_msgs.Id"
UUID_DATATYPE = "uint8[16]"
_WRAPPER_KEYS = frozenset({"type", "value", "metadata"})
_MISSING = object()

Decoder = Callable[[Any], Any]


class Fault(Exception):
    """A decode problem on its way out, with its path relative to the value being decoded.

    ``suffix`` is ``""`` for the value itself, else starts with ``.field`` or ``[index]``.
    """

    def __init__(self, suffix: str, problem: str) -> None:
        self.suffix = suffix
        self.problem = problem

    def within(self, step: str) -> Fault:
        """The same fault seen from outside the wrapper at ``step`` (``.name`` or ``[i]``)."""
        return Fault(step_into(step, self.suffix), self.problem)


def step_into(step: str, suffix: str) -> str:
    """The path of ``suffix`` (relative to a wrapper's value) seen from outside the wrapper at ``step``.

    A problem with the field itself is reported at the field (``point``); one inside its value goes
    through ``value`` (``point.value.x``), as in the normalized rendering.
    """
    return f"{step}.value{suffix}" if suffix else step


def unwrap(wrapper: Any) -> Any:
    """The ``value`` of a ``{"type", "value", "metadata"}`` wrapper, checking the wrapper's shape."""
    if type(wrapper) is dict and len(wrapper) == 2 and type(wrapper.get("type")) is str:
        value = wrapper.get("value", _MISSING)
        if value is not _MISSING:  # the usual FIROS shape: nothing more to check
            return value
    if not isinstance(wrapper, dict):
        raise Fault("", f"expected an NGSI {{type, value}} object, got {short_repr(wrapper)}")
    value = wrapper.get("value", _MISSING)
    if value is _MISSING:
        raise Fault("", "the NGSI object has no value member")
    if not wrapper.keys() <= _WRAPPER_KEYS:
        extra = min(str(k) for k in wrapper.keys() - _WRAPPER_KEYS)
        raise Fault("", f"unexpected member {extra!r} beside type, value and metadata")
    if not isinstance(wrapper.get("type", ""), str):
        raise Fault("", f"type must be a string, got {short_repr(wrapper['type'])}")
    if not isinstance(wrapper.get("metadata", {}), dict):
        raise Fault("", f"metadata must be an object, got {short_repr(wrapper['metadata'])}")
    return value


def _object_decoder(ros_type: str, fields: tuple[tuple[str, Decoder], ...], build: Callable[..., Any]) -> Decoder:
    """Decode an object of wrapped fields (a message or an Id) and build it; all fields must be there."""
    names = frozenset(name for name, _ in fields)

    def decode(value: Any) -> Any:
        if not isinstance(value, dict):
            raise Fault("", f"expected an object for {ros_type}, got {short_repr(value)}")
        kwargs = {}
        for name, decode_field in fields:
            wrapper = value.get(name, _MISSING)
            if wrapper is _MISSING:
                raise Fault(f".{name}", f"missing field of {ros_type}")
            try:
                kwargs[name] = decode_field(unwrap(wrapper))
            except Fault as fault:
                raise fault.within(f".{name}") from None
        if len(value) != len(fields):
            extra = min(str(k) for k in value.keys() - names)
            raise Fault(f".{extra}", f"unknown field of {ros_type}")
        try:
            return build(**kwargs)
        except MessageError as exc:  # a cross-field rule of the message (R2 sequence, action code)
            raise Fault(_suffix(exc.path), exc.problem) from None

    return decode


def _suffix(message_path: str) -> str:
    """A MessageError's dotted path (``robot_action.category``, ``points[2].x``) as a Fault suffix."""
    suffix = ""
    for token in reversed(re.findall(r"\[\d+\]|[^.\[]+", message_path)):
        suffix = step_into(token if token.startswith("[") else f".{token}", suffix)
    return suffix


def _primitive_decoder(ros: str) -> Decoder:
    # A fast path for what JSON gives for valid input; everything else goes through check_primitive.
    exact: Any = float if ros.startswith("float") else int if ros in INT_RANGES else None
    bounds: tuple[float, float] = INT_RANGES.get(ros, (0, -1))
    if ros == "float32":
        bounds = (-FLOAT32_MAX, FLOAT32_MAX)
    elif ros == "float64":
        bounds = (-sys.float_info.max, sys.float_info.max)
    lo, hi = bounds

    def decode(value: Any) -> Any:
        if type(value) is exact and lo <= value <= hi:  # excludes NaN and the infinities too
            return value
        try:
            checked = check_primitive(ros, value)
        except MessageError as exc:
            raise Fault("", exc.problem) from None
        return unescape_string(checked) if ros == "string" else checked

    return decode


def _array_decoder(item: Decoder, what: str, length: int | None = None) -> Decoder:
    def decode(value: Any) -> tuple[Any, ...]:
        if not isinstance(value, list):
            raise Fault("", f"expected an array of {what}, got {short_repr(value)}")
        if length is not None and len(value) != length:
            raise Fault("", f"expected {length} elements ({what}), got {len(value)}")
        out = []
        for i, wrapper in enumerate(value):
            try:
                out.append(item(unwrap(wrapper)))
            except Fault as fault:
                raise fault.within(f"[{i}]") from None
        return tuple(out)

    return decode


decode_id = _object_decoder(
    ID_TYPE,
    (
        ("uuid", _array_decoder(_primitive_decoder("uint8"), UUID_DATATYPE, 16)),
        ("description", _primitive_decoder("string")),
    ),
    lambda uuid, description: Id(bytes(uuid), description),
)


def item_spec(array: FieldSpec) -> FieldSpec:
    """The spec of one element of an array field (``geometry_msgs/Point32[]`` -> a Point32 message)."""
    if array.cls is None:
        return FieldSpec(array.name, "prim", array.ros[:-2])
    if array.cls is Id:
        return FieldSpec(array.name, "id", ID_TYPE, Id)
    return FieldSpec(array.name, "msg", cast(type[Message], array.cls).ROS_TYPE, array.cls)


def _field_decoder(spec: FieldSpec) -> Decoder:
    if spec.kind == "prim":
        return _primitive_decoder(spec.ros)
    if spec.kind == "id":
        return decode_id
    if spec.kind == "msg":
        return message_decoder(cast(type[Message], spec.cls))
    return _array_decoder(_field_decoder(item_spec(spec)), spec.ros)


_DECODERS: dict[type, Decoder] = {}


def message_decoder(cls: type[Message]) -> Decoder:
    """Decode the value object of a ``cls`` (its fields, each wrapped) into a ``cls``; raises Fault.
    Built once per class (a dict rather than functools.cache, which mypy cannot type for classes)."""
    decoder = _DECODERS.get(cls)
    if decoder is None:
        fields = tuple((spec.name, _field_decoder(spec)) for spec in specs(cls))
        decoder = _DECODERS[cls] = _object_decoder(cls.ROS_TYPE, fields, cls)
    return decoder
