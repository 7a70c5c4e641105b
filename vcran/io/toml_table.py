"""A strict, typed reader of one TOML table: what makes scenario files fail early and precisely.

Every read names the file, the entry and the field when it fails (:class:`ScenarioError`); ``done()``
refuses keys nobody read (typos). Kept apart from :mod:`vcran.io.scenario_file` so that the scenario module is
about scenarios, not about reading TOML.

The JSON Schema of the format (``vcran schema scenario``) is recorded from these reads
(:mod:`vcran.io.scenario_schema` runs the loader on a recording subclass), so a section reader states what
it reads through these methods: sub-tables through :meth:`Table.table`/:meth:`Table.tables` (never
``Table(...)`` directly), a field with a fixed set of values through :meth:`Table.choice`, and a field that
is required only in some cases as optional, checked afterwards.
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Sequence
from pathlib import Path
from typing import Any, NoReturn

from vcran.core.orion_rules import FORBIDDEN_CHARS


class ScenarioError(ValueError):
    """A scenario that cannot run; the message names the file, the entry and the field."""


#: TOML's integers are 64-bit signed (toml.io, "Integer"); tomllib reads longer ones, which numpy, orjson
#: (the trace header, the events) and Parquet (a sweep's seed column) cannot hold.
INT64 = range(-(2**63), 2**63)


def is_number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


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
    """Typed, strict reads from one TOML table; every failure names file, entry and field."""

    def __init__(self, data: Any, source: str, where: str) -> None:
        if not isinstance(data, dict):
            raise ScenarioError(f"{source}: {where}: expected a table, got {type(data).__name__}")
        self.data, self.source, self.where = data, source, where
        self.used: set[str] = set()

    def fail(self, key: str, problem: str) -> NoReturn:
        where = f"{self.where}: " if self.where else ""
        raise ScenarioError(f"{self.source}: {where}field {key!r}: {problem}")

    def raw(self, key: str, default: Any = _MISSING) -> Any:
        self.used.add(key)
        if key in self.data:
            return self.data[key]
        if default is _MISSING:
            self.fail(key, "missing")
        return default

    def reject(self, problem: str) -> NoReturn:
        """A rule between fields or sections is broken: the message names the file (and table), no field."""
        where = f"{self.where}: " if self.where else ""
        raise ScenarioError(f"{self.source}: {where}{problem}")

    def done(self) -> None:
        unknown = sorted(set(self.data) - self.used)
        if unknown:
            self.fail(unknown[0], "unknown key (a typo?)")

    def table(self, key: str) -> Table:
        return Table(self.raw(key, {}), self.source, self._sub(key))

    def optional_table(self, key: str) -> Table | None:
        """A sub-table whose presence means something (``[manager]``, ``[job_stream]``): None when absent."""
        return self.table(key) if key in self.data else None

    def tables(self, key: str) -> list[Table]:
        value = self.raw(key, [])
        if not isinstance(value, list):
            self.fail(key, f"expected an array of tables: [[{key}]] sections, or {key} = [{{...}}, ...]")
        return [Table(v, self.source, self._sub(f"{key}[{i}]")) for i, v in enumerate(value)]

    def _sub(self, key: str) -> str:
        return f"{self.where}.{key}" if self.where else key

    def number(self, key: str, default: Any = _MISSING, *, minimum: float | None = None, positive: bool = False) -> Any:
        v = self.raw(key, default)
        if v is default and default is not _MISSING:
            return v
        if not is_number(v):
            self.fail(key, f"expected a finite number, got {v!r}")
        if positive and v <= 0:
            self.fail(key, f"must be positive, got {v}")
        if minimum is not None and v < minimum:
            self.fail(key, f"must be at least {minimum}, got {v}")
        return float(v)

    def integer(self, key: str, default: Any = _MISSING, *, minimum: int | None = None) -> Any:
        v = self.raw(key, default)
        if v is default and default is not _MISSING:
            return v
        if isinstance(v, bool) or not isinstance(v, int):
            self.fail(key, f"expected an integer, got {v!r}")
        if v not in INT64:
            self.fail(key, f"{v} is outside TOML's 64-bit integer range")
        if minimum is not None and v < minimum:
            self.fail(key, f"must be at least {minimum}, got {v}")
        return v

    def boolean(self, key: str, default: Any = _MISSING) -> Any:
        v = self.raw(key, default)
        if not isinstance(v, bool):
            self.fail(key, f"expected true or false, got {v!r}")
        return v

    def string(self, key: str, default: Any = _MISSING) -> Any:
        v = self.raw(key, default)
        if v is default and default is not _MISSING:
            return v
        if not isinstance(v, str) or not v:
            self.fail(key, f"expected a non-empty string, got {v!r}")
        return v

    def text(self, key: str, default: str) -> str:
        """A string that will be published: Orion refuses some characters in values (SPEC §2)."""
        return self._publishable(key, self.string(key, default))

    def name(self, key: str, default: Any = _MISSING) -> Any:
        """An id name (task, motion, action); an integer is its decimal string (task 100 = "100")."""
        v = self.raw(key, default)
        if v is default and default is not _MISSING:
            return v
        if isinstance(v, int) and not isinstance(v, bool):
            v = str(v)
        if not isinstance(v, str) or not v:
            self.fail(key, f"expected a non-empty string or an integer, got {v!r}")
        return self._publishable(key, v)

    def _publishable(self, key: str, v: str) -> str:
        bad = sorted(set(v) & FORBIDDEN_CHARS)
        if bad:
            self.fail(key, f"contains {' '.join(bad)}, which Orion refuses in values")
        return v

    def choice(self, key: str, options: Sequence[str], default: Any = _MISSING, *, hint: str = "",
               what: str = "") -> Any:
        """One of ``options`` (a kind, an action); the error names the value as ``what`` (default: the key),
        lists the options, then ``hint``."""
        v = self.string(key, default)
        if v is default and default is not _MISSING:
            return v
        if v not in options:
            self.fail(key, f"unknown {what or key} {v!r}; known: {', '.join(options)}{hint}")
        return v

    def choices(self, key: str, options: Sequence[str], default: list[str], *, what: str = "value") -> list[str]:
        """A list of values, each one of ``options``."""
        values = self.strings(key, default)
        for v in values:
            if v not in options:
                self.fail(key, f"unknown {what} {v!r}; known: {', '.join(options)}")
        return values

    def strings(self, key: str, default: list[str]) -> list[str]:
        v = self.raw(key, default)
        if not isinstance(v, list) or not all(isinstance(s, str) for s in v):
            self.fail(key, f"expected a list of strings, got {v!r}")
        return list(v)

    def pair(self, key: str, default: Any = _MISSING) -> tuple[float, float]:
        v = self.raw(key, default)
        if not (isinstance(v, (list, tuple)) and len(v) == 2 and all(is_number(c) for c in v)):
            self.fail(key, f"expected [x, y], got {v!r}")
        return float(v[0]), float(v[1])

    def triple(self, key: str, default: Any = _MISSING) -> tuple[float, float, float]:
        v = self.raw(key, default)
        if not (isinstance(v, (list, tuple)) and len(v) == 3 and all(is_number(c) for c in v)):
            self.fail(key, f"expected [x, y, theta], got {v!r}")
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
        ok = isinstance(v, list) and all(
            isinstance(p, (list, tuple)) and len(p) == 2 and all(is_number(c) for c in p) for p in v
        )
        if not ok:
            self.fail(key, f"expected a list of [x, y] points, got {v!r}")
        return [(float(p[0]), float(p[1])) for p in v]

    def pose(self, key: str, default: Any = _MISSING) -> Any:
        """A point ``[x, y]``, or ``[x, y, theta]`` where the heading matters."""
        v = self.raw(key, default)
        if v is default and default is not _MISSING:
            return v
        if not (isinstance(v, (list, tuple)) and len(v) in (2, 3) and all(is_number(c) for c in v)):
            self.fail(key, f"expected [x, y] or [x, y, theta], got {v!r}")
        return float(v[0]), float(v[1]), float(v[2]) if len(v) == 3 else None

    def place(self, key: str, default: Any = _MISSING) -> Any:
        """A place: a point as :meth:`pose` reads it, or the id of a roadmap node (a string, returned as is)."""
        v = self.raw(key, default)
        if v is default and default is not _MISSING:
            return v
        if isinstance(v, str):
            if not v:
                self.fail(key, "expected [x, y] or [x, y, theta], or a roadmap node's id, got ''")
            return v
        if not (isinstance(v, (list, tuple)) and len(v) in (2, 3) and all(is_number(c) for c in v)):
            self.fail(key, f"expected [x, y] or [x, y, theta], or a roadmap node's id, got {v!r}")
        return float(v[0]), float(v[1]), float(v[2]) if len(v) == 3 else None

    def weights(self, key: str) -> list[tuple[str, float]]:
        """Names with positive weights: a list of names (equal weights) or a table ``{name = weight}``."""
        v = self.raw(key)
        if isinstance(v, list) and all(isinstance(x, str) for x in v):
            pairs = [(x, 1.0) for x in v]
        elif isinstance(v, dict):
            for name, w in v.items():
                if not is_number(w) or w <= 0:
                    self.fail(key, f"weight of {name!r} must be a positive number, got {w!r}")
            pairs = [(name, float(w)) for name, w in v.items()]
        else:
            self.fail(key, f"expected a list of station ids or a table {{station = weight}}, got {v!r}")
        if not pairs:
            self.fail(key, "names no station")
        return pairs

    def poses(self, key: str, default: list[Any]) -> list[tuple[float, float, float | None]]:
        """A path: points ``[x, y]``, or ``[x, y, theta]`` where the heading matters."""
        v = self.raw(key, default)
        if not isinstance(v, list):
            self.fail(key, f"expected a list of [x, y] or [x, y, theta] points, got {v!r}")
        for i, p in enumerate(v):
            if not (isinstance(p, (list, tuple)) and len(p) in (2, 3) and all(is_number(c) for c in p)):
                self.fail(f"{key}[{i}]", f"expected [x, y] or [x, y, theta], got {p!r}")
        return [(float(p[0]), float(p[1]), float(p[2]) if len(p) == 3 else None) for p in v]
