"""The rules, checked on a run's output folder (events, trace and the telemetry its leg log determines).

Used by the whole-simulation fuzz tests and by ``vcran fuzz``. The checks are about the rules, not about
"everything completes": a perturbed script legitimately produces rejections, timeouts and cancels. Each
check returns human-readable violations (empty when the run kept the rules):

* R6: every state change is one of the cycle's transitions (restated here from docs/contract.md, not taken from
  RanLogic) and starts where the previous one ended;
* R1/R8/R9: every queued task ends at most once per life, as completed or cancelled with a known reason;
  with ``finished`` (the run went idle), every queued task ended;
* R7/R8/R14: a cancelled task ends at or after the request (its cancel_order, or first seen + timeout),
  at the request (within R14's tolerance) or at the end of the one leg or action that was running;
  nothing of a task finishes after its end, and at most one leg or action of it finishes after the request;
* R13: an assignment cancelled on its own is never finished afterwards;
* docs/contract.md §4/R6: the AGV moves only while its robot is in MOTION (telemetry against the state changes).
"""

from __future__ import annotations

from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from vcran.core.opil.effects import Reason, State
from vcran.core.scenario import Scenario
from vcran.io.trace import (
    event_records,
    events_beside,
    read_header,
    records,
    robots_of,
    samples,
    trace_in,
)
from vcran.testing.model import TOLERANCE, TRANSITIONS

_TRANSITIONS = {(a.value, b.value) for a, b in TRANSITIONS}  # R6, restated in vcran.testing.model
_REASONS = {r.value for r in Reason}


@dataclass
class _Life:
    """One task's life on one robot: from task_queued to its end."""

    queued: float
    end: float | None = None
    reason: str | None = None
    finishes: list[tuple[float, str]] = field(default_factory=list)  # (t, "motion"/"action")
    skips: list[float] = field(default_factory=list)  # when assignments were cancelled on their own (R13)


def check_run(out: Path, task_timeout: float, finished: bool) -> list[str]:
    """Every violation of the rules found in the output folder ``out`` (module docstring)."""
    trace = trace_in(out)
    events = list(event_records(events_beside(trace)))
    cancels = _cancel_requests(trace)
    problems = check_states(events) + check_lives(events, cancels, task_timeout, finished)
    return problems + check_cancelled_assignments(events) + check_motion(out, events)


def check_states(events: list[dict[str, Any]]) -> list[str]:
    """R6: only the cycle's transitions, each from the state the previous one reached."""
    state: dict[str, str] = defaultdict(lambda: State.WAITING.value)
    problems = []
    for e in events:
        if e["event"] != "state":
            continue
        r = e["robot"]
        if (e["from"], e["to"]) not in _TRANSITIONS:
            problems.append(f"t={e['t']} {r}: transition {e['from']} -> {e['to']} does not exist (R6)")
        if e["from"] != state[r]:
            problems.append(f"t={e['t']} {r}: transition from {e['from']}, but the state was {state[r]} (R6)")
        state[r] = e["to"]
    return problems


def check_lives(events: list[dict[str, Any]], cancels: dict[tuple[str, str], list[float]],
                task_timeout: float, finished: bool) -> list[str]:
    """R1, R7, R8, R9 on task lifetimes (module docstring)."""
    lives: dict[tuple[str, str], list[_Life]] = defaultdict(list)
    problems = []
    for e in events:
        kind, key, t = e["event"], (e["robot"], e.get("task", "")), e["t"]
        life = lives[key][-1] if lives[key] else None
        open_life = life if life is not None and life.end is None else None
        if kind == "task_queued":
            if open_life is not None:
                problems.append(f"t={t} {key[0]}: task {key[1]} queued again while queued (R1)")
            lives[key].append(_Life(t))
        elif kind in ("task_completed", "task_cancelled"):
            if open_life is None:
                problems.append(f"t={t} {key[0]}: task {key[1]} ended twice or was never queued")
                continue
            open_life.end, open_life.reason = t, e.get("reason", "completed")
            if kind == "task_cancelled" and e.get("reason") not in _REASONS:
                problems.append(f"t={t} {key[0]}: task {key[1]} cancelled with unknown reason {e.get('reason')!r}")
        elif kind in ("motion_finished", "action_finished"):
            if open_life is None:
                problems.append(f"t={t} {key[0]}: {kind} for task {key[1]}, which is not queued (R8)")
                continue
            open_life.finishes.append((t, kind))
        elif kind == "assignment_cancelled" and open_life is not None:
            open_life.skips.append(t)
    for (robot, task), history in lives.items():
        for life in history:
            where = f"{robot}: task {task} (queued at {life.queued})"
            if life.end is None:
                if finished:
                    problems.append(f"{where} never ended, though the run went idle")
                continue
            if life.reason in ("cancelled", "timeout"):
                if life.reason == "timeout":
                    request = life.queued + task_timeout
                else:
                    whole = [c for c in cancels.get((robot, task), []) if life.queued <= c <= life.end]
                    # a partial cancel may come before the task: remembered, it skips the assignment on arrival
                    partial = [c for c in cancels.get((robot, task + "#"), []) if c <= life.end] if life.skips else []
                    if not whole + partial and any(life.queued <= c <= life.end for c in cancels.get((robot, ""), [])):
                        continue  # a raw payload may have carried the cancel: its task is not known here
                    if not whole + partial:
                        problems.append(f"{where} cancelled at {life.end} with no cancel_order for it (R8)")
                        continue
                    # the first whole-task cancel; else the instant the last of its assignments was cancelled
                    # on its own, which cancelled the task (R13)
                    request = whole[0] if whole else life.skips[-1]
                problems += _ended_after_request(where, life, request)
    return problems


def _ended_after_request(where: str, life: _Life, request: float) -> list[str]:
    """R7/R8: the end comes at the request, or when the one running leg or action finishes."""
    assert life.end is not None
    after = [f for f in life.finishes if f[0] > request]
    if life.end < request:
        return [f"{where} ended ({life.reason}) at {life.end}, before its request at {request}"]
    if len(after) > 1:
        return [f"{where}: {len(after)} legs/actions finished after the {life.reason} request at {request}; "
                "only the running one may (R8)"]
    if life.end > request + 2 * TOLERANCE and not (after and after[0][0] == life.end):
        return [f"{where} ended ({life.reason}) at {life.end}, not at the request ({request}) nor at the end "
                "of its running leg or action (R7/R8)"]
    return []


def _cancel_requests(trace: Path) -> dict[tuple[str, str], list[float]]:
    """cancel_order records: (robot, task label) -> times of whole-task cancels, (robot, label + "#") ->
    times of partial ones (R13); raw ones under (robot, "")."""
    out: dict[tuple[str, str], list[float]] = defaultdict(list)
    for _, r in records(trace, ("in",)):
        if r.get("dir") != "in" or r.get("attr") != "cancel_order":
            continue
        if "value" not in r:
            out[(r["robot"], "")].append(r["t"])
            continue
        v = r["value"]
        whole = all(_unused(v[k]) for k in ("motion_id", "action_id"))
        out[(r["robot"], _label(v["task_id"]) + ("" if whole else "#"))].append(r["t"])
    return out


def check_cancelled_assignments(events: list[dict[str, Any]]) -> list[str]:
    """R13: a motion or action cancelled on its own never finishes afterwards (in that task's life)."""
    cancelled: set[tuple[str, str, str, str]] = set()
    problems = []
    for e in events:
        kind, robot = e["event"], e["robot"]
        if kind == "task_queued":
            cancelled = {c for c in cancelled if c[:2] != (robot, e["task"])}
        elif kind == "assignment_cancelled":
            which = "motion" if "motion" in e else "action"
            cancelled.add((robot, e["task"], which, e[which]))
        elif kind in ("motion_finished", "action_finished"):
            which = kind.split("_")[0]
            if (robot, e["task"], which, e[which]) in cancelled:
                problems.append(f"t={e['t']} {robot}: {which} {e[which]} of task {e['task']} finished after it "
                                "was cancelled (R13)")
    return problems


def _unused(ident: dict[str, Any]) -> bool:
    return ident["description"] == "not supported" or ident["uuid"] == "00000000-0000-0000-0000-000000000000"


def _label(ident: dict[str, Any]) -> str:
    return str(ident["description"] or ident["uuid"])


def check_motion(out: Path, events: list[dict[str, Any]]) -> list[str]:
    """The AGV moves only in MOTION: between two telemetry ticks where its pose changed, or at a tick
    where it has a velocity, its robot was in MOTION at some instant of that interval."""
    trace = trace_in(out)
    robots = robots_of(read_header(trace))
    rows = samples(trace)
    if len(rows) == 0:
        return []
    changes: dict[str, list[tuple[float, str, str]]] = defaultdict(list)
    for e in events:
        if e["event"] == "state":
            changes[e["robot"]].append((e["t"], e["from"], e["to"]))
    problems = []
    t = rows[:, 0]
    for i, robot in enumerate(robots):
        pose = rows[:, 1 + 5 * i: 4 + 5 * i]
        speed = rows[:, 4 + 5 * i: 6 + 5 * i]
        moved = np.zeros(len(rows), dtype=bool)
        moved[1:] = np.any(pose[1:] != pose[:-1], axis=1)
        moved |= np.any(speed != 0.0, axis=1)
        for k in np.flatnonzero(moved):
            start = t[k - 1] if k > 0 else t[k]
            if not _in_motion(changes[robot], float(start), float(t[k])):
                problems.append(f"t={t[k]} {robot}: the AGV moved between t={start} and t={t[k]} "
                                "without being in MOTION (R6, §4)")
                break
    return problems


def _in_motion(changes: list[tuple[float, str, str]], a: float, b: float) -> bool:
    """Whether the state was MOTION at some instant of [a, b]."""
    state = State.WAITING.value
    for t, frm, to in changes:
        if t > b:
            break
        if t <= a:
            state = to
        elif State.MOTION.value in (frm, to):
            return True
    return state == State.MOTION.value


def overdue(robots: list[Any], now: float) -> list[str]:
    """R7 at the end of a run: no task still queued that was not assembled by its deadline, unless it
    is finishing its running leg or action (R8). ``robots`` are OPIL's RanNodes (``model.protocol.nodes``)."""
    problems = []
    for robot in robots:
        for task in robot.logic.queue.values():
            if len(task.slots) < task.length and task.deadline < now and task.ending is None:
                problems.append(f"{robot.id}: task {task.id.label} not assembled by its deadline "
                                f"{task.deadline}, still queued at {now} (R7)")
    return problems


# --- one variant, end to end ---------------------------------------------------------------------------------


def run_variant(scenario: Scenario, work: Path, *, again: bool = True) -> list[str]:
    """Run ``scenario`` into ``work/a`` and return every rule violation of the outputs.

    With ``again``, also run it a second time (outputs must be byte-identical, docs/contract.md §5) and replay its trace
    (replay verification must find no difference, docs/contract.md §6). A crash is a violation too (R12: the simulation
    never crashes on input). When the run went idle, every queued task must have ended.
    """
    from transports.scripted import ScriptedTransport
    from vcran.runner import run_to
    from vcran.testing.variant import again_and_replay

    try:
        result = run_to(scenario, work / "a", ScriptedTransport(scenario.messages(), frames=False))
        idle = result.model.protocol.idle()
        problems = check_run(work / "a", scenario.settings.task_timeout, finished=idle)
        problems += overdue(result.model.protocol.nodes, result.summary["sim_time"])
        if problems or not again:
            return problems
        return again_and_replay(scenario, work)
    except Exception as exc:  # noqa: BLE001 - any crash on input is the finding
        return [f"crash: {type(exc).__name__}: {exc}"]
