"""The rules of what happens in a scenario: injected and random faults, the closed loop's jobs, job stream,
link and manager (docs/contract.md §9), and the message script with its cycles (issue 30 item 3).

Each part has its fields' rules (keyed as a file names the fields, in the order a file's reader reads them)
and a function for its problems: its own fields (``fields_too``), then what relates it to the rest of the
scenario (a fault's robot is one of the fleet, a job's stations are stations, nothing happens after the run
has ended). A message a script sends is checked as it is built (:mod:`vcran.core.opil.build`), not here.
"""

from __future__ import annotations

import math
import re
from collections.abc import Collection, Sequence
from typing import Any

from vcran.core.faults import KINDS as FAULT_KINDS
from vcran.core.faults import MIN_MEAN, RANDOM_KINDS, FaultSpec, RandomFaults
from vcran.core.scenario import (
    ACTION_KINDS,
    POLLING,
    SUBSCRIPTION,
    Cycle,
    Job,
    JobStream,
    LinkSettings,
    ManagerSpec,
    ScriptEntry,
    TaskSpec,
)
from vcran.core.validity.fields import (
    Choices,
    Integer,
    Name,
    Number,
    OneOf,
    Problem,
    Rule,
    Shape,
    Strings,
    Text,
    Weights,
    fields,
    pose_problem,
    shown,
)

#: Actions a script may send: the configurable ones and ``charge`` (docs/contract.md §4, a robot with a battery).
SCRIPT_ACTIONS = (*ACTION_KINDS, "charge")
#: The latest time a message can be stamped with: ROS time stamps hold int32 seconds (docs/contract.md §2).
LAST_STAMP = 2**31 - 1


def after_end(time: float, end: float | None, what: str) -> str | None:
    """A job, a fault or a script entry after the run's end would never happen, silently (a task would
    time out for no visible reason): refuse it. One at exactly ``end`` still happens (before the end,
    docs/determinism.md)."""
    if end is not None and time > end:
        return f"the {what} at t = {time:g}, after the run ends (duration = {end:g})"
    return None


def _starts_too_late(start: float, end: float | None, what: str) -> str | None:
    """A random source (faults, jobs) draws strictly after its ``start``: one starting when the run has
    ended would draw nothing, silently."""
    if end is not None and start >= end:
        return f"the {what} starts at t = {start:g}, when the run has ended (duration = {end:g}): it would draw nothing"
    return None


def in_time_order(section: str, items: Sequence[Any]) -> list[Problem]:
    """The model holds jobs, faults and script entries in time order (a file's reader sorts them, equal times
    in file order): one out of order would fall due in the past, when the run has passed its time."""
    for k in range(1, len(items)):
        t, before = items[k].t, items[k - 1].t
        if t < before:
            return [Problem(f"{section}[{k}].t", f"{t:g} is before the time of {section}[{k - 1}] ({before:g}): "
                                                 f"{section} are listed in time order")]
    return []


# --- faults (docs/contract.md §4) -----------------------------------------------------------------------------------

FAULT: dict[str, Rule] = {
    "t": Number(minimum=0.0),
    "robot": Text(),
    "kind": OneOf(tuple(FAULT_KINDS), "fault"),
    "duration": Number(positive=True),  # of a fault that lasts (FAULT_KINDS[kind]); the others have none
}


def _mean(v: float) -> str | None:
    """``mtbf`` or ``mttr``: at least :data:`~vcran.core.faults.MIN_MEAN` (a tinier mean stalled time)."""
    if v < MIN_MEAN:
        return f"must be at least {MIN_MEAN:g} s (R14: instants closer than 1 µs are one instant), got {v:g}"
    return None


RANDOM_FAULTS: dict[str, Rule] = {
    "kind": OneOf(RANDOM_KINDS, "random fault"),
    "start": Number(minimum=0.0),
    "robots": Strings(),
    "mtbf": Number(positive=True, then=_mean),
    "mttr": Number(positive=True, then=_mean),  # of a kind that lasts
    "until": Number(minimum=0.0, absent=math.inf),
}


def _no_robot(robot: str, robots: Collection[str], why: str = "") -> str | None:
    return None if robot in robots else f"no robot {robot!r} in this scenario{why}; robots: {', '.join(sorted(robots))}"


def fault_problems(f: Any, k: int, robots: Collection[str], end: float | None,
                   fields_too: bool = True) -> list[Problem]:
    where = f"faults[{k}]"
    if not isinstance(f, FaultSpec):
        return [Problem(where, f"expected a FaultSpec, got {type(f).__name__}")]
    if fields_too:
        out = fields(f, where, FAULT, skip=("duration",))
        if not out and FAULT_KINDS[f.kind]:
            out = fields(f, where, {"duration": FAULT["duration"]})
        if out:
            return out
    problems = [("t", after_end(f.t, end, "fault happens")), ("robot", _no_robot(f.robot, robots))]
    return [Problem(f"{where}.{key}", p) for key, p in problems if p]


def random_faults_problems(r: Any, i: int, robots: Collection[str], end: float | None,
                           fields_too: bool = True) -> list[Problem]:
    where = f"random_faults[{i}]"
    if not isinstance(r, RandomFaults):
        return [Problem(where, f"expected a RandomFaults, got {type(r).__name__}")]
    if fields_too:
        out = fields(r, where, RANDOM_FAULTS, skip=("mttr",))
        if not out and FAULT_KINDS[r.kind]:
            out = fields(r, where, {"mttr": RANDOM_FAULTS["mttr"]})
        if out:
            return out
    out = []
    if problem := _starts_too_late(r.start, end, "random fault source"):
        out.append(Problem(f"{where}.start", problem))
    for n, robot in enumerate(r.robots):
        if robot not in robots:
            out.append(Problem(f"{where}.robots", f"no robot {robot!r} in this scenario"))
        elif robot in r.robots[:n]:
            out.append(Problem(f"{where}.robots", f"names {robot!r} twice"))
    if r.until <= r.start:  # it draws strictly after start, before until: nothing, silently
        out.append(Problem(f"{where}.until",
                           f"{r.until:g} is not after start {r.start:g}: the source would draw nothing"))
    return out


def paused_forever(faults: Sequence[FaultSpec]) -> list[Problem]:
    """A run that ends only when idle never ends if a robot stays paused with work to do (it is never idle
    again): a pause that no later resume ends, when there is no duration to stop at."""
    paused: dict[str, float] = {}
    for f in faults:  # in time order, file order within an instant: the order they are applied
        if f.kind == "pause":
            paused.setdefault(f.robot, f.t)
        elif f.kind == "resume":
            paused.pop(f.robot, None)
    return [Problem("", f"[[faults]]: {robot} is paused at t = {t:g} and never resumed, and [simulation] has no "
                        "duration: with until_idle the run would never end once the robot has work; add a resume "
                        "or a duration") for robot, t in paused.items()]


# --- the closed loop (docs/contract.md §9) --------------------------------------------------------------------------

JOB: dict[str, Rule] = {
    "t": Number(minimum=0.0),
    "id": Name(),
    "pickup": Text(),
    "dropoff": Text(),
    "priority": Integer(),
    "deadline": Number(minimum=0.0, absent=None),
}
JOB_STREAM: dict[str, Rule] = {
    "rate": Number(positive=True),
    "start": Number(minimum=0.0),
    "until": Number(minimum=0.0),
    "pickup": Weights(),
    "dropoff": Weights(),
    "prefix": Name(),
    "seed": Integer(),
    "priority": Integer(),
    "deadline_after": Number(positive=True, absent=None),
}
_STREAM_ATTRS = {"pickup": "pickups", "dropoff": "dropoffs"}
LINK: dict[str, Rule] = {
    "latency": Number(positive=True),
    "jitter": Number(minimum=0.0),
    "inbound": OneOf((SUBSCRIPTION, POLLING), "inbound"),
    "poll_interval": Number(positive=True),
    "loss": Number(minimum=0.0, then=lambda v: f"must be below 1 (a probability: 1 would lose every message), got {v!r}"
                   if v >= 1 else None),
}
_MANAGER_PATH = re.compile(r"[A-Za-z_][\w.]*:[A-Za-z_][\w.]*")


def _manager_path(v: str) -> str | None:
    if _MANAGER_PATH.fullmatch(v):
        return None
    return f"expected 'module:Class' (e.g. 'vcran.managers:Dispatcher'), got {v!r}"


#: ``[manager]``: ``class`` is :attr:`ManagerSpec.path`; its ``options`` are the manager's to check.
MANAGER: dict[str, Rule] = {"class": Text(then=_manager_path)}


def _no_station(name: str, stations: Sequence[str]) -> str | None:
    if name in stations:
        return None
    return f"no station {name!r} in this scenario; stations: {', '.join(stations) or 'none'}"


def job_problems(j: Any, k: int, stations: Sequence[str], end: float | None, fields_too: bool = True) -> list[Problem]:
    where = f"jobs[{k}]"
    if not isinstance(j, Job):
        return [Problem(where, f"expected a Job, got {type(j).__name__}")]
    if fields_too and (out := fields(j, where, JOB)):
        return out
    problems = [("t", after_end(j.t, end, "job arrives")), ("pickup", _no_station(j.pickup, stations)),
                ("dropoff", _no_station(j.dropoff, stations))]
    if j.pickup == j.dropoff:
        problems.append(("dropoff", f"equals the pickup {j.pickup!r}: a job moves a part from one station to another"))
    if j.deadline is not None and j.deadline <= j.t:
        problems.append(("deadline",
                         f"{j.deadline} is not after the job's time {j.t} (a deadline is an absolute time)"))
    return [Problem(f"{where}.{key}", p) for key, p in problems if p]


def job_stream_problems(s: Any, stations: Sequence[str], jobs: Sequence[str], end: float | None,
                        fields_too: bool = True) -> list[Problem]:
    """The stream's problems; ``jobs`` are the listed jobs' ids, which its names must not take."""
    if not isinstance(s, JobStream):
        return [Problem("job_stream", f"expected a JobStream, got {type(s).__name__}")]
    if fields_too and (out := fields(s, "job_stream", JOB_STREAM, _STREAM_ATTRS)):
        return out
    problems = [("start", _starts_too_late(s.start, end, "job stream"))]
    if s.until <= s.start:
        problems.append(("until", f"{s.until} is not after start {s.start}"))
    for key, pairs in (("pickup", s.pickups), ("dropoff", s.dropoffs)):
        for n, (name, _) in enumerate(pairs):
            problems.append((key, _no_station(name, stations)))
            if any(name == other for other, _ in pairs[:n]):
                problems.append((key, f"names {name!r} twice"))
    for p, _ in s.pickups:
        if not any(d != p for d, _ in s.dropoffs):
            problems.append(("dropoff", f"offers no station other than the pickup {p!r}"))
    clash = next((j for j in jobs if re.fullmatch(rf"{re.escape(s.prefix)}_[0-9]+", j)), None)
    if clash is not None:
        problems.append(("prefix", f"the stream names its jobs {s.prefix}_1, {s.prefix}_2, ...; [[jobs]] id "
                                   f"{clash!r} would clash"))
    return [Problem(f"job_stream.{key}", p) for key, p in problems if p]


def link_problems(link: Any, fields_too: bool = True) -> list[Problem]:
    if not isinstance(link, LinkSettings):
        return [Problem("link", f"expected a LinkSettings, got {type(link).__name__}")]
    return fields(link, "link", LINK) if fields_too else []


def manager_problems(m: Any, fields_too: bool = True) -> list[Problem]:
    if not isinstance(m, ManagerSpec):
        return [Problem("manager", f"expected a ManagerSpec or None, got {type(m).__name__}")]
    if not fields_too:
        return []
    out = fields(m, "manager", MANAGER, {"class": "path"})
    if not (isinstance(m.options, tuple) and all(isinstance(o, tuple) and len(o) == 2 and isinstance(o[0], str)
                                                 for o in m.options)):
        out.append(Problem("manager.options", f"expected (keyword, value) pairs, got {shown(m.options)!r}"))
    return out


# --- the message script ---------------------------------------------------------------------------------


def _stamp(v: float) -> str | None:
    """Said of the field, before its messages are built (a stamp of 1e308 s overflows)."""
    if v > LAST_STAMP:
        return f"{v:g} s is later than a message's time stamp can say (int32 seconds: up to {LAST_STAMP} s)"
    return None


#: What every script entry has; a cycle's own fields follow in :data:`CYCLE`, a task's in :data:`TASK`.
SCRIPT: dict[str, Rule] = {"t": Number(minimum=0.0, then=_stamp), "robot": Text()}
CYCLE: dict[str, Rule] = {
    "every": Number(positive=True),
    "until": Number(minimum=0.0, absent=math.inf),
    "prefix": Name(),
    "max_velocity": Number(minimum=0.0),
}


def _poses(v: Any) -> str | None:
    if not isinstance(v, (list, tuple)) or any(pose_problem(p) for p in v):
        return f"expected a list of [x, y] or [x, y, theta] points, got {shown(v)!r}"
    return None


TASK: dict[str, Rule] = {"path": Shape(_poses), "actions": Choices(SCRIPT_ACTIONS, "action")}


def task_problem(spec: TaskSpec) -> str | None:
    """A task that does nothing (said of its ``path``)."""
    return None if spec.path or spec.actions else "a task needs at least one point or one action"


def script_problems(script: Sequence[Any], cycles: Sequence[Any], robots: Collection[str], end: float | None,
                    fields_too: bool = True) -> list[Problem]:
    """The script's entries (``script[k]``) and cycles (``cycles[k]``, their tasks ``cycles[k].tasks[j]``):
    each for a robot of the fleet, none after the run's end."""
    out: list[Problem] = []
    for k, e in enumerate(script):
        where = f"script[{k}]"
        if not isinstance(e, ScriptEntry):
            out.append(Problem(where, f"expected a ScriptEntry, got {type(e).__name__}"))
            continue
        own = fields(e, where, SCRIPT) if fields_too else []
        if not own and e.robot not in robots:
            own.append(Problem(f"{where}.robot", _no_robot(e.robot, robots, " (R11)") or ""))
        out += own
    if not out:
        out += in_time_order("script", script)
    for k, c in enumerate(cycles):
        out += _cycle_problems(c, f"cycles[{k}]", robots, fields_too)
    if out or end is None:
        return out
    late = [e.t for e in script if e.t > end] + [c.t for c in cycles if c.t > end]
    if late:
        out.append(Problem("", f"script: an entry is sent at t = {min(late):g}, after the run ends "
                               f"(duration = {end:g})"))
    return out


def _cycle_problems(c: Any, where: str, robots: Collection[str], fields_too: bool) -> list[Problem]:
    if not isinstance(c, Cycle):
        return [Problem(where, f"expected a Cycle, got {type(c).__name__}")]
    out = fields(c, where, {**SCRIPT, **CYCLE}) if fields_too else []
    if not isinstance(c.tasks, tuple) or not c.tasks:
        out.append(Problem(f"{where}.tasks", "a cycle needs at least one task"))
    else:
        for j, spec in enumerate(c.tasks):
            if not isinstance(spec, TaskSpec):
                out.append(Problem(f"{where}.tasks[{j}]", f"expected a TaskSpec, got {type(spec).__name__}"))
                continue
            own = fields(spec, f"{where}.tasks[{j}]", TASK) if fields_too else []
            if not own and (problem := task_problem(spec)):
                own.append(Problem(f"{where}.tasks[{j}].path", problem))
            out += own
    if not out and c.robot not in robots:
        out.append(Problem(f"{where}.robot", _no_robot(c.robot, robots, " (R11)") or ""))
    return out
