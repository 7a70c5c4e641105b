"""A strict, typed reader of one TOML table: what makes scenario files fail early and precisely.

Every read names the file, the entry and the field when it fails (:class:`ScenarioError`); ``done()``
refuses keys nobody read (typos). Kept apart from :mod:`vcran.io.scenario_file` so that the scenario module is
about scenarios, not about reading TOML.

What a value may be is the model's: a table opened with ``rules`` (the model's rules for that part,
:mod:`vcran.core.validity`) checks each key that has one with it, on the value as the file writes it, so a
bound said in the core is told "got -1" for ``-1`` and recorded in the schema; a key without a rule (a
sweep file's, or one the model does not hold) is checked with the bounds the read names. The wording of
every check of one value is the core's (:mod:`vcran.core.validity.fields`).

The JSON Schema of the format (``vcran schema scenario``) is recorded from these reads
(:mod:`vcran.io.scenario_schema` runs the loader on a recording subclass), so a section reader states what
it reads through these methods: sub-tables through :meth:`Table.table`/:meth:`Table.tables` (never
``Table(...)`` directly), a field with a fixed set of values through :meth:`Table.choice`, and a field that
is required only in some cases as optional, checked afterwards.
"""

from __future__ import annotations

import tomllib
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any, NoReturn

from vcran.core.validity.fields import (
    INT64,
    Rule,
    choices_problem,
    describe,
    flag_problem,
    integer_problem,
    is_number,
    name_problem,
    number_problem,
    one_of_problem,
    pair_problem,
    place_problem,
    points_problem,
    pose_problem,
    string_problem,
    strings_problem,
    text_problem,
    triple_problem,
    weights_problem,
)

__all__ = ["INT64", "ScenarioError", "Table", "is_number", "read_toml"]

#: A part's rules, by key (:mod:`vcran.core.validity`).
Rules = Mapping[str, Rule]
_NO_RULES: Rules = {}


class ScenarioError(ValueError):
    """A scenario that cannot run; the message names the file, the entry and the field."""


def read_toml(path: Path, kind: str = "scenario") -> tuple[str, dict[str, Any]]:
    """The text of the TOML file at ``path`` and its table. A file that is missing, a folder, unreadable,
    not UTF-8 or not TOML is a ScenarioError naming it (scenario and sweep files alike: ``kind``)."""
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise ScenarioError(f"{path}: no such file") from None
    except IsADirectoryError:
        raise ScenarioError(f"{path}: is a folder, not a {kind} file") from None
    except OSError as exc:
        raise ScenarioError(f"{path}: cannot read: {exc.strerror}") from None
    if raw.startswith(b"\xef\xbb\xbf"):  # what Notepad writes as "UTF-8"; tomllib says "Invalid statement"
        raise ScenarioError(f"{path}: starts with a byte-order mark, which TOML does not allow: save it as UTF-8 "
                            "without BOM")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ScenarioError(f"{path}: not UTF-8 text (byte {exc.start}); {kind} files are TOML, which is UTF-8") from None
    try:
        return text, tomllib.loads(text)
    except ValueError as exc:  # TOMLDecodeError, or an integer of more than 4300 digits
        reason = str(exc).split("; use sys.set_int_max_str_digits", 1)[0]
        raise ScenarioError(f"{path}: not valid TOML: {reason}") from None


_MISSING = object()


class Table:
    """Typed, strict reads from one TOML table; every failure names file, entry and field. A key left out
    reads as the read's ``default``, the reader's own value, returned as it is."""

    __slots__ = ("data", "source", "where", "rules", "used")

    def __init__(self, data: Any, source: str, where: str, rules: Rules = _NO_RULES) -> None:
        if not isinstance(data, dict):
            raise ScenarioError(f"{source}: {where}: expected a table, got {type(data).__name__}")
        self.data, self.source, self.where, self.rules = data, source, where, rules
        self.used: set[str] = set()

    def fail(self, key: str, problem: str) -> NoReturn:
        raise ScenarioError(f"{self.source}: {describe(self.where, key, problem)}")

    def raw(self, key: str, default: Any = _MISSING) -> Any:
        self.used.add(key)
        if key in self.data:
            return self.data[key]
        if default is _MISSING:
            self.fail(key, "missing")
        return default

    def reject(self, problem: str) -> NoReturn:
        """A rule between fields or sections is broken: the message names the file (and table), no field."""
        raise ScenarioError(f"{self.source}: {describe(self.where, None, problem)}")

    def done(self) -> None:
        if self.used.issuperset(self.data):
            return
        self.fail(sorted(set(self.data) - self.used)[0], "unknown key (a typo?)")

    def bind(self, rules: Rules) -> Table:
        """This table, its keys checked with ``rules`` too (a script entry's, once its kind is known)."""
        self.rules = {**self.rules, **rules}
        return self

    def table(self, key: str, rules: Rules = _NO_RULES) -> Table:
        return Table(self.raw(key, {}), self.source, self._sub(key), rules)

    def optional_table(self, key: str, rules: Rules = _NO_RULES) -> Table | None:
        """A sub-table whose presence means something (``[manager]``, ``[job_stream]``): None when absent."""
        return self.table(key, rules) if key in self.data else None

    def tables(self, key: str, rules: Rules = _NO_RULES) -> list[Table]:
        value = self.raw(key, [])
        if not isinstance(value, list):
            self.fail(key, f"expected an array of tables: [[{key}]] sections, or {key} = [{{...}}, ...]")
        where = self._sub(key)
        return [Table(v, self.source, f"{where}[{i}]", rules) for i, v in enumerate(value)]

    def _sub(self, key: str) -> str:
        return f"{self.where}.{key}" if self.where else key

    def _check(self, key: str, v: Any, own: Callable[..., str | None], *bounds: Any) -> None:
        """Fail with the problem of ``v``: its key's rule's (:mod:`vcran.core.validity`), or for a key without
        one, the read's ``own`` check with the read's ``bounds``."""
        rule = self.rules.get(key)
        problem = own(v, *bounds) if rule is None else rule.check(v)
        if problem:
            self.fail(key, problem)

    def number(self, key: str, default: Any = _MISSING, *, minimum: float | None = None, positive: bool = False) -> Any:
        v = self.raw(key, default)
        if v is default and default is not _MISSING:
            return v
        self._check(key, v, number_problem, minimum, positive)
        return float(v)

    def integer(self, key: str, default: Any = _MISSING, *, minimum: int | None = None) -> Any:
        v = self.raw(key, default)
        if v is default and default is not _MISSING:
            return v
        self._check(key, v, integer_problem, minimum)
        return v

    def boolean(self, key: str, default: Any = _MISSING) -> Any:
        v = self.raw(key, default)
        if v is default and default is not _MISSING:
            return v
        self._check(key, v, flag_problem)
        return v

    def string(self, key: str, default: Any = _MISSING) -> Any:
        v = self.raw(key, default)
        if v is default and default is not _MISSING:
            return v
        self._check(key, v, string_problem)
        return v

    def text(self, key: str, default: str) -> str:
        """A string that will be published: Orion refuses some characters in values (docs/contract.md §2)."""
        v = self.raw(key, default)
        if v is default and default is not _MISSING:
            return v
        self._check(key, v, text_problem)
        return v  # type: ignore[no-any-return]

    def name(self, key: str, default: Any = _MISSING) -> Any:
        """An id name (task, motion, action); an integer is its decimal string (task 100 = "100")."""
        v = self.raw(key, default)
        if v is default and default is not _MISSING:
            return v
        if isinstance(v, int) and not isinstance(v, bool):
            v = str(v)
        self._check(key, v, name_problem)
        return v

    def choice(self, key: str, options: Sequence[str] = (), default: Any = _MISSING, *, hint: str = "",
               what: str = "") -> Any:
        """One of ``options`` (a kind, an action: the key's rule's, if it has one); the error names the value
        as ``what`` (default: the key), lists the options, then ``hint``."""
        v = self.string(key, default)
        if v is default and default is not _MISSING:
            return v
        self._check(key, v, one_of_problem, options, what or key, hint)
        return v

    def choices(self, key: str, options: Sequence[str] = (), default: Any = _MISSING, *,
                what: str = "value") -> list[str]:
        """A list of values, each one of ``options`` (the key's rule's, if it has one)."""
        v = self.raw(key, default)
        if v is default and default is not _MISSING:
            return v
        self._check(key, v, choices_problem, options, what)
        return list(v)

    def strings(self, key: str, default: list[str]) -> list[str]:
        v = self.raw(key, default)
        if v is default and default is not _MISSING:
            return v
        self._check(key, v, strings_problem)
        return list(v)

    def pair(self, key: str, default: Any = _MISSING) -> tuple[float, float]:
        v = self.raw(key, default)
        if v is default and default is not _MISSING:
            return v
        self._check(key, v, pair_problem)
        return float(v[0]), float(v[1])

    def triple(self, key: str, default: Any = _MISSING) -> tuple[float, float, float]:
        v = self.raw(key, default)
        if v is default and default is not _MISSING:
            return v
        self._check(key, v, triple_problem)
        return float(v[0]), float(v[1]), float(v[2])

    def sequence(self, key: str) -> tuple[int, int]:
        v = self.raw(key)
        if not (isinstance(v, list) and len(v) == 2 and all(isinstance(c, int) and not isinstance(c, bool) for c in v)):
            self.fail(key, f"expected [sequence_number, length], got {v!r}")
        if not 1 <= v[0] <= v[1]:
            self.fail(key, f"need 1 <= sequence_number <= length, got {v!r} (R2)")
        return v[0], v[1]

    def points(self, key: str, default: list[Any]) -> list[tuple[float, float]]:
        v = self.raw(key, default)
        if v is default and default is not _MISSING:
            return v
        self._check(key, v, points_problem)
        return [(float(p[0]), float(p[1])) for p in v]

    def pose(self, key: str, default: Any = _MISSING) -> Any:
        """A point ``[x, y]``, or ``[x, y, theta]`` where the heading matters."""
        v = self.raw(key, default)
        if v is default and default is not _MISSING:
            return v
        self._check(key, v, pose_problem)
        return float(v[0]), float(v[1]), float(v[2]) if len(v) == 3 else None

    def place(self, key: str, default: Any = _MISSING) -> Any:
        """A place: a point as :meth:`pose` reads it, or the id of a roadmap node (a string, returned as is)."""
        v = self.raw(key, default)
        if v is default and default is not _MISSING:
            return v
        self._check(key, v, place_problem)
        if isinstance(v, str):
            return v
        return float(v[0]), float(v[1]), float(v[2]) if len(v) == 3 else None

    def weights(self, key: str) -> list[tuple[str, float]]:
        """Names with positive weights: a list of names (equal weights) or a table ``{name = weight}``."""
        v = self.raw(key)
        if isinstance(v, list) and all(isinstance(x, str) for x in v):
            pairs = [(x, 1.0) for x in v]
        elif isinstance(v, dict):
            pairs = list(v.items())
        else:
            self.fail(key, f"expected a list of station ids or a table {{station = weight}}, got {v!r}")
        self._check(key, pairs, weights_problem)
        return [(name, float(w)) for name, w in pairs]

    def poses(self, key: str, default: list[Any]) -> list[tuple[float, float, float | None]]:
        """A path: points ``[x, y]``, or ``[x, y, theta]`` where the heading matters. Each point is checked
        on its own and told by its index (``path[2]``): the key's rule (a list of such points) point by point."""
        v = self.raw(key, default)
        if v is default and default is not _MISSING:
            return v
        if not isinstance(v, list):
            self.fail(key, f"expected a list of [x, y] or [x, y, theta] points, got {v!r}")
        for i, p in enumerate(v):
            if problem := pose_problem(p):
                self.fail(f"{key}[{i}]", problem)
        return [(float(p[0]), float(p[1]), float(p[2]) if len(p) == 3 else None) for p in v]

    def document(self, key: str, default: Any = _MISSING) -> Any:
        """A JSON object written as a TOML table (returned as the dict) or as a JSON text (returned as the
        string, for the caller to parse): a VDA 5050 message in a script (:mod:`vcran.io.scenario_vda5050`)."""
        v = self.raw(key, default)
        if v is default and default is not _MISSING:
            return v
        if not isinstance(v, dict | str):
            self.fail(key, f"expected a table or a JSON text, got {type(v).__name__}")
        return v
