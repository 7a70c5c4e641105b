"""Prepared converters: messages to plain JSON values, one generated function per message class.

A trace writes millions of messages. Letting orjson walk each dataclass and call back into Python for
every id costs several times more than handing it plain dicts; so each message class gets, once, a
function generated from its schema (:func:`vcran.core.opil.schema.specs`) that builds the dict directly,
field by field, nested messages through their own converters and ids through one memoised renderer.
Any message class, including ones added later, goes through the same path: nothing here names a field.

Two id styles share the machinery: ``plain`` (trace v1 and ``vcran decode``: ``{"uuid", "description"}``)
and ``compact`` (trace v2, docs/outputs.md): the name when the id is the stable id of its description
(:func:`vcran.core.opil.ids.id_for`), ``null`` for the nil id without description, else
``[uuid, description]``.
"""

from __future__ import annotations

from collections.abc import Callable
from operator import is_
from typing import Any

import orjson

from vcran.core.opil.ids import NIL, Id, NamedId, canonical_uuid, id_for
from vcran.core.opil.schema import FieldSpec, specs

Convert = Callable[[Any], Any]

#: Bound of each id memo: a run renders the same few ids many times; memory must stay flat.
_MEMO_LIMIT = 8_192


def _plain_id(ident: Id) -> dict[str, str]:
    return {"uuid": canonical_uuid(ident.uuid), "description": ident.description}


def _compact_id(ident: Id) -> Any:
    d = ident.description
    if d and id_for(d).uuid == ident.uuid:
        return d
    if not d and ident.uuid == bytes(16):
        return None
    return [canonical_uuid(ident.uuid), d]


def _memoised(render: Callable[[Id], Any]) -> Callable[[Id], Any]:
    # Keyed by identity, holding the Id itself so that its address cannot be reused while memoised:
    # Id equality ignores the description, which the rendering does not.
    memo: dict[int, tuple[Id, Any]] = {}

    def rendered(ident: Id) -> Any:
        hit = memo.get(id(ident))
        if hit is not None and hit[0] is ident:
            return hit[1]
        if len(memo) >= _MEMO_LIMIT:
            memo.clear()
        value = render(ident)
        memo[id(ident)] = (ident, value)
        return value

    return rendered


_compact_memoised = _memoised(_compact_id)


def _compact(ident: Id) -> Any:
    # An id made by id_for is known to be the stable id of its description without hashing it again
    # (ids.NamedId): nearly every id of a scripted or generated run. Others go through the memo.
    if type(ident) is NamedId:
        return ident.description
    return _compact_memoised(ident)


ID_STYLES: dict[str, Callable[[Id], Any]] = {"plain": _memoised(_plain_id), "compact": _compact}
_CONVERTERS: dict[tuple[type, str], Convert] = {}


def _id_source(style: str, expr: str) -> str:
    """Source text rendering the id held in ``expr`` (a name or attribute) in ``style``, for the generated
    converters: a compact :class:`NamedId` inline, as :func:`_compact` does; any other through ``_id``.
    A run renders a few dozen ids per task, and a call per id was a tenth of writing a record (issue 30)."""
    if style == "compact":  # the nil id (NIL itself: no current motion, no action, ...) is null
        return f"({expr}.description if type({expr}) is _NamedId else None if {expr} is _NIL else _id({expr}))"
    return f"_id({expr})"


def converter(cls: type, style: str = "plain") -> Convert:
    """The function turning a ``cls`` message into its plain JSON value, ids in ``style``."""
    key = (cls, style)
    found = _CONVERTERS.get(key)
    if found is not None:
        return found
    helpers: dict[str, Any] = {"_id": ID_STYLES[style], "_NamedId": NamedId, "_NIL": NIL}
    parts = []
    for spec in specs(cls):
        parts.append(f"{spec.name!r}: {_value_source(spec, style, f'm.{spec.name}', helpers)}")
    found = eval(f"lambda m: {{{', '.join(parts)}}}", helpers)  # noqa: S307 - source built from specs only
    _CONVERTERS[key] = found
    return found


def _value_source(spec: FieldSpec, style: str, here: str, helpers: dict[str, Any]) -> str:
    """Source text of the JSON value of field ``spec`` held in ``here`` (a name or attribute); adds the
    converters of nested messages to ``helpers`` as ``_c_<field>``."""
    if spec.kind == "prim":
        return here
    if spec.kind == "id":
        return _id_source(style, here)
    if spec.kind == "msg":
        helpers[f"_c_{spec.name}"] = converter(spec.cls, style)  # type: ignore[arg-type]
        return f"_c_{spec.name}({here})"
    if spec.cls is None:
        return f"list({here})"
    if spec.cls is Id:
        return f"[{_id_source(style, 'i')} for i in {here}]"
    helpers[f"_c_{spec.name}"] = converter(spec.cls, style)
    return f"[_c_{spec.name}(i) for i in {here}]"


_DELTAS: dict[tuple[type, str], Callable[[Any, Any, dict[str, Any]], dict[str, Any]]] = {}


def delta_converter(cls: type, style: str = "compact") -> Callable[[Any, Any, dict[str, Any]], dict[str, Any]]:
    """``delta(message, last, full)``: the fields of ``message`` whose JSON value differs from ``full``
    (the JSON value of ``last``, the previous message of the same stream), updating ``full`` in place.

    A field holding the very object ``last`` held (a footprint, a task id: statuses share them from
    tick to tick) is skipped without being converted, so an unchanged status costs a few identity tests;
    so is an array holding the very items ``last``'s held (``ran_status`` is built afresh when the
    state changes: on a 1000-robot run half its ``queue`` and ``completed`` arrays were the last ones'
    ids again, and converting them was about 1% of the CPU). The tests and conversions are written out
    in the generated source, not called (a call per field cost more than the field: issue 30).
    """
    key = (cls, style)
    found = _DELTAS.get(key)
    if found is not None:
        return found
    helpers: dict[str, Any] = {"_is": is_, "_dumps": orjson.dumps, "_id": ID_STYLES[style], "_NamedId": NamedId,
                               "_NIL": NIL}
    body = []
    for spec in specs(cls):
        name = spec.name
        if spec.kind == "array":  # the very items of the last value's array
            same = f" w = last.{name}\n if not (v is w or (len(v) == len(w) and all(map(_is, v, w)))):\n"
        else:
            same = f" if v is not last.{name}:\n"
        # == cannot tell -0.0 from 0.0; where a float can be, equal values are compared as JSON text too
        was = f"full[{name!r}]"
        differs = f"not (c == {was} and _dumps(c) == _dumps({was}))" if _holds_float(spec) else f"c != {was}"
        body.append(
            f" v = m.{name}\n"
            + same
            + f"  c = {_value_source(spec, style, 'v', helpers)}\n"
            f"  if {differs}:\n"
            f"   full[{name!r}] = out[{name!r}] = c\n"
        )
    source = "def delta(m, last, full):\n out = {}\n" + "".join(body) + " return out\n"
    exec(source, helpers)  # noqa: S102 - source built from specs only
    found = _DELTAS[key] = helpers["delta"]
    return found  # type: ignore[no-any-return]


def _holds_float(spec: FieldSpec) -> bool:
    """Whether a field's JSON value can hold a float: a float primitive, or a message with one."""
    if spec.kind in ("prim", "array") and spec.cls is None:
        return spec.ros.startswith("float")
    return spec.kind != "id" and spec.cls is not Id and any(_holds_float(s) for s in specs(spec.cls))  # type: ignore[arg-type]


def to_json_value(message: Any, style: str = "plain") -> Any:
    """``message`` as a plain JSON value through its class's prepared converter."""
    return converter(type(message), style)(message)


def from_compact_id(value: Any) -> Id:
    """The inverse of the compact id style; raises ValueError for anything else."""
    if value is None:
        return Id(bytes(16))
    if isinstance(value, str) and value:
        return id_for(value)
    if isinstance(value, list) and len(value) == 2 and all(isinstance(v, str) for v in value):
        return Id.parse(value[0], value[1])
    raise ValueError(f"not a compact id: {value!r}")


def expand(cls: type, value: Any) -> Any:
    """A compact (v2) JSON value of a ``cls`` message in the plain form, ids as ``{"uuid", "description"}``,
    for :func:`vcran.core.opil.plain.from_plain` to validate and build. Anything not shaped like ``cls`` is
    passed through unchanged, so that from_plain names the problem."""
    if not isinstance(value, dict):
        return value
    out = dict(value)
    for spec in specs(cls):
        if spec.name not in out:
            continue
        v = out[spec.name]
        if spec.kind == "id":
            out[spec.name] = _plain_of_compact(v)
        elif spec.kind == "msg":
            out[spec.name] = expand(spec.cls, v)  # type: ignore[arg-type]
        elif spec.kind == "array" and spec.cls is not None and isinstance(v, list):
            out[spec.name] = [_plain_of_compact(i) if spec.cls is Id else expand(spec.cls, i) for i in v]
    return out


def _plain_of_compact(value: Any) -> Any:
    try:
        return _plain_id(from_compact_id(value))
    except ValueError:
        return value
