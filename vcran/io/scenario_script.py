"""A scenario file's ``[[script]]`` (the original VC-RAN's JMeter file as TOML): each entry as the messages it sends,
or as a task cycle (docs/scenarios.md).

An entry names its time, its robot and its ``kind``: one message (``motion``, ``action``, ``cancel``, or a
``raw`` NGSI attribute as JSON), a whole ``task`` (its motions, then its actions), or a ``cycle`` of tasks
sent again and again; in a VDA 5050 scenario an ``order`` or ``instantActions`` message
(:mod:`vcran.io.scenario_vda5050`). The messages are built here (:mod:`vcran.core.opil.build`, which checks them as it builds
them); the model's rules for the entries (a robot of the fleet, a time a stamp can hold, nothing after the
run's end) are :mod:`vcran.core.validity.workload`'s.
"""

from __future__ import annotations

import json
import math
from functools import partial
from typing import Any

from vcran.core.opil import build
from vcran.core.opil.ids import IdError
from vcran.core.opil.messages import INBOUND
from vcran.core.opil.schema import MessageError
from vcran.core.scenario import Cycle, ScriptEntry, TaskSpec, task_entries
from vcran.core.validity.workload import CYCLE, SCRIPT_ACTIONS, TASK, after_end, task_problem
from vcran.io.scenario_vda5050 import Draft, draft
from vcran.io.toml_table import Table

__all__ = ["check_in_run", "script_entry"]


def script_entry(t: Table) -> list[ScriptEntry] | Cycle | Draft:
    """The ``[[script]]`` entry ``t`` (read with :data:`~vcran.core.validity.workload.SCRIPT`'s rules); a
    VDA 5050 message as a :class:`~vcran.io.scenario_vda5050.Draft`, stamped once all are read."""
    time = t.number("t")  # its rule bounds it before the messages are built (a stamp of 1e308 s overflows)
    robot = t.string("robot")
    kind = t.choice("kind", list(_EXPANDERS))
    try:
        entries = _EXPANDERS[kind](t, time, robot)
    except (MessageError, IdError) as exc:
        t.fail(kind, str(exc))
    t.done()
    return entries  # type: ignore[no-any-return]


def _motion(t: Table, time: float, robot: str) -> list[ScriptEntry]:
    seq, length = t.sequence("seq")
    x, y, theta = t.triple("point")
    m = build.motion(
        t.name("task"), t.name("id"), seq, length, x, y, theta,
        use_orientation=t.boolean("use_orientation", False),
        is_waypoint=t.boolean("is_waypoint", seq < length),
        max_velocity=t.number("max_velocity", 0.0, minimum=0.0),
        max_acceleration=t.number("max_acceleration", 0.0, minimum=0.0),
        area=t.points("area", []),
        stamp=time,
    )
    return [ScriptEntry(time, robot, "motion_assignment", m)]


def _action(t: Table, time: float, robot: str) -> list[ScriptEntry]:
    seq, length = t.sequence("seq")
    category, code = t.integer("category", None), t.integer("code", None)
    kind = t.choice("action", SCRIPT_ACTIONS, None, hint=" (or give category/code)")
    task, aid = t.name("task"), t.name("id")
    raw_codes = category is not None or code is not None
    if kind is not None and raw_codes:
        t.fail("action", "give either action or category/code, not both")
    if kind is None and not raw_codes:
        t.fail("action", f"missing; give action ({', '.join(SCRIPT_ACTIONS)}) or category/code")
    if kind is not None:
        a = build.action(task, aid, seq, length, kind)
    else:
        a = build.action(task, aid, seq, length, category=category or 0, code=code or 0)
    return [ScriptEntry(time, robot, "action_assignment", a)]


def _cancel(t: Table, time: float, robot: str) -> list[ScriptEntry]:
    motion, action = t.name("motion", None), t.name("action", None)
    return [ScriptEntry(time, robot, "cancel_order", build.cancel(t.name("task"), motion=motion, action=action))]


def _raw(t: Table, time: float, robot: str) -> list[ScriptEntry]:
    attribute = t.choice("attribute", list(INBOUND))
    value = t.raw("value")
    if isinstance(value, str):
        try:
            value = json.loads(value)
        except (ValueError, RecursionError) as exc:  # JSONDecodeError, or an integer of over 4300 digits
            t.fail("value", f"not valid JSON: {str(exc).split('; use sys.set_int_max_str_digits', 1)[0]}")
    try:  # what Orion could hold: TOML dates and times have no JSON form (NaN is kept, to test R12)
        json.dumps(value, allow_nan=True)
    except (TypeError, ValueError, RecursionError) as exc:
        t.fail("value", f"not a JSON value: {exc}")
    return [ScriptEntry(time, robot, attribute, raw=value)]


def _task(t: Table, time: float, robot: str) -> list[ScriptEntry]:
    """A whole task in one entry: its path's motions, then its actions, ``every`` seconds apart. The task
    is the model's only as those messages, so its rule (:func:`task_problem`) is applied here."""
    task = t.name("task")
    spec = _task_spec(t.bind(TASK))
    problem = task_problem(spec)
    if problem:
        t.fail("path", problem)
    every = t.number("every", 0.0, minimum=0.0)
    return list(task_entries(time, robot, task, spec, every, t.number("max_velocity", 0.0, minimum=0.0)))


def _cycle(t: Table, time: float, robot: str) -> Cycle:
    t.bind(CYCLE)
    every = t.number("every")
    specs = []
    for sub in t.tables("tasks", TASK):
        specs.append(_task_spec(sub))
        sub.done()
    return Cycle(time, robot, every, t.number("until", math.inf), t.name("prefix", robot), tuple(specs),
                 t.number("max_velocity", 0.0))


def _task_spec(t: Table) -> TaskSpec:
    return TaskSpec(tuple(t.poses("path", [])), tuple(t.choices("actions", default=[])))


def check_in_run(t: Table, entry: list[ScriptEntry] | Cycle | Draft, duration: float | None) -> None:
    """An entry the run ends before would never be sent (:func:`vcran.core.validity.workload.after_end`),
    said of the whole [[script]] entry: a task's messages end at its last."""
    start = entry.t if isinstance(entry, Cycle | Draft) else max((e.t for e in entry), default=0.0)
    what = "starts" if isinstance(entry, Cycle) else "ends" if isinstance(entry, list) and len(entry) > 1 else "is sent"
    problem = after_end(start, duration, f"entry {what}")
    if problem:
        t.fail("t", problem)


_EXPANDERS: dict[str, Any] = {
    "motion": _motion, "action": _action, "cancel": _cancel, "raw": _raw, "task": _task, "cycle": _cycle,
    # VDA 5050 (docs/contract.md §11): the topic the message goes on
    "order": partial(draft, topic="order"), "instantActions": partial(draft, topic="instantActions"),
}
