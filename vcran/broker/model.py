"""Entities and attributes: how a request's JSON becomes them, how a write changes them, how they render.

Orion's rules as the recordings (tests/data/orion-4.7-exchanges.jsonl) show them:

- an attribute written without ``type`` gets the default for its value (``Number``, ``StructuredValue``,
  ...), even when it had another type before; written without ``metadata`` it keeps the metadata it had
  (given metadata is merged into the old, ``options=overrideMetadata`` replaces it: Orion's manual);
- a value that is JSON-equal to the stored one (object key order ignored, ``80 == 80.0``) is not a
  change, and the stored value keeps its key order; numbers are stored as doubles, as Orion stores
  them, and print as Orion prints them (:mod:`vcran.broker.jsontext`);
- attributes keep the order in which they were first written; reads always carry ``metadata`` (``{}``);
- every entity has the builtin attributes ``dateCreated`` and ``dateModified`` (``DateTime``), shown only
  when a read or a subscription names them (``attrs=dateModified``, ``options=dateModified``);
  ``dateModified`` moves when a write actually changes the entity, not on a same-value write.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

from vcran.broker.dates import DATE_TYPES, Moment, iso_time, parse_time
from vcran.broker.jsontext import as_double, render_json
from vcran.broker.protocol import NgsiError, bad_request, not_implemented, parse_error
from vcran.core.orion_rules import IDENTIFIER_MAX, default_attribute_type, has_forbidden_chars, is_identifier

#: Attribute type that skips the forbidden-character check on the value (Orion's escape hatch).
TEXT_UNRESTRICTED = "TextUnrestricted"
#: Entity type given to entities created without one.
DEFAULT_ENTITY_TYPE = "Thing"
#: Builtin attributes, shown only when named, after the entity's own attributes.
BUILTIN_ATTRIBUTES = ("dateCreated", "dateModified")


@dataclass(frozen=True, slots=True)
class Metadata:
    type: str
    value: Any


@dataclass(frozen=True, slots=True)
class Attribute:
    type: str
    value: Any
    metadata: Mapping[str, Metadata] = field(default_factory=dict)


@dataclass(frozen=True, slots=True)
class AttributeInput:
    """An attribute as a request writes it: ``type`` and ``metadata`` are None where the request left
    them out, because leaving them out means something (default type, keep the old metadata)."""

    value: Any
    type: str | None = None
    metadata: Mapping[str, Metadata] | None = None


@dataclass(frozen=True, slots=True)
class Change:
    """What one write did to one attribute; subscriptions decide which kinds they care about."""

    value: bool  # created, or its value or type changed
    metadata: bool  # its metadata changed


@dataclass(slots=True)
class Entity:
    id: str
    type: str
    service_path: str
    attrs: dict[str, Attribute] = field(default_factory=dict)
    created: float = 0.0
    modified: float = 0.0

    def write(self, inputs: Mapping[str, AttributeInput], *, override_metadata: bool = False) -> dict[str, Change]:
        """Create or update each attribute; returns what changed, by attribute name."""
        changes = {}
        for name, given in inputs.items():
            self.attrs[name], changes[name] = written(self.attrs.get(name), given, override_metadata=override_metadata)
        return changes


# --- comparing and writing ---------------------------------------------------------------------------


def json_equal(a: Any, b: Any) -> bool:
    """Equality of JSON values as Orion stores them: object key order ignored, numbers as doubles
    (``80 == 80.0``), but ``true`` is not ``1``."""
    if isinstance(a, bool) or isinstance(b, bool):
        return type(a) is type(b) and a == b
    if isinstance(a, (int, float)) and isinstance(b, (int, float)):
        return a == b
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(json_equal(a[k], b[k]) for k in a)
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(map(json_equal, a, b))
    return type(a) is type(b) and a == b


def _same_metadata(a: Mapping[str, Metadata], b: Mapping[str, Metadata]) -> bool:
    return a.keys() == b.keys() and all(a[k].type == b[k].type and json_equal(a[k].value, b[k].value) for k in a)


def written(
    old: Attribute | None, given: AttributeInput, *, override_metadata: bool = False
) -> tuple[Attribute, Change]:
    """The attribute after writing ``given`` over ``old`` (None: a new attribute), and the change."""
    new_type = given.type if given.type is not None else default_attribute_type(given.value)
    if old is None:
        return Attribute(new_type, given.value, dict(given.metadata or {})), Change(True, True)
    value_equal = json_equal(old.value, given.value)
    value = old.value if value_equal else given.value
    if given.metadata is None:
        metadata = old.metadata
    elif override_metadata:
        metadata = dict(given.metadata)
    else:
        metadata = {**old.metadata, **given.metadata}
    metadata_changed = not _same_metadata(old.metadata, metadata)
    if not metadata_changed:
        metadata = old.metadata
    change = Change(value=not value_equal or new_type != old.type, metadata=metadata_changed)
    return Attribute(new_type, value, metadata), change


# --- parsing request payloads ----------------------------------------------------------------------
#
# In the order and with the words of Orion's jsonParseV2 (parseEntity.cpp, parseEntityObject.cpp,
# parseContextAttribute.cpp, parseMetadata.cpp, parseMetadataVector.cpp) and of the checks that follow
# them (ContextAttribute::check, Metadata::check, Entity::check): members are read in payload order, each
# attribute is parsed and then checked (name, type, value, metadata), and the entity's id length and
# type are checked after its attributes.

#: Orion's deepest compound value (common/limits.h MAX_JSON_NESTING), counted from the attribute's value.
MAX_JSON_NESTING = 50
#: The name of a boolean metadata that, when true, lifts the forbidden-character check like the type does.
TEXT_UNRESTRICTED_METADATA = "TextUnrestricted"


def _length_error(kind: str, name: str) -> str | None:
    if not name:
        return f"{kind} length: 0, min length supported: 1"
    if len(name) > IDENTIFIER_MAX:
        return f"{kind} length: {len(name)}, max length supported: {IDENTIFIER_MAX}"
    return None


def _check_name(kind: str, name: str) -> None:
    """Length, then characters: ``ContextAttribute::check``/``Metadata::check`` for names and types."""
    error = _length_error(kind, name)
    if error is None and not is_identifier(name):
        error = f"Invalid characters in {kind}"
    if error is not None:
        raise bad_request(error)


def _nesting(value: Any, depth: int = 0) -> int:
    """How deep compound values nest below ``value`` (a scalar: 0), stopping past Orion's limit."""
    if depth > MAX_JSON_NESTING + 1 or not isinstance(value, (dict, list)):
        return depth
    children = value.values() if isinstance(value, dict) else value
    return max((_nesting(child, depth + 1) for child in children), default=depth + 1)


def _check_nesting(value: Any) -> None:
    """parseCompoundCommon.cpp stops at ``deep > MAX_JSON_NESTING``: a ParseError with its own words."""
    if isinstance(value, (dict, list)) and _nesting(value) > MAX_JSON_NESTING + 1:
        raise NgsiError(400, "ParseError",
                        f"attribute or metadata value has overpassed maximum nesting limit: {MAX_JSON_NESTING}")


#: Orion's update operators (mongoBackend/dbConstants.h UPDATE_OPERATORS_ALL): an object value whose
#: first key is one of them is an operation on the stored value (ContextAttribute.cpp), not a value.
UPDATE_OPERATORS = frozenset({"$inc", "$min", "$max", "$mul", "$push", "$pull", "$set", "$unset", "$addToSet",
                              "$pullAll"})


def _check_not_an_operator(value: Any) -> None:
    if isinstance(value, dict) and value and next(iter(value)) in UPDATE_OPERATORS:
        raise not_implemented(f"update operators ({next(iter(value))}) in attribute values")


def _date_value(value: Any, value_type: str | None, kind: str) -> Any:
    """A ``DateTime`` (or ``ISO8601``) value as Orion keeps it: a time, read by parse8601Time and
    printed back by isodate2str (parseContextAttribute.cpp, parseMetadata.cpp; functional tests
    1039_ngsiv2_date_support/basic_dates_support.test, 2631_partial_datetimes). ``null`` stays null;
    anything that is not such a time is refused."""
    if value_type not in DATE_TYPES or value is None:
        return value
    moment = parse_time(value) if isinstance(value, str) else None
    if moment is None:
        raise bad_request(f"date has invalid format in {kind} value")
    return Moment(iso_time(moment))


def _parse_metadata(raw: Any) -> dict[str, Metadata]:
    if not isinstance(raw, dict):
        raise bad_request("metadata not a JSON object")
    metadata = {}
    for name, item in raw.items():
        if not isinstance(item, dict):
            raise bad_request("metadata must be a JSON object")
        md_type: str | None = None
        value: Any = None
        for key, field_value in item.items():
            if key == "type":
                if not isinstance(field_value, str):
                    raise bad_request("invalid JSON type for attribute metadata type")
                md_type = field_value
            elif key == "value":
                _check_nesting(field_value)
                value = as_double(field_value)
            else:
                raise bad_request("invalid JSON field for attribute metadata")
        metadata[name] = Metadata(md_type if md_type is not None else default_attribute_type(value),
                                  _date_value(value, md_type, "metadata"))
    return metadata


def _check_metadata(metadata: Mapping[str, Metadata]) -> None:
    """Metadata::check: name, type, and a string value's characters (compound values are not checked)."""
    for name, md in metadata.items():
        _check_name("metadata name", name)
        _check_name("metadata type", md.type)
        if isinstance(md.value, str) and has_forbidden_chars(md.value):
            raise bad_request("Invalid characters in metadata value")


def parse_attribute(
    name: Any, raw: Any, *, key_values: bool = False, whole_body: bool = False, dates: bool = True
) -> AttributeInput:
    """One attribute of a request payload, parsed and checked as Orion does. ``whole_body``: ``raw`` is
    a request's whole body (``PUT .../attrs/{name}``), which must be an object or is a ParseError.
    ``dates=False``: a ``DateTime`` value is kept as written (``PUT .../value`` does not parse it)."""
    if key_values:
        _check_nesting(raw)
        given = AttributeInput(as_double(raw))
    else:
        if not isinstance(raw, dict):
            if whole_body:
                raise parse_error()
            raise bad_request("attribute must be a JSON object, unless keyValues option is used")
        attr_type: str | None = None
        value: Any = None
        metadata: dict[str, Metadata] | None = None
        for key, field_value in raw.items():
            if key == "type":
                if not isinstance(field_value, str):
                    raise bad_request("invalid JSON type for attribute type")
                attr_type = field_value
            elif key == "value":
                _check_nesting(field_value)
                value = as_double(field_value)
            elif key == "metadata":
                metadata = _parse_metadata(field_value)
            else:
                raise bad_request("unrecognized property for context attribute")
        _check_not_an_operator(value)
        given = AttributeInput(_date_value(value, attr_type, "attribute") if dates else value, attr_type, metadata)
    _check_not_an_operator(given.value)
    _check_name("attribute name", name)
    if given.type is not None:
        _check_name("attribute type", given.type)
    unrestricted = given.type == TEXT_UNRESTRICTED or (
        given.metadata is not None and TEXT_UNRESTRICTED_METADATA in given.metadata
        and given.metadata[TEXT_UNRESTRICTED_METADATA].value is True
    )
    if not unrestricted and has_forbidden_chars(given.value):
        raise bad_request("Invalid characters in attribute value")
    _check_metadata(given.metadata or {})
    return given


def parse_attributes(payload: Any, *, key_values: bool = False, skip: Iterable[str] = ()) -> dict[str, AttributeInput]:
    """The attributes of a payload object (an entity minus ``skip``, or a bare ``/attrs`` body)."""
    if not isinstance(payload, dict):
        raise parse_error()
    skipped = set(skip)
    return {
        name: parse_attribute(name, raw, key_values=key_values) for name, raw in payload.items() if name not in skipped
    }


def parse_attrs_body(payload: Any, *, key_values: bool = False) -> dict[str, AttributeInput]:
    """The body of ``/v2/entities/{id}/attrs`` (parseEntity.cpp with the id in the URL): an object of
    attributes only, at least one."""
    if not isinstance(payload, dict):
        raise parse_error()
    if "id" in payload:
        raise bad_request("entity id specified in payload")
    if "type" in payload:
        raise bad_request("entity type specified in payload")
    if not payload:
        raise bad_request("empty payload")
    return parse_attributes(payload, key_values=key_values)


@dataclass(frozen=True, slots=True)
class EntityInput:
    """An entity as a request writes it; ``type`` is None where the request left it out."""

    id: str
    type: str | None
    attrs: dict[str, AttributeInput]


def parse_entity(payload: Any, *, key_values: bool = False, batch: bool = False) -> EntityInput:
    """An entity of ``POST /v2/entities`` (parseEntity.cpp) or of an ``op/update`` (``batch``,
    parseEntityObject.cpp, whose caller has checked the object and its ``id``), then Entity::check."""
    if not isinstance(payload, dict):
        raise parse_error()
    if "id" not in payload:
        raise bad_request("entity id length: 0, min length supported: 1")
    entity_id = ""
    entity_type: str | None = None
    attrs: dict[str, AttributeInput] = {}
    for name, raw in payload.items():
        if name in ("id", "type"):
            if not isinstance(raw, str):
                raise bad_request(f"Invalid JSON type for entity {name}")
            if name == "id":
                if not raw and not batch:
                    raise bad_request("entity id length: 0, min length supported: 1")
                if raw and not is_identifier(raw):
                    raise bad_request("Invalid characters in entity id")
                entity_id = raw
            else:
                if not raw:
                    raise bad_request("entity type length: 0, min length supported: 1")
                entity_type = raw  # its characters are checked after the attributes, as Orion does
        else:
            attrs[name] = parse_attribute(name, raw, key_values=key_values)
    if not entity_id:
        raise bad_request("id and idPattern cannot be both empty at the same time")
    for kind, value in (("entity id", entity_id), ("entity type", entity_type)):
        if value is not None and (error := _length_error(kind, value)) is not None:
            raise bad_request(error)
    if entity_type is not None and not is_identifier(entity_type):
        raise bad_request("Invalid characters in entity type")
    return EntityInput(entity_id, entity_type, attrs)


# --- rendering ----------------------------------------------------------------------------------------


def render_attribute(attr: Attribute) -> dict[str, Any]:
    return {
        "type": attr.type,
        "value": attr.value,
        "metadata": {name: {"type": md.type, "value": md.value} for name, md in attr.metadata.items()},
    }


def _builtin(entity: Entity, name: str) -> Attribute | None:
    if name in entity.attrs or name not in BUILTIN_ATTRIBUTES:  # an attribute of the same name wins
        return None
    return Attribute("DateTime", iso_time(entity.created if name == "dateCreated" else entity.modified))


def selected(entity: Entity, attrs: list[str] | None) -> list[tuple[str, Attribute]]:
    """The attributes a read or notification shows: all (``None`` or a list with ``*``) in entity
    order, then the builtins named; else those named that exist, in the order named."""
    if attrs is None or "*" in attrs:
        builtins = [(name, _builtin(entity, name)) for name in BUILTIN_ATTRIBUTES if attrs and name in attrs]
        return list(entity.attrs.items()) + [(name, attr) for name, attr in builtins if attr is not None]
    chosen = []
    for name in dict.fromkeys(attrs):
        attr = entity.attrs.get(name) or _builtin(entity, name)
        if attr is not None:
            chosen.append((name, attr))
    return chosen


def render_entity(
    entity: Entity, attrs: list[str] | None = None, fmt: str = "normalized", *, with_id: bool = True
) -> Any:
    """An entity in one of NGSI v2's representations: ``normalized``, ``keyValues``, ``values`` or
    ``unique`` (values, each distinct value once, compared as printed: Orion's ``options=unique``)."""
    chosen = selected(entity, attrs)
    if fmt == "values":
        return [attr.value for _, attr in chosen]
    if fmt == "unique":
        distinct: dict[bytes, Any] = {}
        for _, attr in chosen:
            distinct.setdefault(render_json(attr.value), attr.value)
        return list(distinct.values())
    out: dict[str, Any] = {"id": entity.id, "type": entity.type} if with_id else {}
    for name, attr in chosen:
        out[name] = attr.value if fmt == "keyValues" else render_attribute(attr)
    return out
