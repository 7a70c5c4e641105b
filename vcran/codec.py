"""The OPIL/FIROS NGSI v2 codec: RAN messages to and from Orion's entity format (SPEC §2, R12).

On the wire every attribute is ``{"type": "<pkg>.<Msg>", "value": {...}, "metadata": {"dataType": ...}}``
and every field inside ``value`` is again a ``{"type", "value"}`` wrapper, down to single uuid bytes
(docs/wire-format.md has the full picture). The walk is mechanical, so it is compiled once per message
class from :func:`vcran.schema.specs` into closures: the live transport encodes ``current_motion`` for a
thousand robots every second and must not re-derive field lists per call.

Decoding is strict on structure and values and lenient on names that carry no information: a wrapper's
``type`` may be any string (or absent) and metadata is ignored, because the schema already fixes every
field's type and fleet managers spell these names differently. Whatever is wrong raises
:class:`CodecError` naming the NGSI path of the offending field; a decode raises nothing else and never
returns a partly decoded message.

Strings are made safe for Orion by a reversible escape (:func:`escape_string`) instead of being refused,
because vcran's own error messages (``length=3``, ``(known: 0, 5)``) are full of characters Orion forbids.
"""

from __future__ import annotations

import json
import re
import sys
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from functools import cache
from operator import attrgetter
from typing import Any

from vcran.ids import Id
from vcran.messages import ATTRIBUTES
from vcran.orion_rules import MAX_REQUEST_BYTES, identifier_error
from vcran.schema import (
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
_PRIMITIVE_TYPES = {"float64": "number", "float32": "number", "int32": "number", "uint32": "number",
                    "uint8": "number", "string": "string", "bool": "boolean"}  # fmt: skip
_WRAPPER_KEYS = frozenset({"type", "value", "metadata"})
_MISSING = object()


class CodecError(ValueError):
    """A value that cannot cross the NGSI boundary; the one error type a decode may raise (R12).

    ``path`` is the NGSI path of the offending field in the normalized rendering, e.g.
    ``motion_assignment.value.point.value.x`` or ``cancel_order.value.task_id.value.uuid.value[3]``;
    ``attribute`` is the attribute it belongs to (empty for entity-level problems).
    """

    def __init__(self, attribute: str, path: str, problem: str) -> None:
        super().__init__(f"{path}: {problem}")
        self.attribute = attribute
        self.path = path
        self.problem = problem

    def __reduce__(self) -> tuple[Any, ...]:
        return (type(self), (self.attribute, self.path, self.problem))


class _Fault(Exception):
    """A decode problem on its way out, carrying its path relative to the value being decoded.

    ``suffix`` is ``""`` for the value itself, else starts with ``.field`` or ``[index]``. Paths are
    built only on the way out, so the happy path never formats a string.
    """

    def __init__(self, suffix: str, problem: str) -> None:
        self.suffix = suffix
        self.problem = problem

    def within(self, step: str) -> _Fault:
        """The same fault seen one wrapper further out; ``step`` is ``.name`` or ``[i]``."""
        return _Fault(_step(step, self.suffix), self.problem)


def _step(step: str, suffix: str) -> str:
    """The path of ``suffix`` (relative to a wrapper's value) seen from outside the wrapper at ``step``."""
    return f"{step}.value{suffix}" if suffix else step


# --- strings: the Orion-safe escape ------------------------------------------------------------------

#: Orion's forbidden characters plus ``%`` itself (so that the escape is reversible), as ``%XX``.
_ESCAPED = frozenset('<>"\'=;()%')
_ESCAPES = {ord(c): f"%{ord(c):02X}" for c in _ESCAPED}
_UNESCAPE = re.compile(r"%(2[25789]|3[B-Eb-e])")


def escape_string(text: str) -> str:
    """Percent-encode exactly ``< > " ' = ; ( ) %``: Orion accepts the result, and it is reversible."""
    return text if _ESCAPED.isdisjoint(text) else text.translate(_ESCAPES)


def unescape_string(text: str) -> str:
    """Undo :func:`escape_string` in one left-to-right pass; any other ``%`` sequence stays as it is."""
    return _UNESCAPE.sub(lambda m: chr(int(m.group(1), 16)), text) if "%" in text else text


# --- decoding ------------------------------------------------------------------------------------------

Decoder = Callable[[Any], Any]


def _unwrap(wrapper: Any) -> Any:
    """The ``value`` of a ``{"type", "value", "metadata"}`` wrapper, checking the wrapper's shape."""
    if type(wrapper) is dict and len(wrapper) == 2 and type(wrapper.get("type")) is str:
        value = wrapper.get("value", _MISSING)
        if value is not _MISSING:  # the usual FIROS shape: nothing more to check
            return value
    if not isinstance(wrapper, dict):
        raise _Fault("", f"expected an NGSI {{type, value}} object, got {short_repr(wrapper)}")
    value = wrapper.get("value", _MISSING)
    if value is _MISSING:
        raise _Fault("", "the NGSI object has no value member")
    if len(wrapper) > 1:
        if not wrapper.keys() <= _WRAPPER_KEYS:
            extra = min(str(k) for k in wrapper.keys() - _WRAPPER_KEYS)
            raise _Fault("", f"unexpected member {extra!r} beside type, value and metadata")
        if not isinstance(wrapper.get("type", ""), str):
            raise _Fault("", f"type must be a string, got {short_repr(wrapper['type'])}")
        if not isinstance(wrapper.get("metadata", {}), dict):
            raise _Fault("", f"metadata must be an object, got {short_repr(wrapper['metadata'])}")
    return value


def _object_decoder(ros_type: str, fields: tuple[tuple[str, Decoder], ...], build: Callable[..., Any]) -> Decoder:
    """Decode an object of wrapped fields (a message or an Id) and build it; all fields must be there."""
    names = frozenset(name for name, _ in fields)

    def decode(value: Any) -> Any:
        if not isinstance(value, dict):
            raise _Fault("", f"expected an object for {ros_type}, got {short_repr(value)}")
        kwargs = {}
        for name, decode_field in fields:
            wrapper = value.get(name, _MISSING)
            if wrapper is _MISSING:
                raise _Fault(f".{name}", f"missing field of {ros_type}")
            try:
                kwargs[name] = decode_field(_unwrap(wrapper))
            except _Fault as fault:
                raise fault.within(f".{name}") from None
        if len(value) != len(fields):
            extra = min(str(k) for k in value.keys() - names)
            raise _Fault(f".{extra}", f"unknown field of {ros_type}")
        try:
            return build(**kwargs)
        except MessageError as exc:  # a cross-field rule of the message (R2 sequence, action code)
            raise _Fault(_suffix(exc.path), exc.problem) from None

    return decode


def _suffix(message_path: str) -> str:
    """A MessageError's dotted path (``robot_action.category``, ``points[2].x``) as an NGSI suffix."""
    suffix = ""
    for token in reversed(re.findall(r"\[\d+\]|[^.\[]+", message_path)):
        suffix = _step(token if token.startswith("[") else f".{token}", suffix)
    return suffix


def _primitive_decoder(ros: str) -> Decoder:
    # Fast paths for what JSON gives for valid input; everything else goes through check_primitive.
    lo, hi = INT_RANGES.get(ros, (0, -1))
    exact = float if ros in ("float64", "float32") else int if ros in INT_RANGES else None
    if ros == "float32":
        lo, hi = -FLOAT32_MAX, FLOAT32_MAX
    elif exact is float:
        lo, hi = -sys.float_info.max, sys.float_info.max

    def decode(value: Any) -> Any:
        if type(value) is exact and lo <= value <= hi:  # excludes NaN and infinities too
            return value
        try:
            checked = check_primitive(ros, value)
        except MessageError as exc:
            raise _Fault("", exc.problem) from None
        return unescape_string(checked) if ros == "string" else checked

    return decode


def _array_decoder(item: Decoder, what: str, length: int | None = None) -> Decoder:
    def decode(value: Any) -> tuple[Any, ...]:
        if not isinstance(value, list):
            raise _Fault("", f"expected an array of {what}, got {short_repr(value)}")
        if length is not None and len(value) != length:
            raise _Fault("", f"expected {length} elements ({what}), got {len(value)}")
        out = []
        for i, wrapper in enumerate(value):
            try:
                out.append(item(_unwrap(wrapper)))
            except _Fault as fault:
                raise fault.within(f"[{i}]") from None
        return tuple(out)

    return decode


_decode_id = _object_decoder(
    ID_TYPE,
    (("uuid", _array_decoder(_primitive_decoder("uint8"), UUID_DATATYPE, 16)), ("description", _primitive_decoder("string"))),
    lambda uuid, description: Id(bytes(uuid), description),
)


def _item_spec(array: FieldSpec) -> FieldSpec:
    """The spec of one element of an array field (``geometry_msgs/Point32[]`` -> a Point32 message)."""
    if array.cls is None:
        return FieldSpec(array.name, "prim", array.ros[:-2])
    if array.cls is Id:
        return FieldSpec(array.name, "id", ID_TYPE, Id)
    return FieldSpec(array.name, "msg", array.cls.ROS_TYPE, array.cls)


def _field_decoder(spec: FieldSpec) -> Decoder:
    if spec.kind == "prim":
        return _primitive_decoder(spec.ros)
    if spec.kind == "id":
        return _decode_id
    if spec.kind == "msg":
        return _message_decoder(spec.cls)  # type: ignore[arg-type]
    return _array_decoder(_field_decoder(_item_spec(spec)), spec.ros)


@cache
def _message_decoder(cls: type[Message]) -> Decoder:
    fields = tuple((spec.name, _field_decoder(spec)) for spec in specs(cls))
    return _object_decoder(cls.ROS_TYPE, fields, cls)


# --- encoding ------------------------------------------------------------------------------------------

Encoder = Callable[[Any], dict[str, Any]]


def _datatype(spec: FieldSpec) -> Any:
    """The ``metadata.dataType`` entry of a field: a ROS type name, or a tree for a nested message."""
    if spec.kind == "id":
        return {"uuid": UUID_DATATYPE, "description": "string"}
    if spec.kind == "msg":
        return {s.name: _datatype(s) for s in specs(spec.cls)}  # type: ignore[arg-type]
    return spec.ros


def _fresh(tree: dict[str, Any]) -> dict[str, Any]:
    """A new copy of a dataType tree, so that no two encoded attributes share a mutable object."""
    return {k: v if isinstance(v, str) else _fresh(v) for k, v in tree.items()}


def _encode_id(ident: Id) -> dict[str, Any]:
    return {
        "type": ID_TYPE,
        "value": {
            "uuid": {
                "type": "array",
                "value": [{"type": "number", "value": b} for b in ident.uuid],
                "metadata": {"dataType": {"type": "dataType", "value": UUID_DATATYPE}},
            },
            "description": {"type": "string", "value": escape_string(ident.description)},
        },
    }


def _field_encoder(spec: FieldSpec) -> Encoder:
    """Encode one field (or array item) as its ``{"type", "value"}`` wrapper."""
    if spec.kind == "prim":
        wire_type = _PRIMITIVE_TYPES[spec.ros]
        if wire_type == "string":
            return lambda v: {"type": "string", "value": escape_string(v)}
        return lambda v: {"type": wire_type, "value": v}
    if spec.kind == "id":
        return _encode_id
    if spec.kind == "msg":
        encode_value, ros_type = _message_encoder(spec.cls), spec.ros  # type: ignore[arg-type]
        return lambda v: {"type": ros_type, "value": encode_value(v)}
    item, datatype = _field_encoder(_item_spec(spec)), spec.ros
    return lambda v: {
        "type": "array",
        "value": [item(x) for x in v],
        "metadata": {"dataType": {"type": "dataType", "value": datatype}},
    }


@cache
def _message_encoder(cls: type[Message]) -> Callable[[Message], dict[str, Any]]:
    """Encode a message's fields into the object that becomes its wrapper's ``value``."""
    names = tuple(spec.name for spec in specs(cls))
    encoders = tuple(_field_encoder(spec) for spec in specs(cls))
    get = attrgetter(*names) if len(names) > 1 else lambda m: (getattr(m, names[0]),)

    def encode(message: Message) -> dict[str, Any]:
        return {name: enc(v) for name, enc, v in zip(names, encoders, get(message))}

    return encode


# --- attributes and entities ----------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class _Plan:
    """Everything the codec needs for one attribute, derived once at import."""

    cls: type[Message]
    decode: Decoder
    encode: Callable[[Message], dict[str, Any]]
    datatype: dict[str, Any]


def _plan(cls: type[Message]) -> _Plan:
    # keyValues detection (a "value" member means normalized) relies on this; see decode_attribute.
    assert all(s.name != "value" for s in specs(cls)), f"{cls.__name__} has a field named value"
    datatype = {s.name: _datatype(s) for s in specs(cls)}
    return _Plan(cls, _message_decoder(cls), _message_encoder(cls), datatype)


_PLANS: dict[str, _Plan] = {name: _plan(cls) for name, cls in ATTRIBUTES.items()}


def _plan_for(name: Any) -> _Plan:
    plan = _PLANS.get(name) if isinstance(name, str) else None
    if plan is None:
        shown = name if isinstance(name, str) else short_repr(name)
        raise CodecError(shown, shown, f"unknown attribute (known: {', '.join(_PLANS)})")
    return plan


def decode_attribute(name: str, attr: Any, *, key_values: bool | None = None) -> Message:
    """Decode one attribute as Orion renders it: normalized, or keyValues (just the value object).

    ``key_values=None`` detects the rendering: an object with a ``value`` member is normalized (no RAN
    message has a field called ``value``). Raises :class:`CodecError` and nothing else.
    """
    plan = _plan_for(name)
    try:
        if key_values is None:
            key_values = not (isinstance(attr, dict) and "value" in attr)
        return plan.decode(attr if key_values else _unwrap(attr))  # type: ignore[no-any-return]
    except _Fault as fault:
        raise CodecError(name, _step(name, fault.suffix), fault.problem) from None


def encode_attribute(name: str, message: Message) -> dict[str, Any]:
    """The normalized NGSI attribute, in the shape of the OPIL reference entity; strings escaped."""
    plan = _plan_for(name)
    if type(message) is not plan.cls:
        problem = f"expected a {plan.cls.__name__} message, got {type(message).__name__}"
        raise CodecError(name, name, problem)
    return {
        "type": plan.cls.ROS_TYPE,
        "value": plan.encode(message),
        "metadata": {"dataType": {"type": "dataType", "value": _fresh(plan.datatype)}},
    }


def decode_entity(entity: Any, *, key_values: bool | None = None) -> dict[str, Message]:
    """Every RAN attribute of an entity, all or nothing; ``id``, ``type`` and unknown attributes are
    skipped (an Orion entity may carry other attributes; :func:`unknown_attributes` lists them)."""
    if not isinstance(entity, dict):
        raise CodecError("", "entity", f"expected an entity object, got {short_repr(entity)}")
    return {
        name: decode_attribute(name, attr, key_values=key_values)
        for name, attr in entity.items()
        if name in _PLANS
    }


def unknown_attributes(entity: dict[str, Any]) -> list[str]:
    """The attribute names of an entity that :func:`decode_entity` skips, in entity order."""
    return [str(name) for name in entity if name not in _PLANS and name not in ("id", "type")]


def encode_entity(entity_id: str, entity_type: str, messages: dict[str, Message]) -> dict[str, Any]:
    """A whole entity for ``POST /v2/entities`` or a batch update; identifiers checked against Orion's rules."""
    for field, kind, name in (("id", "entity id", entity_id), ("type", "entity type", entity_type)):
        problem = identifier_error(kind, name)
        if problem is not None:
            raise CodecError("", field, problem)
    entity: dict[str, Any] = {"id": entity_id, "type": entity_type}
    for name, message in messages.items():
        entity[name] = encode_attribute(name, message)
    return entity


def split_batch(
    entities: Iterable[dict[str, Any]], limit: int = MAX_REQUEST_BYTES, *, action_type: str = "append"
) -> list[bytes]:
    """Compact ``POST /v2/op/update`` bodies of at most ``limit`` bytes each, entities in order.

    Orion answers 413 to a larger request (1 MiB by default), so the live transport sends one body per
    element. An entity too large to fit a body on its own raises :class:`CodecError`.
    """
    head = b'{"actionType":' + json.dumps(action_type).encode() + b',"entities":['
    tail = b"]}"
    bodies: list[bytes] = []
    chunk: list[bytes] = []
    size = len(head) + len(tail)
    for entity in entities:
        data = json.dumps(entity, separators=(",", ":"), allow_nan=False).encode()
        if len(head) + len(data) + len(tail) > limit:
            where = str(entity.get("id", "entity"))
            raise CodecError("", where, f"entity encodes to {len(data)} bytes, too large for a {limit}-byte update")
        if chunk and size + 1 + len(data) > limit:
            bodies.append(head + b",".join(chunk) + tail)
            chunk, size = [], len(head) + len(tail)
        size += len(data) + (1 if chunk else 0)
        chunk.append(data)
    if chunk:
        bodies.append(head + b",".join(chunk) + tail)
    return bodies


__all__ = [
    "CodecError",
    "decode_attribute",
    "decode_entity",
    "encode_attribute",
    "encode_entity",
    "escape_string",
    "split_batch",
    "unescape_string",
    "unknown_attributes",
]
