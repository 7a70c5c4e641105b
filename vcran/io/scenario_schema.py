"""The JSON Schema of scenario files (``vcran schema scenario``), recorded from the loader itself.

The loader (:mod:`vcran.io.scenario_file`) is imperative: each section reader asks a
:class:`~vcran.io.toml_table.Table` for typed fields. Here the whole loader runs on a
:class:`RecordingTable`, which holds no data: every read notes the field (name, type, bounds, default,
whether it is required) and answers with a sample value the loader accepts, so every section, including
ones added later, shows up without a second description of the format to keep in step.

Branches: a field with a fixed set of values is read with :meth:`Table.choice`; the generator runs the
loader once per value (a script entry's ``kind``, and the choices inside each kind), and a table whose
fields differ by the value of a choice becomes one ``if``/``then`` schema per value. Defaults that are
computed from other fields (``max_deceleration`` = ``max_acceleration``, a robot's ``agv_id`` = its
``id``) are left out: every run is made twice with different samples, and only defaults that do not move
are written.

The schema is never stricter than the loader and may be looser: it checks names, types, bounds, required
fields and unknown keys; rules between fields (``seq`` within its length, ``carrying`` within
``capacity``, unique ids, valid Orion ids, an entry within ``duration``) are the loader's alone. It is JSON
Schema draft-07, which TOML language servers (Taplo, "Even Better TOML") read.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

from vcran.core.orion_rules import FORBIDDEN_CHARS
from vcran.core.validity.fields import Choices, Integer, Number, OneOf
from vcran.io.scenario_file import read
from vcran.io.toml_table import _MISSING, _NO_RULES, Rules, Table

__all__ = ["RecordingTable", "scenario_schema"]

DRAFT = "http://json-schema.org/draft-07/schema#"
#: A published string: none of the characters Orion refuses in values (docs/contract.md §2).
_PUBLISHABLE = "^[^" + "".join("\\" + c if c in "\\]^-" else c for c in sorted(FORBIDDEN_CHARS)) + "]*$"
_NUMBER = {"type": "number"}
_PAIR = {"type": "array", "items": _NUMBER, "minItems": 2, "maxItems": 2}
_POSE = {"type": "array", "items": _NUMBER, "minItems": 2, "maxItems": 3}

Choice = tuple[str, str]  # (table path, key)


@dataclass
class _Field:
    schema: dict[str, Any]
    required: bool
    default: Any = None  # None: no default worth writing
    child: str | None = None  # path of the table this field holds (table, or each item of tables)
    many: bool = False  # tables: an array of them


@dataclass
class _Run:
    """One pass of the loader over recording tables."""

    forced: dict[Choice, str]
    variant: int  # 0 or 1: which sample values
    tables: dict[str, list[RecordingTable]] = field(default_factory=dict)
    choices: dict[Choice, tuple[str, ...]] = field(default_factory=dict)
    complaints: list[str] = field(default_factory=list)


class RecordingTable(Table):
    """A Table without data: each read records the field and returns a sample the loader accepts.

    Every public reading method of :class:`Table` is overridden here (a test checks it), so a new method
    is noticed. A loader check that still refuses a sample (``fail``) is noted and the reader goes on:
    the fields come before the checks that relate them.
    """

    def __init__(self, run: _Run, path: str, rules: Rules = _NO_RULES) -> None:
        super().__init__({}, "<schema>", path, rules)
        self.run, self.path = run, path
        self.fields: dict[str, _Field] = {}
        self.chosen: dict[str, str] = {}
        self.closed = False
        run.tables.setdefault(path, []).append(self)

    # --- bookkeeping ------------------------------------------------------------------------------------

    def _note(self, key: str, schema: dict[str, Any], default: Any, **kw: Any) -> None:
        self.used.add(key)
        required = default is _MISSING
        self.fields[key] = _Field(dict(schema), required, None if required else _plain(default), **kw)

    def _sample(self, a: Any, b: Any) -> Any:
        return b if self.run.variant else a

    def fail(self, key: str, problem: str) -> Any:  # type: ignore[override]  # notes instead of raising
        self.run.complaints.append(f"{self.path}.{key}: {problem}")

    def reject(self, problem: str) -> Any:  # type: ignore[override]  # notes instead of raising
        self.run.complaints.append(f"{self.path}: {problem}")

    def done(self) -> None:
        self.closed = True

    def _child(self, key: str, many: bool, rules: Rules) -> RecordingTable:
        path = f"{self.path}.{key}" if self.path else key
        return RecordingTable(self.run, path + "[]" if many else path, rules)

    def _options(self, key: str, options: Sequence[str]) -> Sequence[str]:
        """The values a key may take: its rule's (:mod:`vcran.core.validity`), else the read's."""
        rule = self.rules.get(key)
        return rule.options if isinstance(rule, (OneOf, Choices)) else options

    # --- the reads --------------------------------------------------------------------------------------

    def raw(self, key: str, default: Any = _MISSING) -> Any:
        self._note(key, {}, default)
        return {}

    def table(self, key: str, rules: Rules = _NO_RULES) -> Table:
        child = self._child(key, False, rules)
        self._note(key, {}, {}, child=child.path)
        return child

    def optional_table(self, key: str, rules: Rules = _NO_RULES) -> Table | None:
        child = self._child(key, False, rules)
        self._note(key, {}, None, child=child.path)
        return child

    def tables(self, key: str, rules: Rules = _NO_RULES) -> list[Table]:
        child = self._child(key, True, rules)
        self._note(key, {}, [], child=child.path, many=True)
        return [child]

    def number(self, key: str, default: Any = _MISSING, *, minimum: float | None = None, positive: bool = False) -> Any:
        rule = self.rules.get(key)
        if isinstance(rule, Number):
            minimum, positive = rule.minimum, rule.positive
        schema: dict[str, Any] = dict(_NUMBER)
        if minimum is not None:
            schema["minimum"] = minimum
        if positive:
            schema["exclusiveMinimum"] = 0
        self._note(key, schema, default)
        return (minimum or 0.0) + 1.0 + self.run.variant

    def integer(self, key: str, default: Any = _MISSING, *, minimum: int | None = None) -> Any:
        rule = self.rules.get(key)
        if isinstance(rule, Integer):
            minimum = rule.minimum
        self._note(key, {"type": "integer"} | ({} if minimum is None else {"minimum": minimum}), default)
        return (minimum or 0) + 1 + self.run.variant

    def boolean(self, key: str, default: Any = _MISSING) -> Any:
        self._note(key, {"type": "boolean"}, default)
        return self._sample(True, False)

    def string(self, key: str, default: Any = _MISSING) -> Any:
        self._note(key, {"type": "string", "minLength": 1}, default)
        return self._sample("x0", "x1")

    def text(self, key: str, default: str) -> str:
        self._note(key, {"type": "string", "minLength": 1, "pattern": _PUBLISHABLE}, default)
        return str(self._sample("x0", "x1"))

    def name(self, key: str, default: Any = _MISSING) -> Any:
        self._note(key, {"type": ["string", "integer"], "minLength": 1, "pattern": _PUBLISHABLE}, default)
        return self._sample("x0", "x1")

    def choice(self, key: str, options: Sequence[str] = (), default: Any = _MISSING, *, hint: str = "",
               what: str = "") -> Any:
        options = self._options(key, options)
        self._note(key, {"enum": list(options)}, default)
        point = (self.path, key)
        self.run.choices[point] = tuple(options)
        self.chosen[key] = self.run.forced.get(point, options[0])
        return self.chosen[key]

    def choices(self, key: str, options: Sequence[str] = (), default: Any = _MISSING, *,
                what: str = "value") -> list[str]:
        options = self._options(key, options)
        self._note(key, {"type": "array", "items": {"enum": list(options)}}, default)
        return [options[0]]

    def strings(self, key: str, default: list[str]) -> list[str]:
        self._note(key, {"type": "array", "items": {"type": "string"}}, default)
        return [self._sample("x0", "x1")]

    def pair(self, key: str, default: Any = _MISSING) -> tuple[float, float]:
        self._note(key, _PAIR, default)
        v = 1.0 + self.run.variant
        return v, v

    def triple(self, key: str, default: Any = _MISSING) -> tuple[float, float, float]:
        self._note(key, {"type": "array", "items": _NUMBER, "minItems": 3, "maxItems": 3}, default)
        v = 1.0 + self.run.variant
        return v, v, 0.0

    def sequence(self, key: str) -> tuple[int, int]:
        item = {"type": "integer", "minimum": 1}
        self._note(key, {"type": "array", "items": item, "minItems": 2, "maxItems": 2}, _MISSING)
        return 1, 1 + self.run.variant

    def points(self, key: str, default: list[Any]) -> list[tuple[float, float]]:
        self._note(key, {"type": "array", "items": _PAIR}, default)
        return [(-1e3, -1e3), (1e3, -1e3), (1e3, 1e3), (-1e3, 1e3)]

    def pose(self, key: str, default: Any = _MISSING) -> Any:
        self._note(key, _POSE, default)
        v = 1.0 + self.run.variant
        return v, v, None

    def place(self, key: str, default: Any = _MISSING) -> Any:
        self._note(key, {"oneOf": [{"type": "string", "minLength": 1}, _POSE]}, default)
        v = 1.0 + self.run.variant
        return v, v, None

    def weights(self, key: str) -> list[tuple[str, float]]:
        names = {"type": "array", "items": {"type": "string"}, "minItems": 1}
        table = {"type": "object", "additionalProperties": {"type": "number", "exclusiveMinimum": 0}, "minProperties": 1}
        self._note(key, {"oneOf": [names, table]}, _MISSING)
        return [(self._sample("x0", "x1"), 1.0)]

    def document(self, key: str, default: Any = _MISSING) -> Any:
        self._note(key, {"type": ["object", "string"]}, default)
        return {}

    def poses(self, key: str, default: list[Any]) -> list[tuple[float, float, float | None]]:
        self._note(key, {"type": "array", "items": _POSE}, default)
        return [(1.0, 1.0, None), (2.0, 2.0, self._sample(0.0, 1.0))]


def _plain(value: Any) -> Any:
    """``value`` as JSON, or None when it has no JSON form worth writing as a default (inf, None)."""
    if isinstance(value, tuple | list):
        items = [_plain(v) for v in value]
        return None if any(i is None for i in items) else items
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return None  # an empty sub-table: nothing to say
    return value


# --- running the loader, then merging what the runs saw ---------------------------------------------------


def _record(forced: dict[Choice, str], variant: int) -> _Run:
    run = _Run(forced, variant)
    try:
        read(RecordingTable(run, ""), default_name=f"scenario{variant}")
    except Exception as exc:  # the loader refused a sample value: the samples above need a change
        raise RuntimeError(f"scenario schema: the loader refused the sample values ({exc!r}; "
                           f"noted: {run.complaints})") from exc
    return run


def _runs() -> list[_Run]:
    """Every run: the first choice of everything, then each other value of each choice once (in the run
    that reached it), each twice (variants 0 and 1)."""
    runs: list[_Run] = []
    explored: set[Choice] = set()
    todo: list[dict[Choice, str]] = [{}]
    while todo:
        forced = todo.pop(0)
        pair = [_record(forced, 0), _record(forced, 1)]
        runs += pair
        for point, options in pair[0].choices.items():
            if point not in explored and point not in forced:
                explored.add(point)
                todo += [{**forced, point: option} for option in options[1:]]
    return runs


def scenario_schema() -> dict[str, Any]:
    """The JSON Schema (draft-07) of a scenario file, as a dict ready for ``json.dumps``."""
    tables: dict[str, list[RecordingTable]] = {}
    for run in _runs():
        for path, recorded in run.tables.items():
            tables.setdefault(path, []).extend(recorded)
    schema = _object(tables, "")
    return {"$schema": DRAFT, "title": "vcran scenario file",
            "description": "A vcran scenario (docs/scenarios.md), as `vcran schema scenario` writes it.", **schema}


def _object(tables: dict[str, list[RecordingTable]], path: str) -> dict[str, Any]:
    recorded = tables[path]
    closed = all(t.closed for t in recorded)
    key = _discriminator(recorded)
    if key is None:
        return _properties(tables, recorded, closed)
    groups: dict[str, list[RecordingTable]] = {}
    for t in recorded:
        groups.setdefault(t.chosen[key], []).append(t)
    options = recorded[0].fields[key].schema["enum"]
    return {
        "type": "object",
        "required": [key],
        "properties": {key: {"enum": options}},
        "allOf": [
            {"if": {"properties": {key: {"const": option}}, "required": [key]},
             "then": _properties(tables, groups[option], closed)}
            for option in options
        ],
    }


def _discriminator(recorded: list[RecordingTable]) -> str | None:
    """The choice, read in every recording of this table, whose values bring different fields."""
    found = []
    for key in recorded[0].chosen:
        if not all(key in t.chosen for t in recorded):
            continue
        shapes: dict[Any, set[tuple[str, ...]]] = {}
        for t in recorded:
            shapes.setdefault(t.chosen[key], set()).add(tuple(t.fields))
        if len({frozenset(s) for s in shapes.values()}) > 1:
            found.append(key)
    if len(found) > 1:
        raise NotImplementedError(f"scenario schema: a table whose fields depend on two choices: {found}")
    return found[0] if found else None


def _properties(tables: dict[str, list[RecordingTable]], recorded: list[RecordingTable], closed: bool) -> dict[str, Any]:
    """One object schema for recordings of a table that read the same fields (two variants, and runs
    that differ elsewhere); a field read in only some of them is optional."""
    properties: dict[str, Any] = {}
    required: list[str] = []
    for t in recorded:
        for key, f in t.fields.items():
            if key in properties:
                continue
            seen = [r.fields.get(key) for r in recorded]
            schema = dict(f.schema)
            if f.child is not None:
                child = _object(tables, f.child)
                schema = {"type": "array", "items": child} if f.many else child
            defaults = {repr(s.default) for s in seen if s is not None}
            if not f.required and f.default is not None and len(defaults) == 1:
                schema["default"] = f.default
            properties[key] = schema
            if all(s is not None and s.required for s in seen):
                required.append(key)
    out: dict[str, Any] = {"type": "object", "properties": properties}
    if required:
        out["required"] = required
    if closed:
        out["additionalProperties"] = False
    return out
