"""VDA 5050 messages to JSON and back, in either protocol version (orjson for the text).

Encoding (:func:`encode`, :func:`to_plain`) writes a model as its version spells it and refuses, with the
field's path, what that version cannot carry (a 2.1.0-only field set on a 2.0.0 message); it does not run
the schema, which would cost more than building a fleet's state messages (tests validate every kind,
hypothesis-generated too). Decoding (:func:`decode`) is for received messages: JSON, then the official
schema (:mod:`vcran.core.vda5050.validation`), then the typed model; whatever is wrong comes back as an
:class:`Invalid` naming the offending field by JSON path, never as an exception.

A model's wire form is derived once per (class, version) from its annotations and the metadata of
:mod:`vcran.core.vda5050.fields`: one description of each message serves both directions.
"""

from __future__ import annotations

import dataclasses
import enum
import math
import types
import typing
from collections.abc import Callable
from dataclasses import dataclass
from functools import cache
from typing import Any, TypeVar

import orjson

from vcran.core.vda5050 import validation
from vcran.core.vda5050.enums import Topic, Version
from vcran.core.vda5050.factsheet import Factsheet
from vcran.core.vda5050.fields import camel
from vcran.core.vda5050.order import InstantActions, Order
from vcran.core.vda5050.state import Connection, State, Visualization

M = TypeVar("M")

#: The model of each topic's messages.
MODELS: dict[Topic, type] = {
    Topic.ORDER: Order,
    Topic.INSTANT_ACTIONS: InstantActions,
    Topic.STATE: State,
    Topic.VISUALIZATION: Visualization,
    Topic.CONNECTION: Connection,
    Topic.FACTSHEET: Factsheet,
}


@dataclass(frozen=True, slots=True)
class Invalid:
    """A received message that vcran refuses (§6.6.4.1: ``validationError``): nothing of it is applied.

    ``path`` names the offending field (``$.nodes[2].sequenceId``; ``$`` for the message as a whole);
    the ids a master needs to match the refusal to what it sent (§7.1) are kept where they were readable.
    """

    topic: Topic
    path: str
    problem: str
    header_id: int | None = None
    order_id: str | None = None
    order_update_id: int | None = None

    def __str__(self) -> str:
        return f"{self.topic.value}: {self.path}: {self.problem}"


class EncodeError(ValueError):
    """A model that its target version cannot carry; ``path`` names the field."""

    def __init__(self, path: str, problem: str) -> None:
        super().__init__(f"{path}: {problem}")
        self.path = path
        self.problem = problem


class _Bad(Exception):
    """A decoding problem on its way out to :class:`Invalid` (internal)."""

    def __init__(self, keys: list[str | int], problem: str) -> None:
        self.keys = keys
        self.problem = problem


# --- the wire form of a model ------------------------------------------------------------------------------

_PRIM = {str: "str", int: "int", float: "float", bool: "bool"}


@dataclass(frozen=True, slots=True)
class WireField:
    """One field of a model as ``wire_form`` sees it in one version."""

    attr: str
    name: str  # the JSON name in this version
    alias: str | None  # another spelling accepted on decoding (the other version's)
    kind: str  # str int float bool enum model any, or tuple:<kind>
    cls: Any  # the enum or model class, where kind needs one
    optional: bool
    flatten: bool
    absent: bool  # the field does not exist in this version
    no_object: bool  # the JSON value may not be an object in this version
    check: Any  # a function naming what this version misses below the field, or None


def _kind(tp: Any) -> tuple[str, Any, bool]:
    """(kind, class, optional) of an annotation."""
    optional = False
    if isinstance(tp, types.UnionType) or typing.get_origin(tp) is typing.Union:
        args = [a for a in typing.get_args(tp) if a is not type(None)]
        optional = len(args) != len(typing.get_args(tp))
        (tp,) = args
    if typing.get_origin(tp) is tuple:
        inner, cls, _ = _kind(typing.get_args(tp)[0])
        return f"tuple:{inner}", cls, optional
    if tp is Any:
        return "any", None, optional
    if tp in _PRIM:
        return _PRIM[tp], None, optional
    if isinstance(tp, type) and issubclass(tp, enum.Enum):
        return "enum", tp, optional
    if dataclasses.is_dataclass(tp):
        return "model", tp, optional
    raise TypeError(f"no wire form for {tp!r}")


@cache
def wire_form(cls: type, version: Version) -> tuple[WireField, ...]:
    """The fields of model ``cls`` as ``version`` spells and requires them (built once)."""
    hints = typing.get_type_hints(cls)
    out = []
    for f in dataclasses.fields(cls):
        meta = f.metadata
        kind, sub, optional = _kind(hints[f.name])
        name = meta.get("name") or camel(f.name)
        v2_0 = meta.get("v2_0")
        since = meta.get("since")
        old = version is Version.V2_0_0
        if v2_0:
            name, alias = (v2_0, name) if old else (name, v2_0)
        else:
            alias = meta.get("v2_0_alias") if old else None
        no_object = meta.get("no_object_before")
        out.append(WireField(
            f.name, name, alias, kind, sub, optional, bool(meta.get("flatten")),
            since is not None and not version.at_least(since),
            no_object is not None and not version.at_least(no_object),
            meta.get("v2_0_check") if old else None,
        ))
    return tuple(out)


# --- encoding ----------------------------------------------------------------------------------------------


def encode(message: Any, version: Version) -> bytes:
    """``message`` as the JSON text ``version`` sends (UTF-8)."""
    return orjson.dumps(to_plain(message, version))


def to_plain(message: Any, version: Version) -> dict[str, Any]:
    """``message`` as a JSON-ready dict in ``version``'s spelling; raises :class:`EncodeError` for what
    ``version`` cannot carry."""
    out: dict[str, Any] = {}
    try:
        _encoder(message.__class__, version)(message, out)
    except _Refused:  # the careful walk names the field
        out = {}
        _put(message, version, out, "$")
    if version is Version.V2_0_0 and type(message) is InstantActions:
        # The official 2.0.0 schema requires actionName, the 2.0.0 text actionType (validation.py):
        # both, so that every 2.0.0 vehicle finds its spelling and the official schema passes.
        for action in out["actions"]:
            action["actionName"] = action["actionType"]
    return out


class _Refused(Exception):
    """The fast encoder met what the version cannot carry; :func:`_put` then says where (internal)."""


#: Per version, the encoder of each model class met so far (:func:`_encoder`), and the same as a function that
#: returns a new dict (``_PLAINS``: a nested model of the class its field names).
_ENCODERS: dict[Version, dict[type, Callable[[Any, dict[str, Any]], None]]] = {v: {} for v in Version}
_PLAINS: dict[Version, dict[type, Callable[[Any], dict[str, Any]]]] = {v: {} for v in Version}


def _encoder(cls: type, version: Version) -> Callable[[Any, dict[str, Any]], None]:
    """:func:`_put` for ``cls`` in ``version``, written out as Python once, field after field, as
    :mod:`dataclasses` writes its methods: a fleet's trace encodes every state message it sends, and field by
    field through :func:`wire_form`, each field's JSON path built in case of an error, the encoding cost more
    than building the messages (issue 31's 100-vehicle hour). What ``version`` cannot carry raises
    :class:`_Refused`, and :func:`to_plain` walks the message again with :func:`_put` to name the field."""
    found = _ENCODERS[version].get(cls)
    if found is None:
        _write(cls, version)
        found = _ENCODERS[version][cls]
    return found


def _write(cls: type, version: Version, writing: frozenset[type] = frozenset()) -> None:
    """Write out ``put(m, out)`` and ``plain(m) -> dict`` for ``cls`` in ``version`` (and for the models its
    fields name, which a nested value of exactly that class is encoded with directly; those being written
    further out, ``writing``, through ``_model`` when it runs)."""
    writing |= {cls}
    names: dict[str, Any] = {"_Refused": _Refused, "_encoder": _encoder, "_version": version, "_model": _model}
    body = []
    for n, f in enumerate(wire_form(cls, version)):
        body += [f"    v = m.{f.attr}", "    if v is not None:"]
        if f.absent:
            body.append("        raise _Refused")
            continue
        if f.flatten:
            body.append("        _encoder(v.__class__, _version)(v, out)")
            continue
        if f.check is not None:
            names[f"_check{n}"] = f.check
            body.append(f"        if _check{n}(v) is not None: raise _Refused")
        if f.no_object:
            body.append("        if isinstance(v, dict): raise _Refused")
        direct = f.kind in ("model", "tuple:model") and f.cls not in writing
        if direct:
            if f.cls not in _PLAINS[version]:
                _write(f.cls, version, writing)
            names[f"_C{n}"], names[f"_plain{n}"] = f.cls, _PLAINS[version][f.cls]
        body.append(f"        out[{f.name!r}] = {_expression(f, n, 'v') if direct else _kind_expression(f.kind, 'v', 0)}")
    source = "\n".join(["def put(m, out):", *body, "    return None", "def plain(m):", "    out = {}", *body,
                        "    return out"])
    exec(source, names)  # noqa: S102 (source built here from the models' own field names)
    _ENCODERS[version][cls], _PLAINS[version][cls] = names["put"], names["plain"]


def _expression(f: WireField, n: int, value: str) -> str:
    """The Python expression :func:`_value` computes for ``value`` of field ``f`` (the ``n``-th): a model of the
    field's own class (or a tuple of them) through that class's ``plain``, any other model through ``_model``."""
    if f.kind == "model":
        return f"(_plain{n}({value}) if {value}.__class__ is _C{n} else _model({value}, _version))"
    if f.kind == "tuple:model":
        return f"[_plain{n}(x) if x.__class__ is _C{n} else _model(x, _version) for x in {value}]"
    return _kind_expression(f.kind, value, 0)


def _kind_expression(kind: str, value: str, depth: int) -> str:
    if kind == "enum":
        return f"{value}._value_"  # the member's own attribute: .value is a property (a Python call per enum)
    if kind == "model":
        return f"_model({value}, _version)"
    if kind.startswith("tuple:"):
        item = kind[6:]
        if item in ("str", "float", "int", "bool", "any"):
            return f"list({value})"
        x = f"x{depth}"
        return f"[{_kind_expression(item, x, depth + 1)} for {x} in {value}]"
    return value  # str, int, float, bool, any: JSON already


def _model(value: Any, version: Version) -> dict[str, Any]:
    """A nested model's wire form, whatever its class."""
    plain = _PLAINS[version].get(value.__class__)
    if plain is None:
        _write(value.__class__, version)
        plain = _PLAINS[version][value.__class__]
    return plain(value)


#: The kinds whose values are JSON already.
_PLAIN = frozenset({"str", "int", "float", "bool", "any"})


def _put(model: Any, version: Version, out: dict[str, Any], path: str) -> None:
    # The careful walk that names a refused field (to_plain, after the written-out encoder refused): a field's
    # path is built only for an error or a field that holds more fields, and a plain value is copied as it is.
    cls: type = model.__class__
    for f in wire_form(cls, version):
        value = getattr(model, f.attr)
        if value is None:
            continue
        if f.absent:
            raise EncodeError(f"{path}.{f.name}", f"{f.name} does not exist in VDA 5050 {version.value}")
        if f.flatten:
            _put(value, version, out, path)
            continue
        missing = f.check(value) if f.check is not None else None
        if missing is not None:
            raise EncodeError(f"{path}.{f.name}.{missing}", f"VDA 5050 {version.value} requires it here")
        if f.no_object and isinstance(value, dict):
            raise EncodeError(f"{path}.{f.name}",
                              f"an object value needs VDA 5050 2.1.0 or later, not {version.value}")
        kind = f.kind
        if kind in _PLAIN:
            out[f.name] = value
        elif kind == "enum":
            out[f.name] = value.value
        else:
            out[f.name] = _value(kind, value, version, f"{path}.{f.name}")


def _value(kind: str, value: Any, version: Version, path: str) -> Any:
    if kind == "enum":
        return value.value
    if kind == "model":
        inner: dict[str, Any] = {}
        _put(value, version, inner, path)
        return inner
    if kind.startswith("tuple:"):
        item = kind[6:]
        if item in ("str", "float", "int", "bool", "any"):
            return list(value)
        return [_value(item, v, version, f"{path}[{i}]") for i, v in enumerate(value)]
    return value  # str, int, float, bool, any: JSON already


# --- decoding ----------------------------------------------------------------------------------------------


def decode(topic: Topic, raw: bytes | str | dict[str, Any], version: Version) -> Any:
    """A received ``topic`` message as its model, or an :class:`Invalid` saying what is wrong with it.

    ``raw`` is the message's JSON text, or the object it parses to. Never raises for bad input.
    """
    if isinstance(raw, dict):
        doc: Any = raw
    else:
        try:
            doc = orjson.loads(raw)
        except orjson.JSONDecodeError as exc:
            return Invalid(topic, "$", f"not JSON: {exc}")
    return decode_parsed(topic, doc, version)


def decode_parsed(topic: Topic, doc: Any, version: Version) -> Any:
    """:func:`decode` of a message already parsed: ``doc`` is whatever its JSON text parsed to (an object,
    or any other JSON value, which the schema refuses), for an edge that parsed the payload itself (the
    master's MQTT link: :mod:`transports.mqtt.manage`). Never raises for bad input."""
    found = validation.first_problem(validation.inbound(topic, version), doc)
    if found is not None:
        return _invalid(topic, doc, *found)
    try:
        return _build(MODELS[topic], doc, version, [])
    except _Bad as bad:
        return _invalid(topic, doc, validation.json_path(bad.keys), bad.problem)


def decode_order(raw: bytes | str | dict[str, Any], version: Version) -> Order | Invalid:
    result: Order | Invalid = decode(Topic.ORDER, raw, version)
    return result


def decode_instant_actions(raw: bytes | str | dict[str, Any], version: Version) -> InstantActions | Invalid:
    result: InstantActions | Invalid = decode(Topic.INSTANT_ACTIONS, raw, version)
    return result


def from_plain(cls: type[M], doc: dict[str, Any], version: Version) -> M:
    """Build ``cls`` from an already validated JSON object; a ValueError names a field that does not fit
    (fields the schema leaves open, non-finite numbers)."""
    try:
        built: M = _build(cls, doc, version, [])
    except _Bad as bad:
        raise ValueError(f"{validation.json_path(bad.keys)}: {bad.problem}") from None
    return built


def _invalid(topic: Topic, doc: Any, path: str, problem: str) -> Invalid:
    if not isinstance(doc, dict):
        return Invalid(topic, path, problem)
    header_id, order_id, update_id = doc.get("headerId"), doc.get("orderId"), doc.get("orderUpdateId")
    return Invalid(
        topic, path, problem,
        header_id if _is_int(header_id) else None,
        order_id if isinstance(order_id, str) else None,
        update_id if _is_int(update_id) else None,
    )


def _is_int(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _build(cls: type, doc: Any, version: Version, keys: list[str | int]) -> Any:
    if not isinstance(doc, dict):
        raise _Bad(keys, "expected object")
    args: dict[str, Any] = {}
    for f in wire_form(cls, version):
        if f.absent:
            continue
        if f.flatten:
            args[f.attr] = _build(f.cls, doc, version, keys)
            continue
        name = f.name if f.name in doc or f.alias is None or f.alias not in doc else f.alias
        if name not in doc:
            if not f.optional and not _has_default(cls, f.attr):
                raise _Bad([*keys, f.name], "required field missing")
            continue
        args[f.attr] = _read(f.kind, f.cls, doc[name], version, [*keys, name])
    return cls(**args)


@cache
def _defaults(cls: type) -> frozenset[str]:
    return frozenset(f.name for f in dataclasses.fields(cls)
                     if f.default is not dataclasses.MISSING or f.default_factory is not dataclasses.MISSING)


def _has_default(cls: type, attr: str) -> bool:
    return attr in _defaults(cls)


def _read(kind: str, cls: Any, value: Any, version: Version, keys: list[str | int]) -> Any:
    if kind == "str":
        if not isinstance(value, str):
            raise _Bad(keys, "expected string")
        return value
    if kind == "bool":
        if not isinstance(value, bool):
            raise _Bad(keys, "expected boolean")
        return value
    if kind == "int":
        if isinstance(value, float) and value.is_integer():
            return int(value)
        if not _is_int(value):
            raise _Bad(keys, "expected integer")
        return value
    if kind == "float":
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise _Bad(keys, "expected number")
        if not math.isfinite(value):
            raise _Bad(keys, "not a finite number")
        return float(value)
    if kind == "enum":
        try:
            return cls(value)
        except ValueError:
            raise _Bad(keys, f"{validation.quote(value)} is not one of {', '.join(m.value for m in cls)}") from None
    if kind == "model":
        return _build(cls, value, version, keys)
    if kind == "any":
        return value
    if not isinstance(value, list):
        raise _Bad(keys, "expected array")
    item = kind[6:]
    return tuple(_read(item, cls, v, version, [*keys, i]) for i, v in enumerate(value))
