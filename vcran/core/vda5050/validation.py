"""The official JSON schemas of VDA 5050 2.0.0 and 2.1.0, as validators built once, and what they say
about a message that fails: the first offending field as a JSON path (``$.nodes[1].sequenceId``).

The schemas ship verbatim in ``schemas/<version>/`` with their MIT licence (VDA). Reading them is the one
thing this package does with files: once per (topic, version), from the installed package, the first
time a message of that kind is validated.

Received messages are validated against the official schema with one correction, for 2.0.0's
``instantActions`` (docs/vda5050.md, "Versions"): its schema names an action's type ``actionName`` and
requires no header, where the 2.0.0 text (§6.9 and the action table of §6.6.6) has ``actionType`` and a
header; 2.1.0 fixed both (VDA5050/vd-m-a-5050 issue 20). The text wins where the two disagree (§6, "If
there are differences between the JSON schemas and this document, the variant in this document
applies"), so a header is required and an action's type may be spelled either way (most 2.0.0 masters
send ``actionType``; one generated from the 2.0.0 schema sends ``actionName``). The same text calls the
list of actions ``instantActions``, the schema ``actions`` (VDA5050/vd-m-a-5050 issue 16; vda-5050-lib
1.x sends ``instantActions``): either is read. :func:`official` gives
the schemas unaltered, for checking what vcran sends.
"""

from __future__ import annotations

import copy
import json
from collections.abc import Iterable
from functools import cache
from importlib.resources import files
from typing import Any

from jsonschema import Draft202012Validator
from jsonschema.exceptions import ValidationError, best_match

from vcran.core.vda5050.enums import Topic, Version
from vcran.core.vda5050.quickcheck import Check, compile_schema

#: How long a quoted value may be in a problem's description before it is cut.
QUOTE = 60


def _file(topic: Topic, version: Version) -> str:
    # 2.0.0's factsheet schema is called factsheet.json upstream; the rest are <topic>.schema.
    if topic is Topic.FACTSHEET and version is Version.V2_0_0:
        return "factsheet.json"
    return f"{topic.value}.schema"


@cache
def official(topic: Topic, version: Version) -> dict[str, Any]:
    """The official schema of ``topic`` in ``version``, as published (a fresh copy is the caller's to keep
    unchanged: it is cached)."""
    text = files("vcran.core.vda5050").joinpath("schemas", version.value, _file(topic, version)).read_text("utf-8")
    schema: dict[str, Any] = json.loads(text)
    return schema


def _corrected(topic: Topic, version: Version) -> dict[str, Any]:
    """The schema received messages are checked against (module docstring)."""
    schema = official(topic, version)
    if topic is Topic.INSTANT_ACTIONS and version is Version.V2_0_0:
        schema = copy.deepcopy(schema)
        action = schema["properties"]["actions"]["items"]
        action["properties"]["actionType"] = action["properties"]["actionName"]
        action["required"] = [r for r in action["required"] if r != "actionName"]
        action["anyOf"] = [{"required": ["actionType"]}, {"required": ["actionName"]}]
        schema["properties"]["instantActions"] = schema["properties"]["actions"]
        schema["required"] = [r for r in official(topic, Version.V2_1_0)["required"] if r != "actions"]
        schema["anyOf"] = [{"required": ["actions"]}, {"required": ["instantActions"]}]
    return schema


@cache
def inbound(topic: Topic, version: Version) -> Draft202012Validator:
    """The validator for received ``topic`` messages of ``version`` (built once)."""
    return Draft202012Validator(_corrected(topic, version))


@cache
def outbound(topic: Topic, version: Version) -> Draft202012Validator:
    """The validator of the official schema, unaltered: what every message vcran sends must pass."""
    return Draft202012Validator(official(topic, version))


def first_problem(validator: Draft202012Validator, doc: Any) -> tuple[str, str] | None:
    """``(path, problem)`` of the most relevant schema violation in ``doc``, or None if it is valid.

    jsonschema's own choice (:func:`~jsonschema.exceptions.best_match`) picks the error; the path names
    the offending field itself, also for a missing one (``$.nodes[0].released``: "required field
    missing"), and the description quotes values briefly.
    """
    quick = _quick(validator)
    if (quick is not None and quick(doc)) or validator.is_valid(doc):
        return None
    error = best_match(validator.iter_errors(doc))
    assert error is not None
    while error.validator in ("anyOf", "oneOf") and error.context:
        error = error.context[0]  # the first alternative: the spelling of the text (actionType)
    return path_of(error), describe(error)


#: Each validator's schema's quick check (:mod:`vcran.core.vda5050.quickcheck`), by the schema's id, with the
#: schema itself (so that the id is not reused while it is kept).
_QUICK: dict[int, tuple[Any, Check | None]] = {}


def _quick(validator: Draft202012Validator) -> Check | None:
    """The quick check of ``validator``'s schema: a yes to most received messages in microseconds where
    jsonschema takes milliseconds; jsonschema still has the last word on every other message."""
    schema = validator.schema
    found = _QUICK.get(id(schema))
    if found is None or found[0] is not schema:
        found = _QUICK[id(schema)] = (schema, compile_schema(schema))
    return found[1]


def path_of(error: ValidationError) -> str:
    keys = list(error.absolute_path)
    if error.validator == "required" and isinstance(error.instance, dict):
        missing = [k for k in error.validator_value if k not in error.instance]
        if missing:
            keys.append(missing[0])
    return json_path(keys)


def json_path(keys: Iterable[str | int]) -> str:
    """``["nodes", 0, "sequenceId"]`` -> ``$.nodes[0].sequenceId`` (keys that are not identifiers are
    quoted: ``$['order.nodes']``)."""
    out = ["$"]
    for key in keys:
        if isinstance(key, int):
            out.append(f"[{key}]")
        elif key.isidentifier():
            out.append(f".{key}")
        else:
            out.append(f"[{json.dumps(key)}]")
    return "".join(out)


_JSON_TYPES = {dict: "object", list: "array", str: "string", bool: "boolean", int: "integer", float: "number",
               type(None): "null"}


def describe(error: ValidationError) -> str:
    """A one-line description of ``error`` that does not repeat the (possibly large) offending value."""
    kind, expected, value = error.validator, error.validator_value, error.instance
    if kind == "required":
        return "required field missing"
    if kind == "type":
        wanted = " or ".join(expected) if isinstance(expected, list) else expected
        return f"expected {wanted}, got {_JSON_TYPES.get(type(value), type(value).__name__)}"
    if kind == "enum":
        return f"{quote(value)} is not one of {', '.join(map(str, expected))}"
    if kind in ("minimum", "maximum", "exclusiveMinimum", "exclusiveMaximum"):
        return f"{quote(value)} is {'below' if 'inimum' in kind else 'above'} the {kind} {expected}"
    return error.message if len(error.message) <= 2 * QUOTE else error.message[: 2 * QUOTE] + "..."


def quote(value: Any) -> str:
    text = json.dumps(value)
    return text if len(text) <= QUOTE else text[:QUOTE] + "..."
