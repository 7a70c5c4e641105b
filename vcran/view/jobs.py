"""A closed loop's jobs (docs/contract.md §9) from the fleet manager's events: their tasks, robots and lead times.

``job_arrived`` opens a job, ``job_assigned`` names a task sent for it to a robot, ``job_completed`` and
``job_failed`` end it (docs/outputs.md). A task sent for a job is the first task of that label queued on
that robot at or after the assignment (the RAN may see it later than the manager sent it: the link
has a latency), so the page can show the job's robot, its tasks and the path driven while they ran.
"""

from __future__ import annotations

from bisect import bisect_left
from typing import Any

import numpy as np

from vcran.view.model import Job, Tasks


def jobs_of(robots: list[str], events: list[dict[str, Any]], tasks: Tasks) -> list[Job]:
    if not any(e["event"] == "job_arrived" for e in events):  # no fleet manager in the loop
        return []
    index = {rid: i for i, rid in enumerate(robots)}
    labels = {name: k for k, name in enumerate(tasks.labels)}
    # (robot, label) -> the tasks queued so, in time order: their queue times and indices
    queued: dict[tuple[int, int], tuple[list[float], list[int]]] = {}
    for k in np.argsort(tasks.queued, kind="stable"):
        times, ids = queued.setdefault((int(tasks.robot[k]), int(tasks.label[k])), ([], []))
        times.append(float(tasks.queued[k]))
        ids.append(int(k))
    jobs: dict[str, dict[str, Any]] = {}

    def job(name: str) -> dict[str, Any]:
        return jobs.setdefault(name, {"arrived": None, "pickup": "", "dropoff": "", "priority": None, "deadline": None,
                                      "tasks": [], "robots": [], "status": "open", "ended": None, "lead": None,
                                      "reason": ""})

    for e in events:
        kind, name = e["event"], e.get("job")
        if not kind.startswith("job_") or not isinstance(name, str):
            continue
        j = job(name)
        if kind == "job_arrived":
            j.update(arrived=float(e["t"]), pickup=str(e.get("pickup", "")), dropoff=str(e.get("dropoff", "")),
                     priority=e.get("priority"), deadline=e.get("deadline"))
        elif kind == "job_assigned":
            i = index.get(e["robot"])
            if i is not None and i not in j["robots"]:
                j["robots"].append(i)
            found = queued.get((i, labels.get(str(e.get("task")), -1))) if i is not None else None
            if found is not None:
                at = bisect_left(found[0], float(e["t"]))
                if at < len(found[1]):
                    j["tasks"].append(found[1][at])
        elif kind in ("job_completed", "job_failed"):
            j.update(status="completed" if kind == "job_completed" else "failed", ended=float(e["t"]),
                     lead=e.get("lead_time"), reason=str(e.get("reason", "")))
    return [Job(name, j["arrived"], j["pickup"], j["dropoff"], j["priority"], j["deadline"], tuple(j["tasks"]),
                tuple(j["robots"]), j["status"], j["ended"], j["lead"], j["reason"]) for name, j in jobs.items()]
