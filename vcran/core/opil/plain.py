"""Messages as plain JSON values: the "decoded value" of traces (docs/contract.md §6) and of ``vcran decode``.

A message becomes an object with its fields in ROS order; an id becomes
``{"uuid": "<canonical uuid>", "description": "..."}``; arrays become lists. ``from_plain`` is the exact
inverse and validates like every message constructor, raising :class:`MessageError` with the field path.
"""

from __future__ import annotations

from typing import Any

from vcran.core.opil.ids import Id, IdError
from vcran.core.opil.schema import FieldSpec, Message, MessageError, check_primitive, specs


def to_plain(message: Message) -> dict[str, Any]:
    return {spec.name: _value_to_plain(spec, getattr(message, spec.name)) for spec in specs(type(message))}


def _value_to_plain(spec: FieldSpec, value: Any) -> Any:
    if spec.kind == "prim":
        return value
    if spec.kind == "id":
        return id_to_plain(value)
    if spec.kind == "msg":
        return to_plain(value)
    if spec.cls is None:
        return list(value)
    if spec.cls is Id:
        return [id_to_plain(item) for item in value]
    return [to_plain(item) for item in value]


def id_to_plain(ident: Id) -> dict[str, str]:
    return {"uuid": ident.canonical, "description": ident.description}


def from_plain(cls: type[Message], data: Any) -> Message:
    """Build a ``cls`` from its plain form; every problem is a MessageError naming the field path."""
    if not isinstance(data, dict):
        raise MessageError("", f"expected an object for {cls.__name__}, got {type(data).__name__}")
    kwargs: dict[str, Any] = {}
    for spec in specs(cls):
        if spec.name not in data:
            raise MessageError(spec.name, "missing field")
        try:
            kwargs[spec.name] = _value_from_plain(spec, data[spec.name])
        except MessageError as exc:
            raise exc.within(spec.name) from None
    extra = sorted(set(data) - {s.name for s in specs(cls)})
    if extra:
        raise MessageError(extra[0], f"unknown field for {cls.__name__}")
    return cls(**kwargs)


def _value_from_plain(spec: FieldSpec, value: Any) -> Any:
    if spec.kind == "prim":
        return check_primitive(spec.ros, value)
    if spec.kind == "id":
        return id_from_plain(value)
    if spec.kind == "msg":
        return from_plain(spec.cls, value)  # type: ignore[arg-type]
    if not isinstance(value, list):
        raise MessageError("", f"expected an array, got {type(value).__name__}")
    out = []
    for i, item in enumerate(value):
        try:
            if spec.cls is None:
                out.append(check_primitive(spec.ros[:-2], item))
            elif spec.cls is Id:
                out.append(id_from_plain(item))
            else:
                out.append(from_plain(spec.cls, item))
        except MessageError as exc:
            raise MessageError(f"[{i}]{'.' + exc.path if exc.path else ''}", exc.problem) from None
    return tuple(out)


def id_from_plain(value: Any) -> Id:
    if not isinstance(value, dict) or set(value) != {"uuid", "description"}:
        raise MessageError("", "expected an id object with exactly uuid and description")
    if not isinstance(value["description"], str):
        raise MessageError("description", "expected a string")
    if not isinstance(value["uuid"], str):
        raise MessageError("uuid", f"expected a canonical uuid string, got {value['uuid']!r}")
    try:
        return Id.parse(value["uuid"], value["description"])
    except IdError as exc:
        raise MessageError("uuid", str(exc)) from None
