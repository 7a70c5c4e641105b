"""The rules of a scenario's safety fields and deadlock settings (docs/contract.md §12): ``[traffic]`` and ``[robots.field]``.

A field's own rules (:data:`FIELD`) are those of :class:`vcran.core.traffic.fields.FieldSpec`, told with the
field's path (``robots[1].field.margin``) rather than raised; :data:`TRAFFIC` holds the fleet's settings. What
relates them: a deadlock bound or ``on_deadlock`` means nothing when no robot has a field (nothing can
block), which is a mistake worth a line rather than a run that silently never blocks.
"""

from __future__ import annotations

from typing import Any

from vcran.core.scenario import RobotConfig, Scenario
from vcran.core.traffic.fields import FieldSpec
from vcran.core.traffic.settings import DEADLOCK_ACTIONS, TrafficSettings
from vcran.core.validity.fields import Flag, Number, OneOf, Problem, Rule, fields

FIELD: dict[str, Rule] = {
    "margin": Number(minimum=0.0),
    "reaction": Number(minimum=0.0),
    "braking": Flag(),
    "side": Number(minimum=0.0),
}
TRAFFIC: dict[str, Rule] = {
    "deadlock_bound": Number(positive=True, absent=None),
    "on_deadlock": OneOf(DEADLOCK_ACTIONS, "on_deadlock"),
}


def traffic_problems(sc: Scenario, fields_too: bool = True) -> list[Problem]:
    """The problems of ``[traffic]`` and of each robot's ``[robots.field]``, then of how they relate."""
    out = []
    for i, r in enumerate(sc.robots):
        if isinstance(r, RobotConfig) and r.field is not None:
            out += field_problems(r.field, f"robots[{i}].field", fields_too)
    t = sc.traffic
    if not isinstance(t, TrafficSettings):
        return [*out, Problem("traffic", f"expected a TrafficSettings, got {type(t).__name__}")]
    if t.field is not None:
        out += field_problems(t.field, "traffic.field", fields_too)
    if fields_too:
        out += fields(t, "traffic", TRAFFIC)
    if out or t.field is not None or any(isinstance(r, RobotConfig) and r.field is not None for r in sc.robots):
        return out
    for key, unset in (("deadlock_bound", None), ("on_deadlock", "continue")):
        if getattr(t, key) != unset:
            out.append(Problem(f"traffic.{key}", "no robot has a protective field ([traffic.field] or "
                                                 "[robots.field]), so none can block or deadlock (docs/contract.md §12)"))
    return out


def field_problems(f: Any, where: str, fields_too: bool = True) -> list[Problem]:
    if not isinstance(f, FieldSpec):
        return [Problem(where, f"expected a FieldSpec or None, got {type(f).__name__}")]
    return fields(f, where, FIELD) if fields_too else []
