"""The loop property "no deadlock" (docs/contract.md §12, issue 32 item 4), judged from what a run records.

A fleet manager that routes robots through shared lanes can let them wait on one another for good: two
robots head-on in a one-lane aisle, a ring of robots each waiting for the node ahead. What a run shows of
it depends on what the simulation models:

* **With safety fields** (docs/contract.md §12, coming with issue 30's seam) the simulation itself reports robots
  blocked on one another in a cycle, or one blocked past the scenario's bound, as ``deadlock`` events:
  each is a violation.
* **Without fields** (today) robots never block one another physically; a manager that reserves lanes
  makes its robots *wait* instead, at rest, with work to do. So the check also reports a robot *stuck on
  a job*: one that was sent a task for a job that is still open, whose latest task for that job did not
  end cancelled (then the job waits for a robot, which :func:`~vcran.testing.loop.check_no_idle_while_waiting`
  judges), and that stands idle (WAITING) for more than ``bound`` seconds at a stretch. Time its link is
  down, it is broken down, or its battery is empty does not count (the manager cannot move it then).

The bound is what separates waiting for traffic from waiting for ever: it must exceed the longest wait
the manager's traffic control imposes on purpose (the reference Dispatcher's robots wait for a lane or a
station to clear, docs/loop.md). A real deadlock lasts until the run ends, so any bound finds it given a
long enough run. When fields exist their ``deadlock`` events are the exact word, and this part stays as a
check on managers that leave robots waiting without a physical cause.

:func:`applies` says when the property belongs among the loop properties
(:func:`vcran.testing.loop.loop_problems`): when the scenario has a roadmap (a manager routes, and may
reserve), or the run recorded ``deadlock`` events.
"""

from __future__ import annotations

from typing import Any

from vcran.core.jobs import waiting_spans
from vcran.testing.spans import away_spans, idle_spans, minus

#: Default for :func:`check_no_deadlock`: how long a robot may stand idle on an open job (seconds).
STUCK_BOUND = 600.0
#: The event the simulation raises for robots blocked on one another (docs/contract.md §12).
DEADLOCK = "deadlock"


def applies(result: Any) -> bool:
    """Whether "no deadlock" is one of the loop properties for ``result``: its scenario has a roadmap, or
    the run recorded a ``deadlock`` event."""
    scenario = getattr(result, "scenario", None)
    return getattr(scenario, "roadmap", None) is not None or any(e["event"] == DEADLOCK for e in result.events)


def check_no_deadlock(result: Any, bound: float = STUCK_BOUND) -> list[str]:
    """No ``deadlock`` event, and no robot stuck on a job for more than ``bound`` seconds (module docstring)."""
    if not bound >= 0:
        raise ValueError(f"check_no_deadlock: bound must be a number of seconds >= 0, got {bound}")
    events = result.events
    problems = [_deadlock(e) for e in events if e["event"] == DEADLOCK]
    end = float(result.summary["sim_time"])
    held = _held(events, end)
    away = away_spans(events, end)
    for robot, idle in idle_spans(events, sorted(held), end).items():
        for a, b in minus(idle, away.get(robot, [])):
            for job, c, d in held[robot]:
                lo, hi = max(a, c), min(b, d)
                if hi - lo > bound:
                    problems.append(f"{robot} stood idle from t={lo:g} to t={hi:g} ({hi - lo:g} s > {bound:g} s) "
                                    f"on job {job}, which was still open and had no cancelled task to re-plan")
                    break
    return problems


def _deadlock(e: dict[str, Any]) -> str:
    """A ``deadlock`` event (:class:`vcran.core.incidents.Deadlock`) in one line: a cycle names its robots,
    a robot blocked past the bound the robots it waited for."""
    robot, other = str(e.get("robot", "")), e.get("other") or ""
    if e.get("kind") == "bound":
        return f"t={e['t']:g}: deadlock (bound) of {robot}, blocked {e.get('duration', 0):g} s by {other}"
    kind = f" ({e['kind']})" if e.get("kind") else ""
    return f"t={e['t']:g}: deadlock{kind} of {', '.join([robot, *other.split(', ')] if other else [robot])}"


def _held(events: list[dict[str, Any]], end: float) -> dict[str, list[tuple[str, float, float]]]:
    """Per robot, ``(job, from, to)``: the job was its (its latest task went to the robot) and open, and not
    waiting for a robot (:func:`vcran.core.jobs.waiting_spans`)."""
    spans: dict[str, list[tuple[str, float, float]]] = {}
    since: dict[str, tuple[str, float]] = {}  # job -> (robot, since)

    def close(job: str, t: float) -> None:
        robot, start = since.pop(job, ("", 0.0))
        if robot:
            spans.setdefault(robot, []).append((job, start, t))

    for e in events:
        kind = e["event"]
        if kind == "job_assigned" and since.get(e["job"], ("",))[0] != e["robot"]:  # the same robot: it goes on
            close(e["job"], e["t"])
            since[e["job"]] = (e["robot"], e["t"])
        elif kind in ("job_completed", "job_failed"):
            close(e["job"], e["t"])
    for job in list(since):
        close(job, end)
    waits: dict[str, list[tuple[float, float]]] = {}
    for job, a, b in waiting_spans(events, end):
        waits.setdefault(job, []).append((a, b))
    return {robot: [(job, c, d) for job, a, b in held for c, d in minus([(a, b)], waits.get(job, []))]
            for robot, held in spans.items()}
