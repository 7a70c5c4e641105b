"""The batch operations: ``POST /v2/op/update`` and ``POST /v2/op/query``.

``op/update`` splits into one write per entity, in order, with the semantics of the matching single
operation (Orion's manual, "update action types"): ``append`` creates the entity or updates and adds
attributes; ``appendStrict`` refuses existing attributes; ``update`` needs the entity and its attributes;
``replace`` needs the entity and swaps all its attributes; ``delete`` removes the listed attributes, or
the entity when none are listed. The whole payload is checked before anything is applied (an invalid id
anywhere rejects the batch), then each entity that changes notifies on its own.
"""

from __future__ import annotations

from typing import Any

from vcran.broker.context import Context
from vcran.broker.entities import (
    WriteReport,
    append,
    append_strict,
    create,
    delete_attrs,
    entity_key,
    entity_page,
    replace,
    update,
)
from vcran.broker.model import EntityInput, parse_entity
from vcran.broker.protocol import NgsiError, Response, bad_request, not_implemented, parse_error
from vcran.broker.scope import check_entity_object, parse_query_selector

ACTION_TYPES = ("append", "appendStrict", "update", "delete", "replace")
#: NGSIv1 spellings that Orion still accepts (deprecated).
LEGACY_ACTION_TYPES = {
    "APPEND": "append",
    "APPEND_STRICT": "appendStrict",
    "UPDATE": "update",
    "DELETE": "delete",
    "REPLACE": "replace",
}


def _payload_object(body: Any) -> dict[str, Any]:
    """A batch payload's top level as Orion's parseBatchUpdate/parseBatchQuery check it: not an object
    is a ParseError, ``{}`` an empty payload."""
    if not isinstance(body, dict):
        raise parse_error()
    if not body:
        raise bad_request("empty payload")
    return body


def _action_type(action: Any) -> str:
    if not isinstance(action, str):
        raise bad_request("invalid JSON type for actionType")
    action = LEGACY_ACTION_TYPES.get(action, action)
    if action not in ACTION_TYPES:
        # Orion's words, typo included (jsonParseV2/parseBatchUpdate.cpp)
        raise bad_request("invalid update action type: right ones are: append, appendStric, delete, replace, update")
    return action


def op_update(ctx: Context) -> Response:
    """Checked as Orion's jsonParseV2/parseBatchUpdate.cpp does: both mandatory fields present, then
    each member in payload order; any other member is refused."""
    body = _payload_object(ctx.body)
    for field in ("entities", "actionType"):
        if field not in body:
            raise bad_request(f"Invalid JSON payload, mandatory field /{field}/ not found")
    key_values = "keyValues" in ctx.options
    action = ""
    inputs: list[EntityInput] = []
    for name, value in body.items():
        if name == "entities":
            if not isinstance(value, list):
                raise bad_request("not a JSON array")
            inputs = [_batch_entity(raw, key_values) for raw in value]
        elif name == "actionType":
            action = _action_type(value)
        else:
            raise bad_request(f"Unrecognized field in JSON payload: /{name}/")
    if not inputs:
        raise bad_request("empty entities vector")
    report = WriteReport()
    for given in inputs:
        _apply(ctx, action, given, report)
    return report.response()


def _batch_entity(raw: Any, key_values: bool) -> EntityInput:
    """An ``op/update`` entity (jsonParseV2/parseEntityObject.cpp): an object with an ``id``;
    ``idPattern`` is Orion's 501."""
    raw = check_entity_object(raw)
    if "idPattern" in raw:
        raise NgsiError(501, "NotImplemented", "NotImplemented")
    return parse_entity(raw, key_values=key_values, batch=True)


def _apply(ctx: Context, action: str, given: EntityInput, report: WriteReport) -> None:
    key = entity_key(given.id, given.type)
    entity = ctx.writable(given.id, given.type)
    if entity is None:
        if action in ("append", "appendStrict"):
            create(ctx, given)
            report.success()
        else:
            report.missing_entity(key)
        return
    if action == "append":
        append(ctx, entity, given.attrs, report)
    elif action == "appendStrict":
        append_strict(ctx, entity, key, given.attrs, report)
    elif action == "update":
        update(ctx, entity, key, given.attrs, report)
    elif action == "replace":
        replace(ctx, entity, given.attrs)
        report.success()
    elif given.attrs:
        delete_attrs(ctx, entity, key, list(given.attrs), report)
    else:
        ctx.tenant().remove(entity)
        report.success()


def op_query(ctx: Context) -> Response:
    """Entities matching any of ``entities`` (all when absent), projected to ``attrs``; the payload
    checked as Orion's jsonParseV2/parseBatchQuery.cpp does, member by member."""
    body = _payload_object(ctx.body)
    if not {"entities", "attributes", "attrs", "expression"} & body.keys():
        raise bad_request("Invalid JSON payload, no relevant fields found")
    matchers = []
    attrs: list[str] | None = None
    for name, value in body.items():
        if name == "entities":
            if not isinstance(value, list):
                raise bad_request("not a JSON array")
            matchers = [parse_query_selector(raw) for raw in value]
        elif name in ("attrs", "attributes", "metadata"):
            if not isinstance(value, list):
                raise bad_request(f"the field /{name}/ must be a JSON array")
            if not all(isinstance(a, str) for a in value):
                raise bad_request(f"only JSON Strings allowed in {name} list")
            if name == "attrs":
                attrs = list(dict.fromkeys(value))
            elif value:
                raise not_implemented(f"op/query {name!r}")
        elif name == "expression":
            raise not_implemented("op/query expressions (q, mq, geo)")
        else:
            raise bad_request(f"Unrecognized field in JSON payload: /{name}/")
    matches = [
        e
        for e in ctx.tenant().entities.values()
        if ctx.scope.sees(e.service_path) and (not matchers or any(m.matches(e) for m in matchers))
    ]
    return entity_page(ctx, matches, attrs or None)
