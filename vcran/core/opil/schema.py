"""The one description of every message's fields, shared by validation, plain JSON and the NGSI codec.

Messages are frozen dataclasses whose annotations name ROS field types (``Float64``, ``UInt8``, nested
messages, tuples of messages). From those annotations this module derives, once per class, a tuple of
:class:`FieldSpec`. Three consumers read it: :meth:`Message.__post_init__` (a message validates itself,
h11-style, so no invalid message exists anywhere in vcran), :mod:`vcran.core.opil.plain` (trace and ``vcran decode``
JSON) and :mod:`vcran.core.opil.codec` (the OPIL/FIROS NGSI encoding, which needs the ROS type names for its
``dataType`` metadata). Keeping the field list in one place means a new field cannot be validated but
forgotten on the wire, or the other way round.
"""

from __future__ import annotations

import math
import typing
from dataclasses import dataclass, fields
from typing import Annotated, Any, ClassVar, TypeVar

from vcran.core.opil.ids import Id, IdError

# ROS primitive types. The metadata string is the ROS name used in OPIL's dataType metadata.
Float64 = Annotated[float, "float64"]
Float32 = Annotated[float, "float32"]
Int32 = Annotated[int, "int32"]
UInt32 = Annotated[int, "uint32"]
UInt8 = Annotated[int, "uint8"]
String = Annotated[str, "string"]
Bool = Annotated[bool, "bool"]

INT_RANGES: dict[str, tuple[int, int]] = {
    "int32": (-(2**31), 2**31 - 1),
    "uint32": (0, 2**32 - 1),
    "uint8": (0, 255),
}
FLOAT32_MAX = 3.4028234663852886e38
M = TypeVar("M")


class MessageError(ValueError):
    """A message field holds a value the message cannot have.

    ``path`` is the dotted field path inside the message (``sequence.sequence_number``); the codec
    prefixes it with the attribute and turns it into an NGSI path. ``problem`` says what is wrong.
    """

    def __init__(self, path: str, problem: str) -> None:
        super().__init__(f"{path}: {problem}" if path else problem)
        self.path = path
        self.problem = problem

    def within(self, outer: str) -> MessageError:
        """The same error seen from the enclosing message, one field further out."""
        return MessageError(f"{outer}.{self.path}" if self.path else outer, self.problem)


@dataclass(frozen=True, slots=True)
class FieldSpec:
    """One field of a message: its name, kind and ROS type.

    kind is ``prim`` (ros is the primitive name), ``id`` (a mars_common_msgs/Id), ``msg`` (cls is a
    nested message) or ``array`` (a tuple of cls messages, or of primitives when cls is None).
    """

    name: str
    kind: str
    ros: str
    cls: type | None = None


class Message:
    """Base of every message: validates its fields on construction (see module docstring)."""

    __slots__ = ()
    ROS_TYPE: ClassVar[str] = ""

    def __post_init__(self) -> None:
        for name, fast, spec in _plan(type(self)):
            value = getattr(self, name)
            if fast(value):
                continue
            try:
                checked = _check(spec, value)
            except MessageError as exc:
                raise exc.within(name) from None
            if checked is not value:
                object.__setattr__(self, name, checked)
        self._check_semantics()

    def _check_semantics(self) -> None:
        """Cross-field rules of one message type; raise MessageError naming the field."""


def _fast(spec: FieldSpec) -> Any:
    """A cheap predicate that accepts the common, valid case of a field; anything else takes the full
    check (which normalises or raises). Validation runs on every message built, so this matters."""
    if spec.kind == "prim":
        if spec.ros in ("float64", "float32"):
            limit = FLOAT32_MAX if spec.ros == "float32" else math.inf
            return lambda v: type(v) is float and -limit < v < limit
        if spec.ros in INT_RANGES:
            lo, hi = INT_RANGES[spec.ros]
            return lambda v: type(v) is int and lo <= v <= hi
        if spec.ros == "string":  # non-ASCII takes the full check (lone surrogates)
            return lambda v: type(v) is str and v.isascii()
        return lambda v: type(v) is bool
    if spec.kind == "array":
        item = spec.cls
        if item is None:
            return lambda v: False
        return lambda v: type(v) is tuple and all(type(i) is item for i in v)
    cls = spec.cls
    return lambda v: type(v) is cls


_PLANS: dict[type, tuple[tuple[str, Any, FieldSpec], ...]] = {}


def _plan(cls: type) -> tuple[tuple[str, Any, FieldSpec], ...]:
    found = _PLANS.get(cls)
    if found is None:
        found = _PLANS[cls] = tuple((spec.name, _fast(spec), spec) for spec in specs(cls))
    return found


def _check(spec: FieldSpec, value: Any) -> Any:
    if spec.kind == "prim":
        return check_primitive(spec.ros, value)
    if spec.kind == "id":
        if not isinstance(value, Id):
            raise MessageError("", f"expected an Id, got {type(value).__name__}")
        return value
    if spec.kind == "msg":
        if not isinstance(value, spec.cls):  # type: ignore[arg-type]
            raise MessageError("", f"expected {spec.cls.__name__}, got {type(value).__name__}")  # type: ignore[union-attr]
        return value
    # array
    if isinstance(value, list):
        value = tuple(value)
    if not isinstance(value, tuple):
        raise MessageError("", f"expected an array, got {type(value).__name__}")
    for i, item in enumerate(value):
        if spec.cls is not None and not isinstance(item, spec.cls):
            raise MessageError(f"[{i}]", f"expected {spec.cls.__name__}, got {type(item).__name__}")
    return value


def short_repr(value: Any, limit: int = 40) -> str:
    """A bounded description of an untrusted value for an error message.

    ``repr`` of wire input is unsafe in errors: a deeply nested list raises RecursionError, an integer of
    more than 4300 digits raises ValueError, and a megabyte string floods the log. Scalars show their
    value (cut at ``limit`` characters), containers only their type.
    """
    if isinstance(value, int) and not isinstance(value, bool) and value.bit_length() > 64:
        return f"a {value.bit_length()}-bit integer"
    if value is None or isinstance(value, (bool, int, float)):
        return repr(value)
    if isinstance(value, str):
        return repr(value) if len(value) <= limit else repr(value[:limit]) + "..."
    return type(value).__name__


def check_primitive(ros: str, value: Any) -> Any:
    """Check (and for floats, normalise) one primitive value; return what the message should hold."""
    if ros in ("float64", "float32"):
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise MessageError("", f"expected a number, got {type(value).__name__}")
        try:
            value = float(value)
        except OverflowError:  # an int beyond the float range (JSON allows 1000-digit numbers)
            raise MessageError("", f"number {short_repr(value)} does not fit a {ros}") from None
        if not math.isfinite(value):
            raise MessageError("", f"number must be finite, got {value!r}")
        if ros == "float32" and abs(value) > FLOAT32_MAX:
            raise MessageError("", f"number {value!r} does not fit a float32")
        return value
    if ros in INT_RANGES:
        if isinstance(value, float) and value.is_integer():
            value = int(value)
        if isinstance(value, bool) or not isinstance(value, int):
            raise MessageError("", f"expected an integer, got {type(value).__name__} {short_repr(value)}")
        lo, hi = INT_RANGES[ros]
        if not lo <= value <= hi:
            raise MessageError("", f"{short_repr(value)} is outside the {ros} range {lo}..{hi}")
        return value
    if ros == "string":
        if not isinstance(value, str):
            raise MessageError("", f"expected a string, got {type(value).__name__}")
        if not value.isascii():  # JSON can carry a lone surrogate, which no UTF-8 output can write
            try:
                value.encode("utf-8")
            except UnicodeEncodeError as exc:
                raise MessageError("", f"not valid Unicode: lone surrogate at index {exc.start}") from None
        return value
    if ros == "bool":
        if not isinstance(value, bool):
            raise MessageError("", f"expected a boolean, got {type(value).__name__}")
        return value
    raise AssertionError(f"unknown primitive {ros}")


_SPECS: dict[type, tuple[FieldSpec, ...]] = {}


def specs(cls: type) -> tuple[FieldSpec, ...]:
    """The field specs of a message class, derived once from its annotations."""
    found = _SPECS.get(cls)
    if found is None:
        hints = typing.get_type_hints(cls, include_extras=True)
        found = _SPECS[cls] = tuple(_spec(f.name, hints[f.name]) for f in fields(cls))
    return found


def _spec(name: str, hint: Any) -> FieldSpec:
    if typing.get_origin(hint) is Annotated:
        return FieldSpec(name, "prim", hint.__metadata__[0])
    if hint is Id:
        return FieldSpec(name, "id", "mars_common_msgs.Id", Id)
    if typing.get_origin(hint) is tuple:
        elem = typing.get_args(hint)[0]
        if typing.get_origin(elem) is Annotated:
            return FieldSpec(name, "array", elem.__metadata__[0] + "[]", None)
        if elem is Id:
            return FieldSpec(name, "array", "mars_common_msgs/Id[]", Id)
        return FieldSpec(name, "array", elem.ROS_TYPE.replace(".", "/", 1) + "[]", elem)
    if isinstance(hint, type) and issubclass(hint, Message):
        return FieldSpec(name, "msg", hint.ROS_TYPE, hint)
    raise TypeError(f"field {name}: unsupported annotation {hint!r}")


__all__ = [
    "Bool",
    "FieldSpec",
    "Float32",
    "Float64",
    "Id",
    "IdError",
    "Int32",
    "Message",
    "MessageError",
    "String",
    "UInt32",
    "UInt8",
    "check_primitive",
    "short_repr",
    "specs",
]
