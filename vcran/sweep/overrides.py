"""Overrides: set a value at a dotted path inside a scenario's TOML table (docs/contract.md §10, docs/sweeps.md).

A sweep varies a scenario by paths into the data a scenario file holds, not by knowing what any field
means: ``simulation.task_timeout``, ``robots.*.max_velocity``, ``job_stream.rate``, ``manager.class``.
Whatever the scenario format grows, a sweep can vary it the day it lands, and whether the result makes
sense is decided by loading the overridden scenario with the scenario loader's own strict checks.

A path is keys joined by dots. Where it meets an array of tables (``robots``, ``stations``), the next
segment picks elements: ``*`` every one, an integer the one at that index (from 0), anything else the one
whose ``id`` it is. A missing table on the way is created (``job_stream.rate`` on a scenario without a
``[job_stream]``); the loader then says whether that table is complete. One path is no place in the
table: ``robots.count``, the number of robots (:mod:`vcran.sweep.fleet`).
"""

from __future__ import annotations

import copy
import functools
from collections.abc import Iterable
from typing import Any, NoReturn

from vcran.sweep import fleet

#: Short names a sweep may use for a longer path: the fleet-manager versions of docs/contract.md §10 (``manager =
#: ["vcran.managers:Dispatcher", "mypkg:Mine"]``) are the ``class`` of a scenario's ``[manager]``.
ALIASES = {"manager": "manager.class"}


class OverrideError(ValueError):
    """A path that does not lead into the scenario; the message says where it stopped and why."""


def canonical(path: str) -> str:
    """``path`` with an alias replaced by what it stands for."""
    return ALIASES.get(path, path)


def apply(data: dict[str, Any], overrides: Iterable[tuple[str, Any]]) -> dict[str, Any]:
    """A deep copy of the scenario table ``data`` with every (path, value) set, in order, but the fleet's
    size (``robots.count``, :mod:`vcran.sweep.fleet`) first, so that the other paths reach its robots."""
    out = copy.deepcopy(data)
    overrides = list(overrides)
    for path, value in overrides:
        if canonical(path) == fleet.PATH:
            fleet.set_count(out, value, functools.partial(_fail, path))
    for path, value in overrides:
        if canonical(path) == fleet.PATH:
            continue
        segments = canonical(path).split(".")
        if not all(segments):
            raise OverrideError(f"{path!r}: an empty key (two dots, or a dot at an end)")
        _set(out, segments, copy.deepcopy(value), path, [])
    return out


def _set(node: Any, segments: list[str], value: Any, path: str, seen: list[str]) -> None:
    key, rest = segments[0], segments[1:]
    where = ".".join(seen) or "the scenario"
    if isinstance(node, list):
        if not rest:
            _fail(path, f"{where}.{key} is an element of an array of tables; name a field inside it")
        for element in _select(node, key, path, where):
            _set(element, rest, value, path, [*seen, key])
        return
    if not isinstance(node, dict):
        _fail(path, f"{where} is a value ({node!r}), not a table")
    if not rest:
        node[key] = value
        return
    if key not in node:
        node[key] = {}
    child = node[key]
    if isinstance(child, list) and not all(isinstance(x, dict) for x in child):
        _fail(path, f"{'.'.join([*seen, key])} is a list of values; a path can only end there")
    _set(child, rest, value, path, [*seen, key])


def _select(items: list[Any], key: str, path: str, where: str) -> list[dict[str, Any]]:
    if key == "*":
        if not items:
            _fail(path, f"{where} is empty: '*' selects nothing")
        return items
    if key.isdigit():
        index = int(key)
        if index >= len(items):
            _fail(path, f"{where} has {len(items)} entries; index {index} is past its end (indices start at 0)")
        return [items[index]]
    matches = [x for x in items if isinstance(x, dict) and x.get("id") == key]
    if not matches:
        ids = [str(x.get("id")) for x in items if isinstance(x, dict) and "id" in x]
        known = f"; ids: {', '.join(ids[:10])}{', ...' if len(ids) > 10 else ''}" if ids else ""
        _fail(path, f"{where} has no entry with id {key!r} (use '*', an index or an id){known}")
    return matches


def _fail(path: str, problem: str) -> NoReturn:
    raise OverrideError(f"{path!r}: {problem}")
