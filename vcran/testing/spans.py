"""Spans of a run's events (docs/contract.md §4, §9): when robots were idle, away or out of service, for the loop
properties of :mod:`vcran.testing.loop` and :mod:`vcran.testing.deadlocks`. Plain Python on the events of a
run (``result.events``), each span ``(from, to)`` in simulated seconds; one still open at ``end`` lasts
until then."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

#: Fault kinds during which a robot is out of the fleet manager's reach (from ``fault`` to ``fault_end``).
UNAVAILABLE_FAULTS = frozenset({"link_down", "breakdown"})


def fault_spans(events: list[dict[str, Any]], end: float, kinds: frozenset[str]) -> dict[str, list[tuple[float, float]]]:
    """Per robot, the spans of its faults of ``kinds`` that applied (one still on at ``end`` lasts until then)."""
    since: dict[tuple[str, str], float] = {}
    spans: dict[str, list[tuple[float, float]]] = {}
    for e in events:
        if e["event"] not in ("fault", "fault_end") or e.get("kind") not in kinds:
            continue
        key = (e["robot"], e["kind"])
        if e["event"] == "fault" and e.get("applied", True):
            since.setdefault(key, e["t"])
        elif e["event"] == "fault_end" and key in since:
            spans.setdefault(key[0], []).append((since.pop(key), e["t"]))
    for (robot, _kind), start in since.items():
        spans.setdefault(robot, []).append((start, end))
    return spans


def away_spans(events: list[dict[str, Any]], end: float) -> dict[str, list[tuple[float, float]]]:
    """Per robot, the spans the manager could not use it: its link down or broken down
    (:data:`UNAVAILABLE_FAULTS`), or its battery empty until swapped."""
    away = fault_spans(events, end, UNAVAILABLE_FAULTS)
    for robot, spans in empty_spans(events, end).items():
        away.setdefault(robot, []).extend(spans)
    return away


def empty_spans(events: list[dict[str, Any]], end: float) -> dict[str, list[tuple[float, float]]]:
    """Per robot, the spans its battery was empty: from ``battery_empty`` to ``battery_swapped`` (or ``end``)."""
    since: dict[str, float] = {}
    spans: dict[str, list[tuple[float, float]]] = {}
    for e in events:
        if e["event"] == "battery_empty":
            since.setdefault(e["robot"], e["t"])
        elif e["event"] == "battery_swapped" and e["robot"] in since:
            spans.setdefault(e["robot"], []).append((since.pop(e["robot"]), e["t"]))
    for robot, start in since.items():
        spans.setdefault(robot, []).append((start, end))
    return spans


def assignees(events: list[dict[str, Any]]) -> dict[str, list[tuple[float, str]]]:
    """Per job, its robots in assignment order, with the instant each was given it."""
    out: dict[str, list[tuple[float, str]]] = {}
    for e in events:
        if e["event"] == "job_assigned":
            out.setdefault(e["job"], []).append((e["t"], e["robot"]))
    return out


def robot_at(assigned: list[tuple[float, str]], t: float) -> str:
    """The robot a job was last given at or before ``t`` ("" before its first assignment)."""
    robot = ""
    for since, who in assigned:
        if since > t:
            break
        robot = who
    return robot


def minus(spans: list[tuple[float, float]], cuts: list[tuple[float, float]]) -> list[tuple[float, float]]:
    """``spans`` with every instant inside one of ``cuts`` taken out (a span may split in two)."""
    for c, d in cuts:
        kept = []
        for a, b in spans:
            if a < c:
                kept.append((a, min(b, c)))
            if b > d:
                kept.append((max(a, d), b))
        spans = kept
    return spans


def idle_spans(events: list[dict[str, Any]], robots: Sequence[str], end: float) -> dict[str, list[tuple[float, float]]]:
    """Per robot, the spans it was WAITING (robots start WAITING at t = 0); a VDA 5050 vehicle, the spans it
    had no order to execute: from the start, and from each order's end, to the next new order it accepted
    (an update of the order under way changes nothing)."""
    since: dict[str, float | None] = dict.fromkeys(robots, 0.0)
    spans: dict[str, list[tuple[float, float]]] = {r: [] for r in robots}
    for e in events:
        kind = e["event"]
        if kind == "state":
            idle, busy = e["to"] == "WAITING", e["from"] == "WAITING"
        elif kind == "order_ended":
            idle, busy = True, False
        elif kind == "order_accepted" and not e.get("update"):
            idle, busy = False, True
        else:
            continue
        robot = e["robot"]
        if idle:
            since[robot] = e["t"]
        elif busy:
            start = since.get(robot)
            if start is not None:
                spans[robot].append((start, e["t"]))
            since[robot] = None
    for robot, start in since.items():
        if start is not None:
            spans[robot].append((start, end))
    return spans
