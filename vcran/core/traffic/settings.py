"""A scenario's traffic settings (docs/contract.md §12, ``[traffic]``): the fleet's protective field, the deadlock bound,
and what a deadlock does. Plain data for :class:`vcran.core.scenario.Scenario`; the rules are
:mod:`vcran.core.validity.safety`'s, the simulation's part :mod:`vcran.sim.traffic`'s."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any, Protocol

from vcran.core.traffic.fields import FieldSpec

#: ``on_deadlock =``: the run goes on, or the deadlocked robots' tasks are cancelled (reason ``deadlock``).
DEADLOCK_ACTIONS = ("continue", "cancel")


class _Robot(Protocol):
    @property
    def field(self) -> FieldSpec | None: ...


@dataclass(frozen=True, slots=True)
class TrafficSettings:
    """``[traffic]`` (docs/robots.md "Traffic"): the fleet's protective field, for every robot without a
    ``[robots.field]`` of its own (None: no field, and robots drive through each other as before); how long a
    robot may stay blocked before it counts as deadlocked (None: only cycles do); and what a deadlock does."""

    field: FieldSpec | None = None
    deadlock_bound: float | None = None
    on_deadlock: str = "continue"

    def field_of(self, robot: _Robot) -> FieldSpec | None:
        """``robot``'s protective field: its own, else the fleet's (None: it has none)."""
        return robot.field if robot.field is not None else self.field

    def any_field(self, robots: Iterable[_Robot]) -> bool:
        """Some robot has a protective field: robots brake for one another."""
        return self.field is not None or any(r.field is not None for r in robots)

    def as_dict(self) -> dict[str, Any] | None:
        """``[traffic]`` as a file writes it; None for the default (no table: older trace headers stay as they
        were)."""
        if self == TrafficSettings():
            return None
        out: dict[str, Any] = {"field": self.field.as_dict() if self.field is not None else None,
                               "deadlock_bound": self.deadlock_bound}
        if self.on_deadlock != "continue":
            out["on_deadlock"] = self.on_deadlock
        return out
