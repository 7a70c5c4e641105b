"""Each robot's state, current task, last error and battery level over time, from its events.

The events say when a task was first seen (``task_queued``), when it completed or was cancelled, and
every RanLogic state transition, but not which task a transition to TASK started. R1 settles it, as in
the report (docs/report.md): the queue runs in first-seen order, so a task becomes current at the first
transition to TASK while it heads the tasks still pending, and stops being current when it ends.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from vcran.core.opil.effects import State
from vcran.view.model import Steps, Tasks

#: What a task's life ended with: completed, a cancel reason, or still open when the run ended.
OPEN = "open"
STATE_NAMES = [s.value for s in State]


def task_timelines(robots: list[str], events: list[dict[str, Any]], end: float) -> tuple[Steps, list[str], Tasks, Steps]:
    """States (indices into the returned names), every task's life, and each robot's current task."""
    index = {rid: i for i, rid in enumerate(robots)}
    names = list(STATE_NAMES)
    states: list[list[tuple[float, int]]] = [[] for _ in robots]
    current: list[list[tuple[float, int]]] = [[] for _ in robots]
    pending: list[dict[str, int]] = [{} for _ in robots]  # open tasks by label, first-seen order (R1)
    task_state = State.TASK.value
    labels: dict[str, int] = {}
    outcomes = ["completed", OPEN]
    rows: list[list[Any]] = []  # robot, label, queued, started, end, outcome
    for e in events:
        i = index.get(e["robot"])
        if i is None:
            continue
        t, kind = float(e["t"]), e["event"]
        if kind == "state" and isinstance(e.get("to"), str):
            if e["to"] not in names:
                names.append(e["to"])
            states[i].append((t, names.index(e["to"])))
            if e["to"] == task_state and pending[i]:
                head = next(iter(pending[i].values()))
                if math.isnan(rows[head][3]):
                    rows[head][3] = t
                    current[i].append((t, head))
        elif kind == "task_queued" and isinstance(e.get("task"), str):
            k = labels.setdefault(e["task"], len(labels))
            pending[i][e["task"]] = len(rows)
            rows.append([i, k, t, math.nan, end, 1])
        elif kind in ("task_completed", "task_cancelled") and isinstance(e.get("task"), str):
            k = pending[i].pop(e["task"], -1)
            if k < 0:
                continue
            outcome = "completed" if kind == "task_completed" else str(e.get("reason", "cancelled"))
            if outcome not in outcomes:
                outcomes.append(outcome)
            rows[k][4], rows[k][5] = t, outcomes.index(outcome)
            if not math.isnan(rows[k][3]):
                current[i].append((t, -1))
    columns = list(zip(*rows)) if rows else [()] * 6
    tasks = Tasks(np.array(columns[0], dtype=np.int32), np.array(columns[1], dtype=np.int32),
                  np.array(columns[2], dtype=np.float64), np.array(columns[3], dtype=np.float64),
                  np.array(columns[4], dtype=np.float64), np.array(columns[5], dtype=np.uint8),
                  list(labels), outcomes)
    return Steps.build(states, "uint8"), names, tasks, Steps.build(current, "int32")


def error_timelines(robots: list[str], events: list[dict[str, Any]]) -> tuple[Steps, list[str]]:
    """Each robot's last error (a rejected input or a failure, docs/rules.md) from when it happened."""
    index = {rid: i for i, rid in enumerate(robots)}
    texts: dict[str, int] = {}
    steps: list[list[tuple[float, int]]] = [[] for _ in robots]
    for e in events:
        i = index.get(e["robot"])
        if i is None or e["event"] not in ("rejected", "failed"):
            continue
        text = f"{e.get('code', e['event'])}: {e.get('message', '')}".rstrip(": ")
        steps[i].append((float(e["t"]), texts.setdefault(text, len(texts))))
    return Steps.build(steps, "int32"), list(texts)


def battery_timelines(robots: list[str], batteries: dict[str, list[tuple[float, float]]]) -> Steps:
    """Each robot's published battery percentage (docs/contract.md §4); robots without a battery have no steps."""
    return Steps.build([batteries.get(rid, []) for rid in robots], "float32")
