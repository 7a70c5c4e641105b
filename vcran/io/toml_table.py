"""A strict, typed reader of one TOML table: what makes scenario files fail early and precisely.

Every read names the file, the entry and the field when it fails (:class:`ScenarioError`); ``done()``
refuses keys nobody read (typos). Kept apart from :mod:`vcran.io.scenario_file` so that the scenario module is
about scenarios, not about reading TOML.
"""

from __future__ import annotations

import math
import tomllib
from pathlib import Path
from typing import Any, NoReturn

from vcran.core.orion_rules import FORBIDDEN_CHARS


class ScenarioError(ValueError):
    """A scenario that cannot run; the message names the file, the entry and the field."""


def is_number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def read_toml(path: Path) -> tuple[str, dict[str, Any]]:
    """The text of the TOML file at ``path`` and its table; a missing or broken file is a ScenarioError
    naming it (scenario and sweep files alike)."""
    try:
        text = path.read_text(encoding="utf-8")
        return text, tomllib.loads(text)
    except FileNotFoundError:
        raise ScenarioError(f"{path}: no such file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ScenarioError(f"{path}: cannot read it: {exc}") from None
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{path}: not valid TOML: {exc}") from None


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

    def done(self) -> None:
        unknown = sorted(set(self.data) - self.used)
        if unknown:
            self.fail(unknown[0], "unknown key (a typo?)")

    def table(self, key: str) -> Table:
        return Table(self.raw(key, {}), self.source, self._sub(key))

    def tables(self, key: str) -> list[Table]:
        value = self.raw(key, [])
        if not isinstance(value, list):
            self.fail(key, f"expected an array of tables [[{key}]]")
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

    def strings(self, key: str, default: list[str]) -> list[str]:
        v = self.raw(key, default)
        if not isinstance(v, list) or not all(isinstance(s, str) for s in v):
            self.fail(key, f"expected a list of strings, got {v!r}")
        return list(v)

    def list_of(self, key: str, item: Any) -> list[Any]:
        v = self.raw(key, [])
        if not isinstance(v, list):
            self.fail(key, f"expected a list, got {v!r}")
        return [item(i, x) for i, x in enumerate(v)]

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
