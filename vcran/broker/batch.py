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
from vcran.broker.protocol import Response, bad_request, not_implemented
from vcran.broker.scope import parse_selector

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
    if not isinstance(body, dict):
        raise bad_request("not a JSON object")
    return body


def _action_type(body: dict[str, Any]) -> str:
    action = body.get("actionType")
    if action is None:
        raise bad_request("actionType is missing")
    if not isinstance(action, str):
        raise bad_request("invalid JSON type for actionType")
    action = LEGACY_ACTION_TYPES.get(action, action)
    if action not in ACTION_TYPES:
        raise bad_request("invalid update action type: right ones are: append, appendStrict, delete, replace, update")
    return action


def op_update(ctx: Context) -> Response:
    body = _payload_object(ctx.body)
    action = _action_type(body)
    entities = body.get("entities")
    if not isinstance(entities, list):
        raise bad_request("entities is missing or not an array")
    if not entities:
        raise bad_request("empty entities vector")
    key_values = "keyValues" in ctx.options
    inputs = [parse_entity(raw, key_values=key_values) for raw in entities]
    report = WriteReport()
    for given in inputs:
        _apply(ctx, action, given, report)
    return report.response()


def _apply(ctx: Context, action: str, given: EntityInput, report: WriteReport) -> None:
    key = entity_key(given.id, given.type)
    entity = ctx.writable(given.id, given.type)
    if entity is None:
        if action in ("append", "appendStrict"):
            create(ctx, given)
            report.applied = True
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
        report.applied = True
    elif given.attrs:
        delete_attrs(ctx, entity, key, list(given.attrs), report)
    else:
        ctx.tenant().remove(entity)
        report.applied = True


def op_query(ctx: Context) -> Response:
    """Entities matching any of ``entities`` (all when absent), projected to ``attrs``."""
    body = _payload_object(ctx.body)
    if "expression" in body:
        raise not_implemented("op/query expressions (q, mq, geo)")
    selectors = body.get("entities", [])
    if not isinstance(selectors, list):
        raise bad_request("entities is not an array")
    matchers = [parse_selector(raw) for raw in selectors]
    attrs = body.get("attrs")
    if attrs is not None and not (isinstance(attrs, list) and all(isinstance(a, str) for a in attrs)):
        raise bad_request("attrs is not an array of strings")
    matches = [
        e
        for e in ctx.tenant().entities.values()
        if ctx.scope.sees(e.service_path) and (not matchers or any(m.matches(e) for m in matchers))
    ]
    return entity_page(ctx, matches, attrs or None)
