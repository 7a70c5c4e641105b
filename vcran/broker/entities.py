"""The entity resources: ``/v2/entities``, ``/v2/entities/{id}``, ``.../attrs``, ``.../attrs/{name}``,
``.../attrs/{name}/value``, and the write semantics that ``/v2/op/update`` shares with them.

Each handler takes the request :class:`~vcran.broker.context.Context` (and the path's ids) and returns a
:class:`~vcran.broker.protocol.Response` or raises an :class:`~vcran.broker.protocol.NgsiError`.
A write that applies in part still applies the part and notifies for it, then answers Orion's 422
``PartialUpdate`` (the recordings show a PATCH naming an existing and a missing attribute doing that).
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from dataclasses import dataclass

from vcran.broker.context import Context
from vcran.broker.dates import Moment
from vcran.broker.jsontext import render_json
from vcran.broker.model import (
    DEFAULT_ENTITY_TYPE,
    AttributeInput,
    Change,
    Entity,
    EntityInput,
    parse_attribute,
    parse_attrs_body,
    parse_entity,
    render_attribute,
    render_entity,
    written,
)
from vcran.broker.protocol import (
    ATTRIBUTE_NOT_FOUND,
    Headers,
    NgsiError,
    Response,
    accepted_media,
    bad_request,
    empty_response,
    json_response,
    not_found,
    unprocessable,
)
from vcran.broker.scope import check_pattern, compiles


def location(entity: Entity) -> Headers:
    return (("Location", f"/v2/entities/{entity.id}?type={entity.type}"),)


def entity_key(entity_id: str, entity_type: str | None) -> str:
    """How Orion names an entity in error descriptions: ``id/type`` when the request gave the type."""
    return entity_id if entity_type is None else f"{entity_id}/{entity_type}"


#: How one entity of a write went (Orion's UpdateCoverage, mongoBackend/MongoCommonUpdate.cpp).
SUCCESS, PARTIAL, ATTRS_FAILED, NOT_FOUND = "success", "partial", "attrs failed", "not found"


def _combined(total: str | None, entity: str) -> str:
    """Orion's mongoUpdateContext.cpp: the coverage of a whole write from its entities', in order."""
    if total is None or total == PARTIAL:
        return entity if total is None else PARTIAL
    if total == SUCCESS:
        return SUCCESS if entity == SUCCESS else PARTIAL
    if total == ATTRS_FAILED:
        return ATTRS_FAILED if entity in (ATTRS_FAILED, NOT_FOUND) else PARTIAL
    return NOT_FOUND if entity == NOT_FOUND else ATTRS_FAILED if entity == ATTRS_FAILED else PARTIAL


@dataclass(slots=True)
class WriteReport:
    """What parts of a write did not apply, turned into Orion's answer once the write is done.

    As Orion's ``OrionError::fillOrAppend``: the first failure sets the status, the error name and the
    description; later ones only append ``, E2 - [ A ]`` (``, E2 [entity itself]`` for a missing
    entity, without the dash). A write that applied in part is 422 ``PartialUpdate`` whatever the first
    failure was (mongoUpdateContext.cpp)."""

    coverage: str | None = None
    status: int = 0
    error: str = ""
    description: str = ""

    def _failed(self, status: int, error: str, first: str, later: str) -> None:
        if self.status:
            self.description += later
        else:
            self.status, self.error, self.description = status, error, first

    def success(self) -> None:
        self.coverage = _combined(self.coverage, SUCCESS)

    def missing_entity(self, key: str) -> None:
        self._failed(404, "NotFound", f"do not exist: {key} - [entity itself]", f", {key} [entity itself]")
        self.coverage = _combined(self.coverage, NOT_FOUND)

    def _attrs(self, prefix: str, key: str, names: list[str], total: int) -> None:
        if names:
            listed = f"{key} - [ {', '.join(names)} ]"
            self._failed(422, "Unprocessable", prefix + listed, ", " + listed)
        self.coverage = _combined(self.coverage, SUCCESS if not names else ATTRS_FAILED if len(names) == total
                                  else PARTIAL)

    def missing_attrs(self, key: str, names: list[str], total: int) -> None:
        self._attrs("do not exist: ", key, names, total)

    def existing_attrs(self, key: str, names: list[str], total: int) -> None:
        self._attrs("one or more of the attributes in the request already exist: ", key, names, total)

    def response(self) -> Response:
        """204 when everything applied, else the error for what did not (raised)."""
        if not self.status:
            return empty_response()
        if self.coverage == PARTIAL:
            raise NgsiError(422, "PartialUpdate", self.description)
        raise NgsiError(self.status, self.error, self.description)


# --- write semantics shared with op/update ------------------------------------------------------------


def _override(ctx: Context) -> bool:
    return "overrideMetadata" in ctx.options


def create(ctx: Context, given: EntityInput) -> Entity:
    """Create an entity in the write's service path (``/`` by default) and notify for it."""
    now = ctx.clock()
    entity = Entity(given.id, given.type or DEFAULT_ENTITY_TYPE, ctx.scope.write_path(),
                    created=now, modified=now)
    changes = entity.write(given.attrs)
    ctx.tenant(create=True).add(entity)
    ctx.changed(entity, changes)
    return entity


def append(ctx: Context, entity: Entity, inputs: Mapping[str, AttributeInput], report: WriteReport) -> None:
    """Update the attributes that exist, add the others (``append`` / ``POST .../attrs``)."""
    ctx.changed(entity, entity.write(inputs, override_metadata=_override(ctx)))
    report.success()


def append_strict(
    ctx: Context, entity: Entity, key: str, inputs: Mapping[str, AttributeInput], report: WriteReport
) -> None:
    """Add the attributes that do not exist yet; those that do are an error (``appendStrict``)."""
    existing = [name for name in inputs if name in entity.attrs]
    new = {name: given for name, given in inputs.items() if name not in entity.attrs}
    report.existing_attrs(key, existing, len(inputs))
    if new:
        ctx.changed(entity, entity.write(new, override_metadata=_override(ctx)))


def update(ctx: Context, entity: Entity, key: str, inputs: Mapping[str, AttributeInput], report: WriteReport) -> None:
    """Update the attributes that exist; those that do not are an error (``update`` / ``PATCH``)."""
    report.missing_attrs(key, [name for name in inputs if name not in entity.attrs], len(inputs))
    present = {name: given for name, given in inputs.items() if name in entity.attrs}
    if present:
        ctx.changed(entity, entity.write(present, override_metadata=_override(ctx)))


def replace(ctx: Context, entity: Entity, inputs: Mapping[str, AttributeInput]) -> None:
    """Drop every attribute and write the given ones (``replace`` / ``PUT .../attrs``); an attribute
    written again with an equal value is not a change."""
    changes: dict[str, Change] = {}
    attrs = {}
    for name, given in inputs.items():
        attrs[name], changes[name] = written(entity.attrs.get(name), given, override_metadata=_override(ctx))
    if entity.attrs.keys() - attrs.keys():
        entity.modified = ctx.clock()  # dropping an attribute changes the entity too
    entity.attrs = attrs
    ctx.changed(entity, changes)


#: What deleting an attribute is to subscriptions: a change of it. Orion notifies as for an update,
#: with the attributes left (functional tests 0000_subs_attrs_deletion/*.test and
#: 3956_delete_attribute_notif_fail/delete_attribute_notif_fail.test).
DELETED = Change(value=True, metadata=True)


def delete_attrs(ctx: Context, entity: Entity, key: str, names: list[str], report: WriteReport) -> None:
    report.missing_attrs(key, [name for name in names if name not in entity.attrs], len(names))
    deleted = {name: DELETED for name in names if entity.attrs.pop(name, None) is not None}
    if deleted:
        ctx.changed(entity, deleted)


# --- /v2/entities --------------------------------------------------------------------------------------


def entity_page(ctx: Context, matches: list[Entity], attrs: list[str] | None) -> Response:
    """A list answer: ``limit``/``offset`` applied, ``Fiware-Total-Count`` with ``options=count``."""
    limit, offset = ctx.page_bounds()
    fmt = ctx.render_format()
    body = [render_entity(e, attrs, fmt) for e in matches[offset : offset + limit]]
    headers = (("Fiware-Total-Count", str(len(matches))),) if "count" in ctx.options else ()
    return json_response(body, headers=headers)


def _param_list(ctx: Context, name: str) -> list[str] | None:
    value = ctx.params.get(name)
    return value.split(",") if value is not None else None


def _types_param(ctx: Context) -> list[str] | None:
    """Every ``type`` of the query string (a repeated one adds up, engine.ADDING_PARAMS), which
    getEntities.cpp queries."""
    values = ctx.repeated.get("type")
    return None if values is None else [t for value in values for t in value.split(",")]


def list_entities(ctx: Context) -> Response:
    ids, types = _param_list(ctx, "id"), _types_param(ctx)
    id_pattern, type_pattern = ctx.params.get("idPattern"), ctx.params.get("typePattern")
    if ids is not None and id_pattern is not None:
        raise bad_request("Incompatible parameters: id, IdPattern")
    if types is not None and type_pattern is not None:
        raise bad_request("Incompatible parameters: type, typePattern")
    id_re = re.compile(check_pattern(id_pattern, "idPattern")) if id_pattern is not None else None
    if ids is not None and compiles(listed := "|".join(f"^{i}$" for i in ids if i)):
        # Orion turns an id list into the regex ^a$|^b$ (serviceRoutinesV2/getEntities.cpp), so an id
        # is a pattern: id=robot.1 also lists robot_1.
        id_re, ids = re.compile(listed), None
    type_re = re.compile(check_pattern(type_pattern, "typePattern")) if type_pattern is not None else None
    matches = [
        e
        for e in ctx.tenant().entities.values()
        if ctx.scope.sees(e.service_path)
        and (ids is None or e.id in ids)
        and (types is None or e.type in types)
        and (id_re is None or id_re.search(e.id))
        and (type_re is None or type_re.search(e.type))
    ]
    return entity_page(ctx, matches, ctx.attrs_param())


#: Orion's limit on id + type + Fiware-ServicePath (MongoDB's key size), with its structural overhead
#: (serviceRoutinesV2/postEntities.cpp legalEntityLength).
MAX_ENTITY_KEY = 1024 - 10


def create_entity(ctx: Context) -> Response:
    given = parse_entity(ctx.body, key_values="keyValues" in ctx.options)
    header = ctx.request.header("Fiware-ServicePath") or ""
    if len(header) + len(given.id) + len(given.type or DEFAULT_ENTITY_TYPE) >= MAX_ENTITY_KEY:
        raise bad_request("Too long entity id/type/servicePath combination")
    path = ctx.scope.write_path()
    existing = ctx.tenant().entities.get((path, given.id, given.type or DEFAULT_ENTITY_TYPE))
    if existing is not None:
        if "upsert" not in ctx.options:
            raise unprocessable("Already Exists")
        append(ctx, existing, given.attrs, WriteReport())
        return empty_response(204, location(existing))
    # With upsert Orion answers 204 whether it updated or created (serviceRoutinesV2/postEntities.cpp;
    # functional test 3215_upsert_op/upsert_op_as_create.test).
    return empty_response(204 if "upsert" in ctx.options else 201, location(create(ctx, given)))


# --- /v2/entities/{id} and /attrs -----------------------------------------------------------------------


def get_entity(ctx: Context, entity_id: str) -> Response:
    entity = ctx.find(entity_id, ctx.params.get("type"))
    return json_response(render_entity(entity, ctx.attrs_param(), ctx.render_format()))


def get_attrs(ctx: Context, entity_id: str) -> Response:
    entity = ctx.find(entity_id, ctx.params.get("type"))
    return json_response(render_entity(entity, ctx.attrs_param(), ctx.render_format(), with_id=False))


def delete_entity(ctx: Context, entity_id: str) -> Response:
    ctx.tenant().remove(ctx.find_for_write(entity_id, ctx.params.get("type")))
    return empty_response()


def _attrs_write(ctx: Context, entity_id: str) -> tuple[Entity, str, dict[str, AttributeInput]]:
    """The common start of POST/PATCH/PUT ``.../attrs``: parsed payload, target entity, its name."""
    inputs = parse_attrs_body(ctx.body, key_values="keyValues" in ctx.options)
    entity_type = ctx.params.get("type")
    return ctx.find_for_write(entity_id, entity_type), entity_key(entity_id, entity_type), inputs


def post_attrs(ctx: Context, entity_id: str) -> Response:
    entity, key, inputs = _attrs_write(ctx, entity_id)
    if not inputs:
        raise bad_request("empty payload")
    report = WriteReport()
    if "append" in ctx.options:
        append_strict(ctx, entity, key, inputs, report)
    else:
        append(ctx, entity, inputs, report)
    return report.response()


def patch_attrs(ctx: Context, entity_id: str) -> Response:
    entity, key, inputs = _attrs_write(ctx, entity_id)
    if not inputs:
        raise bad_request("empty payload")
    report = WriteReport()
    update(ctx, entity, key, inputs, report)
    return report.response()


def put_attrs(ctx: Context, entity_id: str) -> Response:
    entity, _, inputs = _attrs_write(ctx, entity_id)
    replace(ctx, entity, inputs)
    return empty_response()


# --- /v2/entities/{id}/attrs/{name} and /value ------------------------------------------------------------


def _require_attribute(entity: Entity, name: str) -> None:
    if name not in entity.attrs:
        raise not_found(ATTRIBUTE_NOT_FOUND)


def get_attr(ctx: Context, entity_id: str, name: str) -> Response:
    entity = ctx.find(entity_id, ctx.params.get("type"))
    _require_attribute(entity, name)
    return json_response(render_attribute(entity.attrs[name]))


def put_attr(ctx: Context, entity_id: str, name: str) -> Response:
    given = parse_attribute(name, ctx.body, whole_body=True)
    entity = ctx.find_for_write(entity_id, ctx.params.get("type"))
    _require_attribute(entity, name)
    ctx.changed(entity, entity.write({name: given}, override_metadata=_override(ctx)))
    return empty_response()


def delete_attr(ctx: Context, entity_id: str, name: str) -> Response:
    entity = ctx.find_for_write(entity_id, ctx.params.get("type"))
    _require_attribute(entity, name)
    del entity.attrs[name]
    ctx.changed(entity, {name: DELETED})
    return empty_response()


def get_value(ctx: Context, entity_id: str, name: str) -> Response:
    """Objects and arrays as JSON; a string, number, boolean or null as ``text/plain`` (strings in
    quotes) when the client accepts it, else 406, as the NGSI v2 specification says."""
    entity = ctx.find(entity_id, ctx.params.get("type"))
    _require_attribute(entity, name)
    value = entity.attrs[name].value
    if isinstance(value, (dict, list)):
        return json_response(value)
    if not {"*/*", "text/*", "text/plain"}.intersection(accepted_media(ctx.request)):
        raise NgsiError(406, "NotAcceptable", "accepted MIME types: text/plain")
    text = value.encode() if isinstance(value, Moment) else render_json(value)  # a time without quotes
    return Response(200, (("Content-Type", "text/plain"),), text)


#: What C's ``strtod`` reads in full (Orion's str2double, common/string.cpp): decimal or hexadecimal
#: floats, ``inf``/``infinity``/``nan``, surrounding whitespace; not Python's ``1_000``.
_STRTOD = re.compile(
    r"\s*[+-]?(?:(?P<dec>(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)|(?P<hex>0[xX](?:[0-9a-fA-F]+\.?[0-9a-fA-F]*|\.[0-9a-fA-F]+)"
    r"(?:[pP][+-]?\d+)?)|(?P<special>inf(?:inity)?|nan))\s*",
    re.IGNORECASE,
)


def _strtod(text: str) -> float | None:
    """The double ``strtod`` reads from all of ``text``, or None where Orion's str2double fails
    (text left over, or ERANGE: overflow, or underflow of a non-zero number to zero)."""
    match = _STRTOD.fullmatch(text)
    if match is None:
        return None
    body = text.strip()
    if match["hex"]:
        sign = -1.0 if body.startswith("-") else 1.0
        digits = body.lstrip("+-")
        try:
            number = sign * float.fromhex(digits if "p" in digits.lower() else digits + "p0")
        except OverflowError:
            return None
    else:
        number = float(body)
    if match["special"]:
        return number
    mantissa = (match["dec"] or match["hex"]).lower().split("e")[0] if match["dec"] else match["hex"].lower()
    nonzero = any(c not in "0.x" for c in mantissa.split("p")[0])
    if math.isinf(number) or (number == 0 and nonzero):
        return None
    return number


def _plain_text_value(text: str) -> object:
    """A ``text/plain`` value as Orion's textParseAttributeValue (parse/textParse.cpp) reads it:
    ``"quoted"`` is a string (taken as it is, no escapes), ``true``/``True``/``TRUE`` (and false, null
    alike) the constants, else a number as ``strtod`` reads it."""
    if text.startswith('"'):
        if not text.endswith('"'):
            raise bad_request("Missing citation-mark at end of string")
        return text[1:-1]
    for word, constant in (("true", True), ("false", False), ("null", None)):
        if text in (word, word.capitalize(), word.upper()):
            return constant
    number = _strtod(text)
    if number is None:
        raise bad_request("attribute value type not recognized")
    return int(number) if number.is_integer() and abs(number) < 2**53 else number


def put_value(ctx: Context, entity_id: str, name: str) -> Response:
    """Set the value only: the attribute keeps its type and metadata."""
    value = _plain_text_value(ctx.text) if ctx.text is not None else ctx.body
    entity = ctx.find_for_write(entity_id, ctx.params.get("type"))
    _require_attribute(entity, name)
    given = parse_attribute(name, {"value": value, "type": entity.attrs[name].type}, dates=False)
    ctx.changed(entity, entity.write({name: given}))
    return empty_response()
