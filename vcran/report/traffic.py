"""docs/contract.md §12 in a report: each robot's blocks, blocked time and deadlocks, counted from the events.

A *block* is a ``blocked`` event: another robot entered the robot's empty protective field. It lasts until
the robot's next ``unblocked`` (its field clear, or new work or a stop from outside); one still open when
the run ends counts up to the end. A robot's *deadlocks* are the ``deadlock`` events it is part of: logged
on it, or naming it among a cycle's robots (``other`` of a cycle lists them; of a ``bound`` deadlock, the
robots it waited for, which are not deadlocked themselves). The fleet's deadlocks are the ``deadlock``
events: a cycle counts once however many robots it holds.
"""

from __future__ import annotations

from dataclasses import dataclass

from vcran.report.folder import Run

BOUND = "bound"


@dataclass(frozen=True, slots=True)
class Blocking:
    blocks: int = 0
    blocked_time: float = 0.0
    deadlocks: int = 0


def blocking(run: Run) -> dict[str, Blocking]:
    """Each robot's blocks, blocked time (s) and deadlocks (module docstring), in fleet order."""
    blocks = dict.fromkeys(run.robot_ids, 0)
    time = dict.fromkeys(run.robot_ids, 0.0)
    deadlocks = dict.fromkeys(run.robot_ids, 0)
    since: dict[str, float] = {}
    for e in run.events:
        kind, rid = e["event"], e["robot"]
        if kind == "blocked" and rid in blocks:
            blocks[rid] += 1
            since.setdefault(rid, float(e["t"]))
        elif kind == "unblocked" and rid in since:
            time[rid] += float(e["t"]) - since.pop(rid)
        elif kind == "deadlock":
            part = [rid] if e.get("kind") == BOUND or not e.get("other") else [rid, *str(e["other"]).split(", ")]
            for r in part:
                if r in deadlocks:
                    deadlocks[r] += 1
    for rid, t in since.items():
        time[rid] += run.sim_time - t
    return {rid: Blocking(blocks[rid], time[rid], deadlocks[rid]) for rid in run.robot_ids}


def fleet_deadlocks(run: Run) -> int:
    return sum(e["event"] == "deadlock" for e in run.events)
