"""How jobs ended, judged from what the run recorded (docs/contract.md §9): two loop properties a manager that gives up
must fail. docs/fuzzing.md defines every term; :mod:`vcran.testing.loop` applies them with the others.

* :func:`check_failures_have_evidence` — a job is reported failed only with evidence: a task sent for it
  ended without success by the instant of the report, or no robot could serve it then;
* :func:`check_feasible_jobs_completed` — in an undisturbed run (no fault, no empty battery, no collision),
  a feasible workload completes every job: none is reported failed, and none is still open at the end
  that arrived at least ``margin`` seconds before it.

The evidence comes from the events and job records of the run and from its scenario (the fleet's
configuration, which the manager is given too), never from what the manager says: a ``job_failed``
event's reason is the manager's word and proves nothing.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable
from typing import Any

from vcran.core.jobs import order_unsuccessful
from vcran.core.scenario import Scenario

#: Default for :func:`check_feasible_jobs_completed`: a job that arrived this long before the end of the
#: run has had time to complete (the Dispatcher needs under two minutes for one warehouse job, with
#: three tries and their 10 + 20 s back-off; ``loop_variants``' default settle is 600 s).
COMPLETION_MARGIN = 300.0

#: Why a task ended without success, as the run records it: the RAN cancelled it (``task_cancelled``,
#: any reason), or refused it whole because its robot was out of service (``rejected``, code
#: ``battery_empty``). Other rejections are the manager's own protocol errors (``check_protocol``).
REFUSED_OUT_OF_SERVICE = "battery_empty"


def lost_for_good(scenario: Scenario, events: Iterable[dict[str, Any]], t: float) -> set[str]:
    """The robots out of service for good at ``t``: their battery ran empty by then (a ``battery_empty``
    event) and is never swapped (no ``swap_after``). A robot waiting for a swap is not lost."""
    never_swapped = {r.id for r in scenario.robots if r.battery is not None and r.battery.swap_after is None}
    return {e["robot"] for e in events if e["event"] == "battery_empty" and e["t"] <= t and e["robot"] in never_swapped}


def unservable(scenario: Scenario, events: list[dict[str, Any]], t: float) -> bool:
    """No robot can serve a job at ``t``: none is configured for it (``RobotConfig.moves_parts``: load and
    unload, capacity at least 1), or every one that is has been lost for good by then
    (:func:`lost_for_good`). Stations are never in doubt: a job names stations of the scenario (the loader
    refuses others) whose docks are in their reach, and robots drive straight to any point."""
    able = {r.id for r in scenario.robots if r.moves_parts}
    return not able - lost_for_good(scenario, events, t)


def _unsuccessful_ends(events: list[dict[str, Any]]) -> dict[tuple[str, str], list[float]]:
    """Per (robot, task), the instants the run recorded it ending without success; a VDA 5050 job's task is an
    order (:func:`vcran.core.jobs.order_unsuccessful`: refused, given up, cancelled, or its action FAILED)."""
    ends: dict[tuple[str, str], list[float]] = {}
    for e in events:
        if e["event"] == "task_cancelled" or (e["event"] == "rejected" and e.get("code") == REFUSED_OUT_OF_SERVICE
                                              and "task" in e):
            ends.setdefault((e["robot"], e["task"]), []).append(e["t"])
        elif (order := order_unsuccessful(e)) is not None:
            ends.setdefault((e["robot"], order), []).append(e["t"])
    return ends


def check_failures_have_evidence(result: Any) -> list[str]:
    """Every job reported failed has evidence at the instant of the report: a task sent for it (a
    ``job_assigned`` event) ended without success at or after it was sent and at or before the report
    (:data:`REFUSED_OUT_OF_SERVICE`), or no robot could serve it then (:func:`unservable`)."""
    scenario = _scenario(result, "check_failures_have_evidence")
    events = result.events
    ends = _unsuccessful_ends(events)
    sent: dict[str, list[tuple[float, str, str]]] = {}
    problems = []
    for e in events:
        if e["event"] == "job_assigned":
            sent.setdefault(e["job"], []).append((e["t"], e["robot"], e["task"]))
        elif e["event"] == "job_failed":
            t, job = e["t"], e["job"]
            if any(a <= end <= t for a, robot, task in sent.get(job, []) for end in ends.get((robot, task), [])):
                continue
            if unservable(scenario, events, t):
                continue
            tasks = sent.get(job, [])
            problems.append(f"job {job} reported failed ({e.get('reason', '')}) at t={t:g} without evidence: "
                            + (f"none of its {len(tasks)} task(s) ({', '.join(task for _, _, task in tasks)}) had ended "
                               "without success by then" if tasks else "no task was sent for it")
                            + ", and a robot could serve it")
    return problems


def infeasible(scenario: Scenario, jobs: Iterable[Any]) -> list[str]:
    """Why the workload ``jobs`` (JobRecords) is not feasible on ``scenario``'s fleet (empty: feasible).

    Feasible: some robot can serve a job (``RobotConfig.moves_parts``) and every robot starts with nothing
    on board; every pickup station holds at the start at least one part per job that picks up there (parts
    produced or delivered later are not counted); every drop-off station has room for one part per job that
    delivers there, beyond what it holds at the start and all it may produce (one that produces without a
    ``produce_limit`` may fill up: no room is certain)."""
    reasons = []
    if not any(r.moves_parts for r in scenario.robots):
        reasons.append("no robot is configured to load and unload")
    reasons += [f"{r.id} starts with {r.carrying} part(s) on board" for r in scenario.robots if r.carrying]
    stations = {s.id: s for s in scenario.stations}
    records = list(jobs)
    for station, n in sorted(Counter(r.job.pickup for r in records).items()):
        if stations[station].parts < n:
            reasons.append(f"{station} holds {stations[station].parts} part(s) at the start for {n} pickup(s)")
    for station, n in sorted(Counter(r.job.dropoff for r in records).items()):
        s = stations[station]
        if s.produce_every > 0 and not s.produce_limit:
            reasons.append(f"{station} produces parts without limit, so it may be full for {n} drop-off(s)")
            continue
        room = s.capacity - s.parts - (s.produce_limit if s.produce_every > 0 else 0)
        if room < n:
            reasons.append(f"{station} has room for {room} part(s) for {n} drop-off(s), after what it holds at "
                           "the start and may produce")
    return reasons


def disturbances(events: Iterable[dict[str, Any]]) -> list[dict[str, Any]]:
    """The events that disturbed the run (docs/contract.md §4): a fault that applied (one with ``applied: false`` did
    nothing), a battery that ran empty, a task cancelled (a VDA 5050 order given up) by a collision
    (``collisions = "stop"``; a ``collision`` merely reported stops nobody)."""
    return [e for e in events if (e["event"] == "fault" and e.get("applied", True)) or e["event"] == "battery_empty"
            or (e["event"] == "task_cancelled" and e.get("reason") == "collision")
            or (e["event"] == "order_ended" and e.get("how") == "collision")]


def check_feasible_jobs_completed(result: Any, margin: float = COMPLETION_MARGIN) -> list[str]:
    """Without faults, a feasible workload completes every job by the run's end: in an undisturbed run
    (:func:`disturbances`) of a feasible workload (:func:`infeasible`), no job is reported failed, and
    none is still open at the end of the run that arrived at least ``margin`` seconds before it."""
    if not margin >= 0:
        raise ValueError(f"check_feasible_jobs_completed: margin must be a number of seconds >= 0, got {margin}")
    scenario = _scenario(result, "check_feasible_jobs_completed")
    if disturbances(result.events) or infeasible(scenario, result.jobs):
        return []
    end = float(result.summary["sim_time"])
    problems = []
    for r in result.jobs:
        if r.outcome == "failed":
            problems.append(f"job {r.id} ({r.job.pickup} -> {r.job.dropoff}) reported failed ({r.reason}) at "
                            f"t={r.ended:g}, though the workload was feasible and nothing disturbed the run")
        elif r.outcome == "open" and r.job.t <= end - margin:
            problems.append(f"job {r.id} ({r.job.pickup} -> {r.job.dropoff}) arrived at t={r.job.t:g} and was not "
                            f"completed by the end at t={end:g}, though the workload was feasible and nothing "
                            "disturbed the run")
    return problems


def _scenario(result: Any, check: str) -> Scenario:
    scenario = getattr(result, "scenario", None)
    if not isinstance(scenario, Scenario):
        raise TypeError(f"{check}: the result carries no scenario (a vcran.Result from vcran.simulate does), "
                        f"got {type(result).__name__}")
    return scenario
