"""A fast yes to "is this message valid against its schema?", for the schemas VDA 5050 publishes.

jsonschema walks a schema keyword by keyword for every message, through its generic machinery (a validator
evolved for each subschema, each ``$ref`` resolved through a registry): 4 ms for a 10-node order
(benchmarks/bench_vda5050.py), most of a closed loop's cost, where every order a master sends is checked
as the vehicle receives it (issue 31: 100 vehicles in the closed loop ran at 3x the CPU of OPIL's). The
official schemas use a handful of keywords; :func:`compile_schema` writes a schema of only those as nested
Python checks, once. A check answers True only where jsonschema's Draft 2020-12 validator (without format
checking, as vcran builds it) finds no error; anything else goes to jsonschema, which also names the
problem (:func:`vcran.core.vda5050.validation.first_problem`). A schema with any keyword outside the
handful gets no check (None), and jsonschema does all of it.

The keywords and their meaning, as jsonschema implements them: ``type`` (a name or a list; a bool is no
number, and an integer is an int or a float with no fraction), ``enum`` of strings, ``minimum`` and
``maximum`` on numbers, ``required`` and ``properties`` on objects (other properties allowed), ``items``
(one schema) on arrays, ``anyOf``, and ``$ref`` to a place in the same document; annotations (``title``,
``description``, ``format``, ``examples`` ...) assert nothing.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

Check = Callable[[Any], bool]

#: Keywords that assert nothing here (``format`` is an annotation unless a format checker is given).
ANNOTATIONS = frozenset({"$schema", "$id", "$comment", "title", "description", "examples", "default", "format",
                         "subtopic", "definitions", "$defs", "deprecated", "readOnly", "writeOnly"})
#: The keywords compiled (module docstring).
ASSERTIONS = frozenset({"type", "enum", "minimum", "maximum", "required", "properties", "items", "anyOf", "$ref"})


def _number(x: Any) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


TYPES: dict[str, Check] = {
    "object": lambda x: isinstance(x, dict),
    "array": lambda x: isinstance(x, list),
    "string": lambda x: isinstance(x, str),
    "boolean": lambda x: isinstance(x, bool),
    "null": lambda x: x is None,
    "number": _number,
    "integer": lambda x: (isinstance(x, int) and not isinstance(x, bool)) or (isinstance(x, float) and x.is_integer()),
}


class Unsupported(Exception):
    """The schema uses what this module does not compile (internal): jsonschema checks it all."""


def compile_schema(root: Any) -> Check | None:
    """A check of documents against ``root`` (module docstring), or None if ``root`` goes beyond its keywords."""
    try:
        return _compile(root, root, {})
    except Unsupported:
        return None


def _compile(schema: Any, root: Any, refs: dict[str, list[Check]]) -> Check:
    if schema is True:
        return lambda x: True
    if schema is False:
        return lambda x: False
    if not isinstance(schema, dict) or not set(schema) <= ANNOTATIONS | ASSERTIONS:
        raise Unsupported
    checks: list[Check] = []
    if "type" in schema:
        names = [schema["type"]] if isinstance(schema["type"], str) else schema["type"]
        if not isinstance(names, list) or any(name not in TYPES for name in names):
            raise Unsupported
        kinds = tuple(TYPES[name] for name in names)
        checks.append(kinds[0] if len(kinds) == 1 else lambda x: any(kind(x) for kind in kinds))
    if "enum" in schema:
        values = schema["enum"]
        if not isinstance(values, list) or not all(isinstance(v, str) for v in values):
            raise Unsupported  # jsonschema's equality of other values (1 and 1.0 equal, True and 1 not) is not copied
        allowed = frozenset(values)
        checks.append(lambda x: isinstance(x, str) and x in allowed)
    for key, fails in (("minimum", lambda x, m: x < m), ("maximum", lambda x, m: x > m)):
        if key in schema:
            bound = schema[key]
            if not _number(bound):
                raise Unsupported
            checks.append(lambda x, bound=bound, fails=fails: not _number(x) or not fails(x, bound))
    if "required" in schema:
        names = tuple(schema["required"])
        checks.append(lambda x: not isinstance(x, dict) or all(name in x for name in names))
    if "properties" in schema:
        if not isinstance(schema["properties"], dict):
            raise Unsupported
        properties = tuple((name, _compile(sub, root, refs)) for name, sub in schema["properties"].items())
        checks.append(lambda x: not isinstance(x, dict) or all(
            check(x[name]) for name, check in properties if name in x))
    if "items" in schema:
        item = _compile(schema["items"], root, refs)  # a list (draft 4-7's tuple form) is not a schema: Unsupported
        checks.append(lambda x: not isinstance(x, list) or all(item(i) for i in x))
    if "anyOf" in schema:
        if not isinstance(schema["anyOf"], list) or not schema["anyOf"]:
            raise Unsupported
        options = tuple(_compile(sub, root, refs) for sub in schema["anyOf"])
        checks.append(lambda x: any(option(x) for option in options))
    if "$ref" in schema:
        checks.append(_ref(schema["$ref"], root, refs))
    if not checks:
        return lambda x: True
    if len(checks) == 1:
        return checks[0]
    every = tuple(checks)
    return lambda x: all(check(x) for check in every)


def _ref(pointer: Any, root: Any, refs: dict[str, list[Check]]) -> Check:
    """The check of the place ``pointer`` names in ``root`` (``#/definitions/node``), compiled once; a
    reference met again while it is being compiled is checked through its holder when it runs."""
    if not isinstance(pointer, str) or not pointer.startswith("#/"):
        raise Unsupported
    holder = refs.get(pointer)
    if holder is None:
        holder = refs[pointer] = []
        target = root
        for part in pointer[2:].split("/"):
            part = part.replace("~1", "/").replace("~0", "~")
            if not isinstance(target, dict) or part not in target:
                raise Unsupported
            target = target[part]
        holder.append(_compile(target, root, refs))
    return lambda x: holder[0](x)
