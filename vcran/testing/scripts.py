"""Hypothesis strategies for whole scenarios and for perturbations of a message script.

A fleet manager talking to a real Orion reorders, repeats, delays and loses messages, cancels what it
sent and now and then writes garbage. :func:`perturbations` draws such mishaps for a given script as a
list of small operations (:class:`Delay`, :class:`Swap`, :class:`Duplicate`, :class:`Drop`,
:class:`InjectCancel`, :class:`InjectMalformed`); :func:`apply` plays them on the script. Operations are
frozen dataclasses with plain reprs and name entries by index, so hypothesis shrinks a failure to the
few operations that matter, and :func:`perturbed_toml` turns the result into a scenario file that
``vcran run`` re-runs. :func:`fleets` draws small generated scenarios (robots, stations, tasks) as the
plain data that :func:`vcran.io.scenario_file.parse` reads.

Example, a property of your own over perturbed versions of a scenario::

    from hypothesis import given, strategies as st
    from vcran.io.scenario_file import load
    from vcran.testing.scripts import perturbations, perturbed_toml

    base = load("scenarios/demo.toml")

    @given(perturbations(list(base.messages()), robots=["robot_1"]))
    def test_my_property(ops):
        text = perturbed_toml(base, ops)   # a scenario file: run it, check what you care about
"""

from __future__ import annotations

import tomllib
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

from vcran.testing._extra import require_hypothesis

require_hypothesis(__name__)

from hypothesis import strategies as st

from vcran.core.opil import build
from vcran.core.opil.messages import ActionAssignment, CancelTask, MotionAssignment
from vcran.core.scenario import Scenario, ScriptEntry
from vcran.io.scenario_file import parse
from vcran.io.scenario_toml import dumps, name_of, scenario_dict
from vcran.testing.delivery import Delay, Drop, Duplicate, Swap
from vcran.testing.plans import KINDS

# --- perturbations ------------------------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class InjectCancel:
    """A cancel_order for ``task`` at ``t``; naming a ``motion`` or ``action`` makes it partial (R8)."""

    t: float
    robot: str
    task: str
    motion: str | None = None
    action: str | None = None


@dataclass(frozen=True, slots=True)
class InjectMalformed:
    """A payload for ``attribute`` at ``t`` that no decoder accepts (R12)."""

    t: float
    robot: str
    attribute: str
    payload: Any


Perturbation = Delay | Swap | Duplicate | Drop | InjectCancel | InjectMalformed

#: Payloads that are wrong in shape, type or content, whatever the rendering (R12).
def _nested(depth: int) -> Any:
    value: Any = 0
    for _ in range(depth):
        value = [value]
    return value


def _near_valid() -> tuple[Any, ...]:
    """Real encodings of valid messages with one field broken: what a buggy fleet manager sends."""
    from vcran.core.opil.codec import encode_attribute

    def motion(mutate: Any) -> Any:
        attr = encode_attribute("motion_assignment", build.motion("M", "M_m1", 1, 2, 1.0, 2.0))
        mutate(attr["value"])
        return attr

    def set_path(*path: str, to: Any) -> Any:
        def mutate(value: Any) -> None:
            for key in path[:-1]:
                value = value[key]["value"] if isinstance(value[key], dict) and "value" in value[key] else value[key]
            value[path[-1]] = to
        return mutate

    return (
        motion(set_path("point", "x", to={"type": "number", "value": float("nan")})),
        motion(set_path("point", "x", to={"type": "string", "value": "1.0"})),
        motion(set_path("sequence", "sequence_number", to={"type": "number", "value": 3})),
        motion(set_path("task_id", "uuid", to={"type": "array", "value": [{"type": "number", "value": 1}] * 15})),
        motion(set_path("task_id", "uuid", to={"type": "array", "value": [{"type": "number", "value": 256}] * 16})),
        motion(lambda value: value.pop("sequence")),
    )


#: Payloads the RAN must reject (R12) without crashing, recording them exactly for replay (docs/contract.md §6): wrong
#: shapes, values no message can hold (NaN, a 100-digit integer, nesting deeper than orjson writes),
#: and near-valid encodings with one field broken.
MALFORMED: tuple[Any, ...] = (
    "garbage",
    42,
    [],
    {},
    {"type": "mars_agent_physical_robot_msgs.MotionAssignment", "value": {"task_id": 7}},
    {"type": "mars_agent_physical_robot_msgs.CancelTask", "value": {"task_id": {"uuid": [1, 2, 3]}}},
    {"type": "x", "value": float("nan")},
    {"type": "x", "value": {"task_id": 10**100}},
    {"type": "x", "value": _nested(300)},
    *_near_valid(),
)


def apply(entries: Sequence[ScriptEntry], ops: Sequence[Perturbation]) -> list[ScriptEntry]:
    """Play ``ops`` in order on a copy of ``entries``; indexes wrap, so every op applies to something.

    The result is in time order, equal times in list order (as a scenario file's script is).
    """
    out = list(entries)
    for op in ops:
        if isinstance(op, InjectCancel):
            c = build.cancel(op.task, motion=op.motion, action=op.action)
            out.append(ScriptEntry(op.t, op.robot, "cancel_order", c))
            continue
        if isinstance(op, InjectMalformed):
            out.append(ScriptEntry(op.t, op.robot, op.attribute, raw=op.payload))
            continue
        if not out:
            continue
        i = op.index % len(out)
        if isinstance(op, Delay):
            out[i] = replace(out[i], t=out[i].t + op.by)
        elif isinstance(op, Swap):
            j = min(i + op.offset, len(out) - 1)
            out[i], out[j] = replace(out[i], t=out[j].t), replace(out[j], t=out[i].t)
        elif isinstance(op, Duplicate):
            out.append(replace(out[i], t=out[i].t + op.after))
        else:
            del out[i]
    return sorted(out, key=lambda e: e.t)


def task_robots(entries: Sequence[ScriptEntry]) -> list[tuple[str, str]]:
    """(task name, robot) of a script's messages, in order of first appearance."""
    pairs: dict[tuple[str, str], None] = {}
    for e in entries:
        if isinstance(e.message, (MotionAssignment, ActionAssignment, CancelTask)):
            pairs.setdefault((name_of(e.message.task_id), e.robot))
    return list(pairs)


def assignment_names(entries: Sequence[ScriptEntry], kind: type[MotionAssignment | ActionAssignment]) -> list[str]:
    """Motion (or action) ids of a script, in order of first appearance."""
    names: dict[str, None] = {}
    for e in entries:
        if isinstance(e.message, MotionAssignment) and kind is MotionAssignment:
            names.setdefault(name_of(e.message.motion_id))
        elif isinstance(e.message, ActionAssignment) and kind is ActionAssignment:
            names.setdefault(name_of(e.message.action_id))
    return list(names)


def own_assignments(entries: Sequence[ScriptEntry]) -> list[tuple[str, str, str, str]]:
    """``(task, robot, "motion" | "action", id)`` of every assignment of a script, in order of first
    appearance: what a partial cancel (R13) of the task's own assignments may name."""
    found: dict[tuple[str, str, str, str], None] = {}
    for e in entries:
        m = e.message
        if isinstance(m, MotionAssignment):
            found.setdefault((name_of(m.task_id), e.robot, "motion", name_of(m.motion_id)))
        elif isinstance(m, ActionAssignment):
            found.setdefault((name_of(m.task_id), e.robot, "action", name_of(m.action_id)))
    return list(found)


def perturbations(
    entries: Sequence[ScriptEntry],
    robots: Sequence[str],
    *,
    window: int = 3,
    horizon: float | None = None,
    malformed: bool = True,
    max_ops: int = 8,
) -> st.SearchStrategy[list[Perturbation]]:
    """Lists of up to ``max_ops`` perturbations of ``entries`` (module docstring).

    ``window`` bounds how far a swap reorders; ``horizon`` (default: the last entry's time plus
    20 s) bounds when injected messages arrive; ``malformed`` adds undecodable payloads (R12).
    """
    n = max(len(entries), 1)
    end = horizon if horizon is not None else max((e.t for e in entries), default=0.0) + 20.0
    times = st.integers(0, int(end * 2)).map(lambda k: k / 2)
    delays = st.sampled_from([0.5, 1.0, 2.0, 5.0, 15.0, 45.0])
    # a cancel goes to the robot that has the task (else it is just an unknown task), or is for a ghost
    targets = st.sampled_from(task_robots(entries) + [("ghost", r) for r in robots])
    motions = st.sampled_from(assignment_names(entries, MotionAssignment) or ["ghost_m1"])
    actions = st.sampled_from(assignment_names(entries, ActionAssignment) or ["ghost_a1"])
    index = st.integers(0, n - 1)
    ops: list[st.SearchStrategy[Any]] = [
        st.builds(Delay, index, delays),
        st.builds(Swap, index, st.integers(1, max(window, 1))),
        st.builds(Duplicate, index, st.sampled_from([0.0, 0.5, 3.0, 40.0])),
        st.builds(Drop, index),
        st.builds(lambda t, to: InjectCancel(t, to[1], to[0]), times, targets),
        st.builds(lambda t, to, m: InjectCancel(t, to[1], to[0], motion=m), times, targets, motions),
        st.builds(lambda t, to, a: InjectCancel(t, to[1], to[0], action=a), times, targets, actions),
    ]
    own = own_assignments(entries)
    if own:  # R13 proper: a partial cancel naming an assignment of its own task
        ops.append(st.builds(lambda t, x: InjectCancel(t, x[1], x[0], **{x[2]: x[3]}), times, st.sampled_from(own)))
    if malformed:
        ops.append(st.builds(InjectMalformed, times, st.sampled_from(list(robots)),
                             st.sampled_from(["motion_assignment", "action_assignment", "cancel_order"]),
                             st.sampled_from(MALFORMED)))
    return st.lists(st.one_of(ops), max_size=max_ops)


def perturbed_toml(base: Scenario, ops: Sequence[Perturbation], header: str = "") -> str:
    """``base`` with its script perturbed by ``ops``, as a scenario file (cycles expanded). A message
    delayed or repeated past the run's end never arrives (a scenario file may not send it then)."""
    end = base.settings.duration
    entries = [e for e in apply(list(base.messages()), ops) if end is None or e.t <= end]
    return dumps(scenario_dict(base, entries), header)


def load_text(text: str, source: str = "<fuzz>") -> Scenario:
    return parse(tomllib.loads(text), source)


# --- generated fleets ---------------------------------------------------------------------------------------


@st.composite
def fleets(draw: st.DrawFn, max_robots: int = 3, max_tasks: int = 4) -> dict[str, Any]:
    """A small scenario as plain data: 1..``max_robots`` robots, a few stations, a few tasks each.

    Robots may lack an action (a failed action, docs/contract.md §4); stations may hold or produce parts, so loads and
    unloads succeed or fail; tasks arrive one message at a time or all at once. The run stops when idle.
    """
    n = draw(st.integers(1, max_robots))
    robots: list[dict[str, Any]] = []
    for i in range(1, n + 1):
        robots.append({
            "id": f"robot_{i}", "pose": [0.0, 3.0 * (i - 1), 0.0],
            "max_velocity": draw(st.sampled_from([0.5, 1.0, 2.0])),
            "max_acceleration": draw(st.sampled_from([0.0, 0.5])),
            "max_angular_velocity": draw(st.sampled_from([0.0, 1.0])),
            "actions": draw(st.sampled_from([list(KINDS), ["dummy", "load"]])),
        })
    stations = []
    for j in range(1, draw(st.integers(0, 3)) + 1):
        stations.append({
            "id": f"s{j}", "position": [float(draw(st.integers(-4, 4))), float(draw(st.integers(-4, 4)))],
            "reach": 1.5, "parts": draw(st.integers(0, 2)), "produce_every": draw(st.sampled_from([0.0, 10.0])),
        })
    point = st.tuples(st.integers(-4, 4), st.integers(-4, 4)).map(lambda p: [float(p[0]), float(p[1])])
    script = []
    for r in robots:
        t = 0.0
        for k in range(1, draw(st.integers(1, max_tasks)) + 1):
            path = draw(st.lists(point, max_size=3))
            actions = draw(st.lists(st.sampled_from(KINDS), min_size=0 if path else 1, max_size=2))
            t += draw(st.sampled_from([0.0, 0.5, 1.0, 4.0]))
            script.append({"t": t, "robot": r["id"], "kind": "task", "task": f"{r['id'][-1]}t{k}",
                           "path": path, "actions": actions, "every": draw(st.sampled_from([0.0, 0.5, 1.0]))})
    return {
        "simulation": {
            "name": "fuzz", "until_idle": True, "duration": 5000.0,
            "task_timeout": draw(st.sampled_from([5.0, 30.0])),
            "history_limit": draw(st.sampled_from([3, 10_000])),
            "action_durations": {"dummy": 0.5, "load": 1.0, "unload": 1.5},
        },
        "robots": robots,
        "stations": stations,
        "script": script,
    }
