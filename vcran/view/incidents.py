"""The incidents the page puts on its timeline, each a click away (docs/contract.md §13).

:data:`KINDS` is the one list: an event name, the incident kind it shows as, and how that kind is drawn.
Traffic (docs/contract.md §12, issue 32) adds its blocks and deadlocks here as rows of their own; an event not listed
is not an incident.
"""

from __future__ import annotations

from typing import Any

from vcran.view.model import Incident

#: kind -> (label, colour) in the order of the timeline's rows
KINDS: dict[str, tuple[str, str]] = {
    "collision": ("collisions", "#d62728"),
    "fault": ("faults", "#ff7f0e"),
    "failure": ("failures", "#8c564b"),
    "rejection": ("rejections", "#9467bd"),
    "battery": ("battery", "#bcbd22"),
    "cancel": ("cancelled tasks", "#7f7f7f"),
    "job_failed": ("failed jobs", "#e377c2"),
    "block": ("blocks", "#17becf"),
    "deadlock": ("deadlocks", "#1f1f1f"),
}

#: event name -> incident kind
EVENTS: dict[str, str] = {
    "collision": "collision",
    "fault": "fault",
    "fault_end": "fault",
    "failed": "failure",
    "rejected": "rejection",
    "battery_low": "battery",
    "battery_empty": "battery",
    "battery_swapped": "battery",
    "task_cancelled": "cancel",
    "job_failed": "job_failed",
    "blocked": "block",
    "deadlock": "deadlock",
}


def incidents_of(robots: list[str], events: list[dict[str, Any]]) -> list[Incident]:
    index = {rid: i for i, rid in enumerate(robots)}
    out = []
    for e in events:
        kind = EVENTS.get(e["event"])
        if kind is None or (e["event"] == "fault" and e.get("applied") is False):
            continue
        out.append(Incident(float(e["t"]), kind, index.get(e["robot"], -1), describe(e)))
    return out


def describe(e: dict[str, Any]) -> str:
    """One line for the incident list: who, what, and the details the event has."""
    name = e["event"]
    who = e["robot"] or "fleet"
    at = f" at ({e['x']:.2f}, {e['y']:.2f})" if isinstance(e.get("x"), int | float) and isinstance(e.get("y"), int | float) else ""
    if name == "collision":
        return f"{who} collided with {e.get('other', '?')}{at}"
    if name in ("fault", "fault_end"):
        lasting = f" for {e['duration']:g} s" if isinstance(e.get("duration"), int | float) else ""
        return f"{who}: {e.get('kind', 'fault')}{' ends' if name == 'fault_end' else lasting}"
    if name in ("failed", "rejected"):
        return f"{who} {name}: {e.get('code', '')}: {e.get('message', '')}".rstrip(": ")
    if name == "task_cancelled":
        return f"{who}: task {e.get('task', '?')} cancelled ({e.get('reason', '?')})"
    if name == "blocked":
        return f"{who} blocked by {e.get('other', '?')}{at}"
    if name == "deadlock":
        return f"{who}: deadlock with {e.get('other', '?')} ({e.get('kind', '?')})"
    if name == "job_failed":
        return f"job {e.get('job', '?')} failed ({e.get('reason', '?')})"
    pct = f" ({e['percentage']:.0f}%)" if isinstance(e.get("percentage"), int | float) else ""
    return f"{who}: {name.replace('_', ' ')}{pct}{at}"
