"""Encoding messages as FIROS-wrapped NGSI attributes, in the shape of the OPIL reference entity.

Every field becomes ``{"type", "value"}`` with ``"number"``, ``"string"``, ``"boolean"``, ``"array"`` or
the nested message's ROS type; arrays and the attribute carry ``metadata.dataType`` (ROS type names,
e.g. ``uint8[16]``, ``geometry_msgs/Point32[]``, or a tree of them for a message).

Each attribute type gets generated functions, the way :mod:`dataclasses` generates ``__init__``: one
walk over the field specs writes a single expression with nested messages inlined, arrays as
comprehensions and constant metadata as literals. Two targets share the walk: Python dicts
(:class:`_Dicts`, for :func:`vcran.core.opil.codec.encode_attribute`; every call builds fresh dicts) and the
compact JSON text of the same dicts (:class:`_Text`, for the wire). The live transport publishes
``current_motion``, ``assignment_state`` and ``ran_status`` for every robot every second; writing the
text directly is several times faster than building dicts and then ``json.dumps``. The generated
source is kept as the function's ``source`` attribute for reading.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from json.encoder import encode_basestring_ascii
from typing import Any, cast

from vcran.core.opil.codec.decoding import ID_TYPE, UUID_DATATYPE, item_spec
from vcran.core.opil.codec.strings import escape_string
from vcran.core.opil.ids import Id
from vcran.core.opil.schema import FieldSpec, Message, specs

PRIMITIVE_TYPES = {"float64": "number", "float32": "number", "int32": "number", "uint32": "number",
                   "uint8": "number", "string": "string", "bool": "boolean"}  # fmt: skip


def datatype(spec: FieldSpec) -> Any:
    """The ``metadata.dataType`` entry of a field: a ROS type name, or a tree for a nested message."""
    if spec.kind == "id":
        return {"uuid": UUID_DATATYPE, "description": "string"}
    if spec.kind == "msg":
        return {s.name: datatype(s) for s in specs(cast(type[Message], spec.cls))}
    return spec.ros


def _metadata(tree: Any) -> dict[str, Any]:
    return {"dataType": {"type": "dataType", "value": tree}}


def _compact(value: Any) -> str:
    return json.dumps(value, separators=(",", ":"))


def encode_id(ident: Id) -> dict[str, Any]:
    return {
        "type": ID_TYPE,
        "value": {
            "uuid": {
                "type": "array",
                "value": [{"type": "number", "value": b} for b in ident.uuid],
                "metadata": _metadata(UUID_DATATYPE),
            },
            "description": {"type": "string", "value": escape_string(ident.description)},
        },
    }


_UUID_ITEMS = tuple(_compact({"type": "number", "value": b}) for b in range(256))


def encode_id_text(ident: Id) -> str:
    """The compact JSON of :func:`encode_id`, with the sixteen byte wrappers looked up, not formatted."""
    return "".join((
        '{"type":"mars_common_msgs.Id","value":{"uuid":{"type":"array","value":[',
        ",".join([_UUID_ITEMS[b] for b in ident.uuid]),
        '],"metadata":{"dataType":{"type":"dataType","value":"uint8[16]"}}},"description":{"type":"string","value":',
        encode_basestring_ascii(escape_string(ident.description)),
        "}}}",
    ))  # fmt: skip


class _Dicts:
    """Expressions that build the attribute as Python dicts."""

    encode_id = "_encode_id"

    def message(self, fields: list[tuple[str, str]]) -> str:
        return "{" + ", ".join(f"{name!r}: {expr}" for name, expr in fields) + "}"

    def wrapper(self, wire_type: str, value: str, metadata: Any = None) -> str:
        meta = "" if metadata is None else f", 'metadata': {_metadata(metadata)!r}"
        return f"{{'type': {wire_type!r}, 'value': {value}{meta}}}"

    def primitive(self, ros: str, var: str) -> str:
        return f"_escape({var})" if ros == "string" else var

    def array(self, item: str, item_var: str, var: str) -> str:
        return f"[{item} for {item_var} in {var}]"


class _Text:
    """Expressions that write the same attribute as compact JSON text (``json.dumps`` of the dicts)."""

    encode_id = "_encode_id_text"

    def message(self, fields: list[tuple[str, str]]) -> str:
        parts = []
        for i, (name, expr) in enumerate(fields):
            parts += [repr(("{" if i == 0 else ",") + _compact(name) + ":"), expr]
        return _join(parts + [repr("}")])

    def wrapper(self, wire_type: str, value: str, metadata: Any = None) -> str:
        meta = "" if metadata is None else ',"metadata":' + _compact(_metadata(metadata))
        return _join([repr('{"type":' + _compact(wire_type) + ',"value":'), value, repr(meta + "}")])

    def primitive(self, ros: str, var: str) -> str:
        if ros == "string":
            return f"_json_string(_escape({var}))"
        if ros == "bool":
            return f"('true' if {var} else 'false')"
        return f"_float_repr({var})" if ros.startswith("float") else f"_int_repr({var})"

    def array(self, item: str, item_var: str, var: str) -> str:
        return f"'[' + ','.join([{item} for {item_var} in {var}]) + ']'"


def _join(parts: list[str]) -> str:
    return f"''.join(({', '.join(parts)},))"


_Target = _Dicts | _Text
_NAMESPACE = {
    "_escape": escape_string,
    "_encode_id": encode_id,
    "_encode_id_text": encode_id_text,
    "_json_string": encode_basestring_ascii,
    "_float_repr": float.__repr__,  # what json.dumps writes for a float
    "_int_repr": int.__repr__,
}


def attribute_encoder(cls: type[Message], target: _Target) -> Callable[[Message], Any]:
    """Generate the function that encodes a ``cls`` as a whole normalized attribute, for ``target``.

    The source is assembled only from field names (Python identifiers) and ``repr`` of the ROS type
    names of the message classes, never from data.
    """
    tree = {spec.name: datatype(spec) for spec in specs(cls)}
    source = f"def encode(m):\n    return {target.wrapper(cls.ROS_TYPE, _message(cls, 'm', 0, target), tree)}\n"
    namespace = dict(_NAMESPACE)
    filename = f"<{type(target).__name__.lower()[1:]} encoder of {cls.__name__}>"
    exec(compile(source, filename, "exec"), namespace)  # noqa: S102 (source built from the schema only)
    encode = namespace["encode"]
    setattr(encode, "source", source)  # noqa: B010 (a function attribute for readers, not for mypy)
    return cast(Callable[[Message], Any], encode)


def _message(cls: type[Message], var: str, depth: int, target: _Target) -> str:
    return target.message([(spec.name, _field(spec, f"{var}.{spec.name}", depth, target)) for spec in specs(cls)])


def _field(spec: FieldSpec, var: str, depth: int, target: _Target) -> str:
    """An expression for the ``{"type", "value"}`` wrapper of the field whose value is ``var``."""
    if spec.kind == "prim":
        return target.wrapper(PRIMITIVE_TYPES[spec.ros], target.primitive(spec.ros, var))
    if spec.kind == "id":
        return f"{target.encode_id}({var})"
    if spec.kind == "msg":
        return target.wrapper(spec.ros, _message(cast(type[Message], spec.cls), var, depth, target))
    item_var = f"item{depth}"  # one name per nesting level: arrays of messages holding arrays
    items = target.array(_field(item_spec(spec), item_var, depth + 1, target), item_var, var)
    return target.wrapper("array", items, spec.ros)


DICTS, TEXT = _Dicts(), _Text()
