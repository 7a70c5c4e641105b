"""Write scenarios back as TOML: the inverse of :func:`vcran.io.scenario_file.parse` for what a script holds.

``vcran fuzz`` prints the shrunk script that broke a rule as a scenario file that ``vcran run`` re-runs,
and builds every variant it runs from that same text, so what a user re-runs is exactly what failed.
Script entries become ``motion``, ``action``, ``cancel`` and ``raw`` tables (a VDA 5050 scenario's
``order`` and ``instantActions``, their headers left for the reader to stamp); the fleet comes from
:meth:`Scenario.fleet_dict`. A message whose fields a scenario file cannot express (a ``point_id`` that
differs from its ``motion_id``, a header frame, action attributes, ...) raises :class:`ValueError`
naming the field, rather than being written differently from what it is.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterable
from datetime import datetime
from typing import Any

from vcran.core.opil.build import CATEGORY_OF
from vcran.core.opil.ids import Id, id_for
from vcran.core.opil.messages import ActionAssignment, CancelTask, MotionAssignment
from vcran.core.scenario import VDA5050_TOPICS, RobotConfig, Scenario, ScriptEntry
from vcran.core.vda5050.enums import Version
from vcran.core.vda5050.header import epoch_of
from vcran.io.scenario_vda5050 import HEADER, header


def scenario_dict(scenario: Scenario, script: Iterable[ScriptEntry]) -> dict[str, Any]:
    """``scenario``'s fleet and settings with ``script`` (in time order) as its message script, as parse()
    reads it. A VDA 5050 message is written without its header, which the reader stamps again: one whose
    header is not the one the reader would stamp raises :class:`ValueError`."""
    data = scenario.fleet_dict()
    vehicles = {r.id: r for r in scenario.robots}
    epoch = epoch_of(scenario.settings.epoch)
    counts: dict[tuple[str, str], int] = {}
    tables = []
    for e in script:
        if e.attribute in VDA5050_TOPICS and e.message is not None:
            n = counts.get((e.robot, e.attribute), 0)
            counts[(e.robot, e.attribute)] = n + 1
            tables.append(_vda5050_message(e, vehicles.get(e.robot), n, epoch))
        else:
            tables.append(entry_table(e))
    data["script"] = tables
    return data


def loop_dict(scenario: Scenario) -> dict[str, Any]:
    """A closed-loop scenario (docs/contract.md §9) as parse() reads it: the fleet, its listed jobs, its job stream,
    the link and the fleet manager. ``vcran fuzz --manager`` saves a shrunk failing scenario this way."""
    data = scenario.fleet_dict()
    if scenario.manager is not None:
        data["manager"] = {"class": scenario.manager.path, "options": dict(scenario.manager.options)}
    data["link"] = scenario.link.as_dict()
    s = scenario.job_stream
    if s is not None:
        data["job_stream"] = {
            "rate": s.rate, "until": s.until, "start": s.start, "seed": s.seed, "prefix": s.prefix,
            "priority": s.priority, "pickup": dict(s.pickups), "dropoff": dict(s.dropoffs),
            **({"deadline_after": s.deadline_after} if s.deadline_after is not None else {}),
        }
    if scenario.jobs:
        data["jobs"] = [{"t": j.t, "id": j.id, "pickup": j.pickup, "dropoff": j.dropoff, "priority": j.priority,
                         **({"deadline": j.deadline} if j.deadline is not None else {})} for j in scenario.jobs]
    return data


def entry_table(e: ScriptEntry) -> dict[str, Any]:
    """One script entry as a ``[[script]]`` table (a VDA 5050 message only through :func:`scenario_dict`,
    which knows its header)."""
    head: dict[str, Any] = {"t": e.t, "robot": e.robot}
    m = e.message
    if m is None and e.attribute in VDA5050_TOPICS:
        return {**head, "kind": e.attribute, "payload": e.raw}
    if m is None:
        return {**head, "kind": "raw", "attribute": e.attribute, "value": json.dumps(e.raw, ensure_ascii=False)}
    if isinstance(m, MotionAssignment):
        return {**head, **_motion(m, e.t)}
    if isinstance(m, ActionAssignment):
        return {**head, **_action(m)}
    if isinstance(m, CancelTask):
        return {**head, **_cancel(m)}
    raise ValueError(f"a script cannot hold {type(m).__name__}")


def _vda5050_message(e: ScriptEntry, vehicle: RobotConfig | None, n: int, epoch: datetime) -> dict[str, Any]:
    """A VDA 5050 script message (``n``-th of its robot and topic; on the scenario's calendar, ``epoch``) as its
    ``[[script]]`` table."""
    from vcran.core.vda5050.codec import to_plain

    if vehicle is None:
        raise ValueError(f"a script message for {e.robot!r}, which is no robot of the scenario")
    plain = to_plain(e.message, Version(vehicle.vda5050_identity[3]))
    stamped = {key: plain.pop(key, None) for key in HEADER}
    expected = header(vehicle, n, e.t, epoch)
    _require(stamped == expected, "header", f"vcran stamps {expected}, the message has {stamped}")
    return {"t": e.t, "robot": e.robot, "kind": e.attribute, "message": plain}


def name_of(ident: Id) -> str:
    """The scenario name that maps back to ``ident`` (its description), else its canonical uuid."""
    if ident.description and id_for(ident.description) == ident:
        return ident.description
    return ident.canonical


def _motion(m: MotionAssignment, t: float) -> dict[str, Any]:
    seq, length = m.sequence.sequence_number, m.sequence.length
    _require(m.point_id == m.motion_id, "point_id", "must equal motion_id")
    _require(m.header.seq == 0 and m.header.frame_id == "", "header", "only the stamp may be set")
    _require(m.max_velocity.linear.y == m.max_velocity.linear.z == 0.0 and m.max_velocity.angular.x
             == m.max_velocity.angular.y == m.max_velocity.angular.z == 0.0, "max_velocity", "only linear.x")
    _require(m.max_acceleration.linear.y == m.max_acceleration.linear.z == 0.0 and m.max_acceleration.angular.x
             == m.max_acceleration.angular.y == m.max_acceleration.angular.z == 0.0,
             "max_acceleration", "only linear.x")
    _require(m.motion_area.header.seq == 0 and m.motion_area.header.frame_id == "" and
             m.motion_area.header.stamp.secs == m.motion_area.header.stamp.nsecs == 0 and
             all(p.z == 0.0 for p in m.motion_area.polygon.points), "motion_area", "only x, y points")
    out: dict[str, Any] = {
        "kind": "motion", "task": name_of(m.task_id), "id": name_of(m.motion_id), "seq": [seq, length],
        "point": [m.point.x, m.point.y, m.point.theta],
    }
    if m.use_orientation:
        out["use_orientation"] = True
    if m.is_waypoint != (seq < length):
        out["is_waypoint"] = m.is_waypoint
    if m.max_velocity.linear.x:
        out["max_velocity"] = m.max_velocity.linear.x
    if m.max_acceleration.linear.x:
        out["max_acceleration"] = m.max_acceleration.linear.x
    if m.motion_area.polygon.points:
        out["area"] = [[x, y] for x, y in m.motion_area.xy()]
    return out


def _action(a: ActionAssignment) -> dict[str, Any]:
    ra = a.robot_action
    _require(ra.attributes == () and ra.description == "", "robot_action", "attributes and description must be empty")
    out: dict[str, Any] = {
        "kind": "action", "task": name_of(a.task_id), "id": name_of(a.action_id),
        "seq": [a.sequence.sequence_number, a.sequence.length],
    }
    if ra.action == 0 and ra.category == CATEGORY_OF.get(a.kind):
        out["action"] = a.kind.value
    else:
        out["category"], out["code"] = ra.category, ra.action
    return out


def _cancel(c: CancelTask) -> dict[str, Any]:
    out: dict[str, Any] = {"kind": "cancel", "task": name_of(c.task_id)}
    if not c.motion_id.is_unused:  # unused ids are written as OPIL's "not supported" (R8: same meaning)
        out["motion"] = name_of(c.motion_id)
    if not c.action_id.is_unused:
        out["action"] = name_of(c.action_id)
    return out


def _require(ok: bool, field: str, problem: str) -> None:
    if not ok:
        raise ValueError(f"a scenario file cannot express this {field}: {problem}")


# --- a TOML writer for scenario data ------------------------------------------------------------------------


def dumps(data: dict[str, Any], header: str = "") -> str:
    """TOML for scenario data: tables, arrays of tables, strings, numbers, booleans and arrays of them."""
    lines = [f"# {line}" if line else "#" for line in header.splitlines()]
    _table(lines, [], data)
    return "\n".join(lines).lstrip("\n") + "\n"


def _table(lines: list[str], path: list[str], data: dict[str, Any]) -> None:
    for k, v in data.items():
        if not isinstance(v, dict) and not _is_table_array(v):
            lines.append(f"{k} = {_value(v)}")
    for k, v in data.items():
        if isinstance(v, dict):
            lines += ["", f"[{'.'.join(path + [k])}]"]
            _table(lines, path + [k], v)
    for k, v in data.items():
        if _is_table_array(v):
            for item in v:
                lines += ["", f"[[{'.'.join(path + [k])}]]"]
                _table(lines, path + [k], item)


def _is_table_array(v: Any) -> bool:
    return isinstance(v, list) and bool(v) and all(isinstance(x, dict) for x in v)


def _value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        return repr(v)  # inf, -inf and exponents are TOML as Python writes them
    if isinstance(v, str):
        return json.dumps(v, ensure_ascii=False).replace("\x7f", "\\u007f")
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    raise TypeError(f"no TOML form for {type(v).__name__}")
