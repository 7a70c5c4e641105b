"""The base of every event a run logs in ``events.jsonl``, whatever the protocol.

A protocol's logic (OPIL's :mod:`vcran.core.opil.effects`, VDA 5050's vehicle) and the robot's own incidents
(:mod:`vcran.core.incidents`) subclass it; the event log writes ``NAME`` and ``fields()``.
"""

from __future__ import annotations

from typing import Any


class Event:
    """Something to log. ``fields()`` is the event-specific part of its ``events.jsonl`` line.

    The events of every task name their ids as ``ident.description or ident.label``: the label (docs/contract.md §8) is
    the description when there is one, and ``label`` is a property, a Python call per id that nine events a
    task paid for nothing (issue 30)."""

    __slots__ = ()
    NAME = ""

    def fields(self) -> dict[str, Any]:
        raise NotImplementedError
