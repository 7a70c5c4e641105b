"""Readable labels for swept values that are lists or tables (issue 29 item 11; docs/sweeps.md, "Runs").

A parameter's values label the runs table's cells and the figures' axes. A number or a string is itself;
a list or table as JSON was unreadable once it held tables (a ``robots`` array: ``[{"id": "robot_1",
"pose": ...``). So:

* a list of plain values (a pose) is its JSON, with spaces: ``[1.0, 0.0, 0.0]``;
* a list of tables is counted and named by the path's last key, with their ids when each has one:
  ``3 robots: robot_1, robot_2, robot_3`` (more than four ids: the first two, ``…``, the last);
* a table is written as TOML writes an inline table: ``{max_tries = 2, retry_after = 5.0}``.

Two different values of one parameter never share a label: where they would (two ``robots`` arrays
with the same ids), each is followed by ``#1``, ``#2``, ... in the order the runs meet them.
"""

from __future__ import annotations

import json
from collections.abc import Iterable
from typing import Any


class Labels:
    """The labels of one parameter's values, distinct for distinct values; call it with a value."""

    def __init__(self, path: str, values: Iterable[Any]) -> None:
        self.path = path
        by_label: dict[str, list[str]] = {}
        for value in values:
            keys = by_label.setdefault(label(path, value), [])
            if _key(value) not in keys:
                keys.append(_key(value))
        self._labels = {key: text if len(keys) == 1 else f"{text} #{n}"
                        for text, keys in by_label.items() for n, key in enumerate(keys, 1)}

    def __call__(self, value: Any) -> str:
        return self._labels[_key(value)]


def label(path: str, value: Any) -> str:
    """``value``, a value of the swept ``path``, as the module's docstring writes it."""
    if isinstance(value, str):
        return value
    if isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
        noun = path.rsplit(".", 1)[-1]
        ids = [str(v["id"]) for v in value if "id" in v]
        if len(ids) < len(value):
            return f"{len(value)} {noun}"
        shown = ids if len(ids) <= 4 else [*ids[:2], "…", ids[-1]]
        return f"{len(value)} {noun}: {', '.join(shown)}"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k} = {_plain(v)}" for k, v in value.items()) + "}"
    return _plain(value)


def _plain(value: Any) -> str:
    if isinstance(value, str):
        return json.dumps(value, ensure_ascii=False)
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return repr(value)
    return json.dumps(value, ensure_ascii=False, separators=(", ", ": "))


def _key(value: Any) -> str:
    """Equal values, equal keys (an int and the equal float too, as TOML would have them apart)."""
    return json.dumps(value, sort_keys=True, ensure_ascii=False) + type(value).__name__
