"""docs/contract.md §4 in a report: downtime per robot, and the incidents to mark on the timeline and the layout.

Downtime is time a robot could not work: held by a breakdown (``fault`` to its end) or a pause (to its
``resume``), and out of service with an empty battery (``battery_empty`` to ``battery_swapped``); an
interval still open when the run ends counts to the end, and overlapping intervals count once.
"""

from __future__ import annotations

from dataclasses import dataclass

from vcran.report.folder import Run
from vcran.report.style import INCIDENT_STYLE


@dataclass(frozen=True, slots=True)
class Incident:
    """A docs/contract.md §4 event to mark: ``kind`` (a key of INCIDENT_STYLE) at ``t``, at ``place`` when the event has one."""

    robot: str
    t: float
    kind: str
    place: tuple[float, float] | None = None


def incidents(run: Run) -> list[Incident]:
    out = []
    for e in run.events:
        kind = e["event"]
        if kind not in INCIDENT_STYLE or (kind == "fault" and e.get("applied") is False):
            continue
        place = (float(e["x"]), float(e["y"])) if "x" in e and "y" in e else None
        out.append(Incident(e["robot"], float(e["t"]), kind, place))
    return out


def downtime(run: Run) -> dict[str, float]:
    """Seconds each robot was held or out of service (module docstring)."""
    intervals: dict[str, list[tuple[float, float]]] = {rid: [] for rid in run.robot_ids}
    paused: dict[str, float] = {}
    empty: dict[str, float] = {}
    for e in run.events:
        rid, t, kind = e["robot"], float(e["t"]), e["event"]
        if rid not in intervals:
            continue
        if kind == "fault" and e.get("applied", True):
            if e.get("kind") == "breakdown":
                intervals[rid].append((t, t + float(e.get("duration", 0.0))))
            elif e.get("kind") == "pause":
                paused[rid] = t
            elif e.get("kind") == "resume" and rid in paused:
                intervals[rid].append((paused.pop(rid), t))
        elif kind == "battery_empty":
            empty[rid] = t
        elif kind == "battery_swapped" and rid in empty:
            intervals[rid].append((empty.pop(rid), t))
    for open_ in (paused, empty):
        for rid, t in open_.items():
            intervals[rid].append((t, run.sim_time))
    return {rid: _union(spans, run.sim_time) for rid, spans in intervals.items()}


def _union(spans: list[tuple[float, float]], end: float) -> float:
    total, reach = 0.0, float("-inf")
    for a, b in sorted((a, min(b, end)) for a, b in spans):
        if b <= reach:
            continue
        total += b - max(a, reach)
        reach = b
    return total
