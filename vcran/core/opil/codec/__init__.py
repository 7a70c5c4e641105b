"""The OPIL/FIROS NGSI v2 codec: RAN messages to and from Orion's entity format (docs/contract.md §2, R12).

On the wire every attribute is ``{"type": "<pkg>.<Msg>", "value": {...}, "metadata": {"dataType": ...}}``
and every field inside ``value`` is again a ``{"type", "value"}`` wrapper, down to single uuid bytes
(docs/wire-format.md). The walk is mechanical, so it is derived once per attribute type from
:func:`vcran.core.opil.schema.specs` (:mod:`.decoding`, :mod:`.encoding`): the live transport encodes
``current_motion`` for a thousand robots every second and must not re-derive field lists per call.

A decode accepts both renderings a client meets (normalized, and ``options=keyValues``, which is just
the value object) and raises :class:`CodecError`, naming the NGSI path of the offending field, and
nothing else; it never returns a partly decoded message. Everything encoded is accepted by Orion:
strings are escaped (:mod:`.strings`), identifiers checked, batches split under the request limit.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from json.encoder import encode_basestring_ascii
from typing import Any, cast

from vcran.core.opil.codec.decoding import Decoder, Fault, message_decoder, step_into, unwrap
from vcran.core.opil.codec.encoding import DICTS, TEXT, attribute_encoder
from vcran.core.opil.codec.strings import escape_string, unescape_string
from vcran.core.opil.messages import ATTRIBUTES
from vcran.core.opil.schema import Message, short_repr, specs
from vcran.core.orion_rules import MAX_REQUEST_BYTES, identifier_error


class CodecError(ValueError):
    """A value that cannot cross the NGSI boundary; the one error type a decode may raise (R12).

    ``path`` is the NGSI path of the offending field in the normalized rendering, e.g.
    ``motion_assignment.value.point.value.x`` or ``cancel_order.value.task_id.value.uuid.value[3]``,
    whichever rendering was decoded; ``attribute`` is the attribute it belongs to (empty for
    entity-level problems); ``problem`` says what is wrong.
    """

    def __init__(self, attribute: str, path: str, problem: str) -> None:
        super().__init__(f"{path}: {problem}")
        self.attribute = attribute
        self.path = path
        self.problem = problem

    def __reduce__(self) -> tuple[Any, ...]:
        return (type(self), (self.attribute, self.path, self.problem))


@dataclass(frozen=True, slots=True)
class _Plan:
    """Everything the codec needs for one attribute, derived once at import."""

    cls: type[Message]
    decode: Decoder
    encode: Callable[[Message], dict[str, Any]]
    encode_text: Callable[[Message], str]


def _plan(cls: type[Message]) -> _Plan:
    # Rendering detection (a "value" member means normalized) relies on this; see decode_attribute.
    assert all(s.name != "value" for s in specs(cls)), f"{cls.__name__} has a field named value"
    return _Plan(cls, message_decoder(cls), attribute_encoder(cls, DICTS), attribute_encoder(cls, TEXT))


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
        return cast(Message, plan.decode(attr if key_values else unwrap(attr)))
    except Fault as fault:
        raise CodecError(name, step_into(name, fault.suffix), fault.problem) from None


def encode_attribute(name: str, message: Message) -> dict[str, Any]:
    """The normalized NGSI attribute, in the shape of the OPIL reference entity; strings escaped."""
    return _plan_of(name, message).encode(message)


def encode_attribute_json(name: str, message: Message) -> str:
    """``json.dumps(encode_attribute(name, message), separators=(",", ":"))``, written directly.

    For the wire: several times faster than building the dicts and serializing them.
    """
    return _plan_of(name, message).encode_text(message)


def _plan_of(name: str, message: Message) -> _Plan:
    plan = _plan_for(name)
    if type(message) is not plan.cls:
        problem = f"expected a {plan.cls.__name__} message, got {type(message).__name__}"
        raise CodecError(name, name, problem)
    return plan


def decode_entity(entity: Any, *, key_values: bool | None = None) -> dict[str, Message]:
    """Every RAN attribute of an entity, all or nothing, in entity order.

    ``id``, ``type`` and attributes that are not RAN messages are skipped: an Orion entity may carry
    others (a fleet manager's own, ``battery_level``...); :func:`unknown_attributes` lists them.
    """
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
    """A whole entity for ``POST /v2/entities`` or a batch update, its identifiers checked against
    Orion's rules (refused, not altered: an entity id is how the RAN routes, R11)."""
    _check_identifiers(entity_id, entity_type)
    entity: dict[str, Any] = {"id": entity_id, "type": entity_type}
    for name, message in messages.items():
        entity[name] = encode_attribute(name, message)
    return entity


def encode_entity_json(entity_id: str, entity_type: str, messages: dict[str, Message]) -> bytes:
    """The compact JSON of :func:`encode_entity`, written directly (see :func:`encode_attribute_json`);
    what :func:`split_batch` takes for the live transport's periodic updates."""
    _check_identifiers(entity_id, entity_type)
    parts = ['{"id":', encode_basestring_ascii(entity_id), ',"type":', encode_basestring_ascii(entity_type)]
    for name, message in messages.items():
        parts += [",", encode_basestring_ascii(name), ":", encode_attribute_json(name, message)]
    parts.append("}")
    return "".join(parts).encode()


def _check_identifiers(entity_id: str, entity_type: str) -> None:
    for field, kind, name in (("id", "entity id", entity_id), ("type", "entity type", entity_type)):
        problem = identifier_error(kind, name)
        if problem is not None:
            raise CodecError("", field, problem)


def split_batch(
    entities: Iterable[dict[str, Any] | bytes], limit: int = MAX_REQUEST_BYTES, *, action_type: str = "append"
) -> list[bytes]:
    """Compact ``POST /v2/op/update`` bodies of at most ``limit`` bytes each, entities in order.

    Orion answers 413 to a larger request (1 MiB by default), so the live transport sends one body per
    element. An entity is a dict, or bytes already serialized (:func:`encode_entity_json`). Bodies are
    filled greedily, so there are as few as the sizes allow. An entity too large to fit a body on its
    own raises :class:`CodecError` naming it.
    """
    return [body for body, _ in split_batch_counted(entities, limit, action_type=action_type)]


def split_batch_counted(
    entities: Iterable[dict[str, Any] | bytes], limit: int = MAX_REQUEST_BYTES, *, action_type: str = "append"
) -> list[tuple[bytes, int]]:
    """:func:`split_batch`, each body with how many of the entities (the next ones, in order) it holds:
    a sender that stops at a failed body knows exactly which entities Orion has not taken."""
    head = b'{"actionType":' + json.dumps(action_type).encode() + b',"entities":['
    tail = b"]}"
    bodies: list[tuple[bytes, int]] = []
    chunk: list[bytes] = []
    size = len(head) + len(tail)
    for index, entity in enumerate(entities):
        data = entity if isinstance(entity, bytes) else json.dumps(entity, separators=(",", ":"), allow_nan=False).encode()
        if len(head) + len(data) + len(tail) > limit:
            where = str(entity.get("id", "entity")) if isinstance(entity, dict) else f"entities[{index}]"
            raise CodecError("", where, f"entity encodes to {len(data)} bytes, too large for a {limit}-byte update")
        if chunk and size + 1 + len(data) > limit:
            bodies.append((head + b",".join(chunk) + tail, len(chunk)))
            chunk, size = [], len(head) + len(tail)
        size += len(data) + (1 if chunk else 0)
        chunk.append(data)
    if chunk:
        bodies.append((head + b",".join(chunk) + tail, len(chunk)))
    return bodies


__all__ = [
    "CodecError",
    "decode_attribute",
    "decode_entity",
    "encode_attribute",
    "encode_attribute_json",
    "encode_entity",
    "encode_entity_json",
    "escape_string",
    "split_batch",
    "split_batch_counted",
    "unescape_string",
    "unknown_attributes",
]
