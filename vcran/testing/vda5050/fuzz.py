"""Perturbations of a VDA 5050 scenario's script, as a master and its broker perturb it (``vcran fuzz``,
docs/fuzzing.md "VDA 5050 scenarios"; the OPIL twin is :mod:`vcran.testing.scripts`).

A master re-sends (QoS 1 delivers at least once), sends late, out of order or not at all; it sends order
updates with a stale, equal or skipped orderUpdateId, cancels and pauses at any moment, and now and then
writes garbage. :func:`perturbations` draws such mishaps for a script as a list of small frozen operations
(:class:`Delay`, :class:`Swap`, :class:`Duplicate`, :class:`Drop` of :mod:`vcran.testing.delivery`, and
:class:`Resend`, :class:`Instant`, :class:`Malformed`) that name entries by index, so hypothesis shrinks a failure to the few that matter.

They are played on the script as its ``[[script]]`` tables (the messages without their headers): the
scenario loader stamps every message again, ``headerId`` counting in the order they are now sent (§6.4), and
checks it against the vehicle's version's schema, so every perturbed script is one ``vcran run`` plays.
:func:`vcran.testing.vda5050_runs.perturbed_toml` writes it as a scenario file (there, as the shared files
module still imports OPIL's, which this package may not).
"""

from __future__ import annotations

import copy
import json
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from vcran.testing._extra import require_hypothesis

require_hypothesis(__name__)

from hypothesis import strategies as st

from vcran.core.scenario import Scenario
from vcran.testing.delivery import Delay, Drop, Duplicate, Swap

Table = dict[str, Any]


@dataclass(frozen=True, slots=True)
class Resend:
    """The order at entry ``index`` (else the next order after it) is sent again ``after`` seconds later with
    its orderUpdateId moved by ``update`` (at least 0): lower is stale (§6.6.4.3), higher an update whose
    first node is the order's first (accepted only where the vehicle stands there, Figure 8 (7), (8))."""

    index: int
    after: float
    update: int


@dataclass(frozen=True, slots=True)
class Instant:
    """An instantActions message with one ``action_type`` (blocking NONE) for ``robot`` at ``t``."""

    t: float
    robot: str
    action_type: str


@dataclass(frozen=True, slots=True)
class Malformed:
    """A payload on ``topic`` for ``robot`` at ``t``, sent as it is: the vehicle refuses it (§6.6.4.1)."""

    t: float
    robot: str
    topic: str
    payload: str


Perturbation = Delay | Swap | Duplicate | Drop | Resend | Instant | Malformed

#: Instant actions a master sends at any moment (§6.8): the vehicle performs, refuses or fails each by its rules.
INSTANT_TYPES = ("cancelOrder", "startPause", "stopPause", "stateRequest", "factsheetRequest")
#: Payloads wrong in shape, type or content; near-valid ones are built from the script's own orders.
GARBAGE = ("garbage", "42", "[]", "{}", '{"orderId": 7}', '{"actions": "cancelOrder"}', "[" * 300 + "]" * 300,
           '{"headerId": 1e400}', '{"x": NaN}')


def near_valid(tables: Sequence[Table], base: Scenario) -> list[str]:
    """The script's first order, headed as a master heads it, with one field broken each (§6.6.4.1)."""
    order = next((t for t in tables if t.get("kind") == "order" and "message" in t), None)
    if order is None:
        return []
    robot = next(r for r in base.robots if r.id == order["robot"])
    _, manufacturer, serial, version = robot.vda5050_identity
    head = {"headerId": 0, "timestamp": "1970-01-01T00:00:00.00Z", "version": version, "manufacturer": manufacturer,
            "serialNumber": serial}

    def broken(change: Any) -> str:
        message = copy.deepcopy({**head, **order["message"]})
        change(message)
        return json.dumps(message)

    def set_first_node(key: str, value: Any) -> Any:
        return lambda m: m["nodes"][0].__setitem__(key, value)

    return [
        broken(lambda m: m.__setitem__("nodes", [])),
        broken(lambda m: m.pop("edges")),
        broken(lambda m: m.__setitem__("orderUpdateId", -1)),
        broken(lambda m: m.__setitem__("orderUpdateId", "1")),
        broken(set_first_node("sequenceId", 1)),
        broken(set_first_node("released", "yes")),
        broken(lambda m: m.__setitem__("version", "9.9.9")),
    ]


def apply(tables: Sequence[Table], ops: Sequence[Perturbation]) -> list[Table]:
    """Play ``ops`` in order on a copy of ``tables``; indexes wrap, so every op applies to something. The
    result is in time order, equal times in list order (as a scenario file's script is)."""
    out = [dict(t) for t in tables]
    for op in ops:
        if isinstance(op, Instant):
            action = {"actionType": op.action_type, "actionId": f"fuzz_{op.action_type}_{op.t:g}",
                      "blockingType": "NONE"}
            out.append({"t": op.t, "robot": op.robot, "kind": "instantActions", "message": {"actions": [action]}})
            continue
        if isinstance(op, Malformed):
            out.append({"t": op.t, "robot": op.robot, "kind": op.topic, "payload": op.payload})
            continue
        if not out:
            continue
        i = op.index % len(out)
        if isinstance(op, Delay):
            out[i] = {**out[i], "t": out[i]["t"] + op.by}
        elif isinstance(op, Swap):
            j = min(i + op.offset, len(out) - 1)
            out[i], out[j] = {**out[i], "t": out[j]["t"]}, {**out[j], "t": out[i]["t"]}
        elif isinstance(op, Duplicate):
            out.append({**out[i], "t": out[i]["t"] + op.after})
        elif isinstance(op, Resend):
            k = next((k for k in [*range(i, len(out)), *range(i)]
                      if out[k].get("kind") == "order" and "message" in out[k]), None)
            if k is not None:
                message = {**out[k]["message"], "orderUpdateId": max(out[k]["message"]["orderUpdateId"] + op.update, 0)}
                out.append({**out[k], "t": out[k]["t"] + op.after, "message": message})
        else:
            del out[i]
    return sorted(out, key=lambda t: t["t"])


def perturbations(base: Scenario, tables: Sequence[Table], *, window: int = 3, max_ops: int = 8,
                  horizon: float | None = None) -> st.SearchStrategy[list[Perturbation]]:
    """Lists of up to ``max_ops`` perturbations of ``base``'s script, given as its ``tables`` (module
    docstring). ``window`` bounds how far a swap reorders; ``horizon`` (default: the last message's time
    plus 20 s) when injected messages arrive."""
    robots = [r.id for r in base.robots]
    end = horizon if horizon is not None else max((t["t"] for t in tables), default=0.0) + 20.0
    times = st.integers(0, int(end * 2)).map(lambda k: k / 2)
    delays = st.sampled_from([0.5, 1.0, 2.0, 5.0, 15.0, 45.0])
    index = st.integers(0, max(len(tables), 1) - 1)
    robot = st.sampled_from(robots)
    payloads = st.sampled_from([*GARBAGE, *near_valid(tables, base)])
    ops: list[st.SearchStrategy[Any]] = [
        st.builds(Delay, index, delays),
        st.builds(Swap, index, st.integers(1, max(window, 1))),
        st.builds(Duplicate, index, st.sampled_from([0.0, 0.5, 3.0, 40.0])),
        st.builds(Drop, index),
        st.builds(Resend, index, st.sampled_from([0.0, 0.5, 2.0, 5.0, 15.0]), st.sampled_from([-1, 1, 2])),
        st.builds(Instant, times, robot, st.sampled_from(INSTANT_TYPES)),
        st.builds(Malformed, times, robot, st.sampled_from(["order", "instantActions"]), payloads),
    ]
    return st.lists(st.one_of(ops), max_size=max_ops)
