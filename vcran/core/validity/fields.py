"""What one field of a scenario may hold (its rule), and how a scenario's problem is told (issue 30 item 3).

A :class:`Problem` is where and what: ``Problem("robots[2].battery.capacity", "must be positive, got 0")`` is
told ``robots[2].battery: field 'capacity': must be positive, got 0``. The path names the entry and the field
as a scenario file spells them, so a file's reader only puts the file's name in front, and a scenario built
in code is told in the same words. A path ending in ``]`` names a whole entry (``roadmap.edges[2]``); the
empty path, the scenario as a whole (the message then says which sections, ``[simulation]: ...``).

A rule (:class:`Number`, :class:`Text`, ...) is one field's kind and bounds; :meth:`check` returns the problem
with a value, or None. The model's rules are declared once, beside the parts they check
(:mod:`vcran.core.validity.fleet`, :mod:`vcran.core.validity.workload`), and applied twice: by
:func:`vcran.core.validity.validate` to the model's values, and by the scenario file's reader to each value
as the file writes it (so ``task_timeout = -1`` is told "got -1", as written, and ``vcran schema scenario``
records the bound). ``absent`` is the model's value for a field left out (None for "no deadline", inf for
"no end"): the model may hold it, a file says it by leaving the key out.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, NamedTuple, Protocol

from vcran.core.orion_rules import FORBIDDEN_CHARS

#: TOML's integers are 64-bit signed (toml.io, "Integer"); tomllib reads longer ones, which numpy, orjson
#: (the trace header, the events) and Parquet (a sweep's seed column) cannot hold.
INT64 = range(-(2**63), 2**63)
#: ``absent`` of a field the model always holds a value for.
REQUIRED: Any = type("Required", (), {"__repr__": lambda self: "REQUIRED"})()

#: A check added to a rule: the problem with a value that has the rule's kind and bounds, or None.
Then = Callable[[Any], "str | None"]


class Problem(NamedTuple):
    """One broken rule: where (``robots[2].battery.capacity``), and what."""

    path: str
    message: str

    def __str__(self) -> str:
        if not self.path or self.path.endswith("]"):
            return describe(self.path, None, self.message)
        where, _, key = self.path.rpartition(".")
        return describe(where, key, self.message)


def describe(where: str, key: str | None, message: str) -> str:
    """The one-line form of a problem: ``where: field 'key': message`` (``where`` or ``key`` left out if none)."""
    if key is not None:
        message = f"field {key!r}: {message}"
    return f"{where}: {message}" if where else message


class Rule(Protocol):
    @property
    def absent(self) -> Any: ...

    def check(self, value: Any) -> str | None: ...


def fields(part: Any, where: str, rules: Mapping[str, Rule], attrs: Mapping[str, str] | None = None,
           skip: Iterable[str] = ()) -> list[Problem]:
    """The problems of ``part``'s fields under ``rules`` (keyed as a file names them; ``attrs`` maps a key to
    the model's attribute where the two differ), leaving out the keys in ``skip``."""
    out = []
    for key, rule in rules.items():
        if key in skip:
            continue
        value = getattr(part, attrs.get(key, key) if attrs else key)
        if rule.absent is not REQUIRED and (value is rule.absent or value == rule.absent):
            continue
        problem = rule.check(value)
        if problem:
            out.append(Problem(f"{where}.{key}" if where else key, problem))
    return out


def shown(value: Any) -> Any:
    """``value`` as a file would write it, for a message: the model's tuples as lists."""
    if isinstance(value, (tuple, list)):
        return [shown(v) for v in value]
    return value


def is_number(v: Any) -> bool:
    """A finite number, not a bool. (Plain floats and ints first: the reader asks this of every coordinate.)"""
    kind = type(v)
    if kind is float:
        return math.isfinite(v)
    return kind is int or isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


# --- one value on its own: what a file's reader checks as it reads -----------------------------------------


def number_problem(v: Any, minimum: float | None = None, positive: bool = False) -> str | None:
    if not is_number(v):
        return f"expected a finite number, got {shown(v)!r}"
    if positive and v <= 0:
        return f"must be positive, got {v}"
    if minimum is not None and v < minimum:
        return f"must be at least {minimum}, got {v}"
    return None


def integer_problem(v: Any, minimum: int | None = None) -> str | None:
    if isinstance(v, bool) or not isinstance(v, int):
        return f"expected an integer, got {shown(v)!r}"
    if v not in INT64:
        return f"{v} is outside TOML's 64-bit integer range"
    if minimum is not None and v < minimum:
        return f"must be at least {minimum}, got {v}"
    return None


def flag_problem(v: Any) -> str | None:
    return None if isinstance(v, bool) else f"expected true or false, got {shown(v)!r}"


def string_problem(v: Any) -> str | None:
    return None if isinstance(v, str) and v else f"expected a non-empty string, got {shown(v)!r}"


def publishable_problem(v: str) -> str | None:
    """A string that will be published: Orion refuses some characters in values (docs/contract.md §2)."""
    bad = sorted(set(v) & FORBIDDEN_CHARS)
    return f"contains {' '.join(bad)}, which Orion refuses in values" if bad else None


def name_problem(v: Any) -> str | None:
    """An id name (task, job, prefix); a file may write it as an integer, read as its decimal string."""
    if not isinstance(v, str) or not v:
        return f"expected a non-empty string or an integer, got {shown(v)!r}"
    return publishable_problem(v)


def strings_problem(v: Any) -> str | None:
    if not isinstance(v, (list, tuple)) or not all(isinstance(s, str) for s in v):
        return f"expected a list of strings, got {shown(v)!r}"
    return None


def text_problem(v: Any) -> str | None:
    """A non-empty string Orion takes as a value."""
    return string_problem(v) or publishable_problem(v)


def one_of_problem(v: str, options: Sequence[str], what: str, hint: str = "") -> str | None:
    return None if v in options else f"unknown {what} {v!r}; known: {', '.join(options)}{hint}"


def choices_problem(v: Any, options: Sequence[str], what: str) -> str | None:
    """A list of values, each one of ``options``."""
    return strings_problem(v) or next((p for x in v if (p := one_of_problem(x, options, what))), None)


def _coordinates(v: Any, sizes: tuple[int, ...], heading: bool = False) -> bool:
    """``v`` is ``[x, y]`` or ``[x, y, theta]`` (as ``sizes`` allow) of finite numbers; with ``heading`` a
    theta of None (the model's "any heading") too."""
    if not isinstance(v, (list, tuple)) or len(v) not in sizes:
        return False
    return all(map(is_number, v)) or (heading and len(v) == 3 and v[2] is None and is_number(v[0]) and is_number(v[1]))


def pair_problem(v: Any) -> str | None:
    return None if _coordinates(v, (2,)) else f"expected [x, y], got {shown(v)!r}"


def triple_problem(v: Any) -> str | None:
    return None if _coordinates(v, (3,)) else f"expected [x, y, theta], got {shown(v)!r}"


def points_problem(v: Any) -> str | None:
    if not isinstance(v, (list, tuple)) or not all(_coordinates(p, (2,)) for p in v):
        return f"expected a list of [x, y] points, got {shown(v)!r}"
    return None


def pose_problem(v: Any) -> str | None:
    return None if _coordinates(v, (2, 3), heading=True) else f"expected [x, y] or [x, y, theta], got {shown(v)!r}"


def place_problem(v: Any) -> str | None:
    if isinstance(v, str) and v or _coordinates(v, (2, 3), heading=True):
        return None
    return f"expected [x, y] or [x, y, theta], or a roadmap node's id, got {shown(v)!r}"


def weights_problem(pairs: Any) -> str | None:
    """Names with positive weights, as ``(name, weight)`` pairs (a file's list of names weighs each 1)."""
    if not isinstance(pairs, (list, tuple)) or not all(isinstance(p, tuple) and len(p) == 2 and isinstance(p[0], str)
                                                       for p in pairs):
        return f"expected (station, weight) pairs, got {shown(pairs)!r}"
    for name, w in pairs:
        if not is_number(w) or w <= 0:
            return f"weight of {name!r} must be a positive number, got {w!r}"
    return None if pairs else "names no station"


# --- the rules: a kind, its bounds, and what more a field asks -------------------------------------------


@dataclass(frozen=True, slots=True)
class Number:
    minimum: float | None = None
    positive: bool = False
    absent: Any = REQUIRED
    then: Then | None = None

    def check(self, v: Any) -> str | None:
        return number_problem(v, self.minimum, self.positive) or (self.then(v) if self.then else None)


@dataclass(frozen=True, slots=True)
class Integer:
    minimum: int | None = None
    absent: Any = REQUIRED

    def check(self, v: Any) -> str | None:
        return integer_problem(v, self.minimum)


@dataclass(frozen=True, slots=True)
class Flag:
    absent: Any = REQUIRED

    def check(self, v: Any) -> str | None:
        return flag_problem(v)


@dataclass(frozen=True, slots=True)
class Text:
    """A non-empty string; ``publishable``: one Orion takes as a value."""

    publishable: bool = False
    absent: Any = REQUIRED
    then: Then | None = None

    def check(self, v: Any) -> str | None:
        problem = text_problem(v) if self.publishable else string_problem(v)
        return problem or (self.then(v) if self.then else None)


@dataclass(frozen=True, slots=True)
class Name:
    """An id name a file may write as an integer (``task = 100``); the model holds its decimal string."""

    absent: Any = REQUIRED

    def check(self, v: Any) -> str | None:
        return name_problem(v)


@dataclass(frozen=True, slots=True)
class OneOf:
    """One of ``options``; the message names the value as ``what``, lists the options, then ``hint``."""

    options: tuple[str, ...]
    what: str
    hint: str = ""
    absent: Any = REQUIRED

    def check(self, v: Any) -> str | None:
        return string_problem(v) or one_of_problem(v, self.options, self.what, self.hint)


@dataclass(frozen=True, slots=True)
class Choices:
    """A list of values, each one of ``options``; ``hints`` explain values that are mistaken for options."""

    options: tuple[str, ...]
    what: str = "value"
    hints: Mapping[str, str] = field(default_factory=dict)
    absent: Any = REQUIRED

    def check(self, v: Any) -> str | None:
        problem = strings_problem(v)
        if problem:
            return problem
        return next((self.hints[x] for x in v if x in self.hints), None) or choices_problem(v, self.options, self.what)


@dataclass(frozen=True, slots=True)
class Strings:
    absent: Any = REQUIRED

    def check(self, v: Any) -> str | None:
        return strings_problem(v)


@dataclass(frozen=True, slots=True)
class Shape:
    """A point, a pose, a place or a list of points (``problem`` says which), then ``then``."""

    problem: Callable[[Any], str | None]
    absent: Any = REQUIRED
    then: Then | None = None

    def check(self, v: Any) -> str | None:
        return self.problem(v) or (self.then(v) if self.then else None)


@dataclass(frozen=True, slots=True)
class Weights:
    absent: Any = REQUIRED

    def check(self, v: Any) -> str | None:
        return weights_problem(v)
