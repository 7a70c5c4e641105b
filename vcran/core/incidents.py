"""What happens to a robot on its own (docs/contract.md §4, §12): battery, faults, collisions, blocks and deadlocks, as
events for ``events.jsonl``.

RanLogic's events (:mod:`vcran.core.opil.effects`) say what the rules did; these say what the robot went
through, and are logged by the SimPy model when it happens. Where the fleet manager would notice, the model
also publishes a ``ran_error`` (docs/robots.md lists which).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from vcran.core.events import Event


@dataclass(frozen=True, slots=True)
class BatteryLow(Event):
    NAME = "battery_low"
    charge: float
    percentage: float

    def fields(self) -> dict[str, Any]:
        return {"charge": self.charge, "percentage": self.percentage}


@dataclass(frozen=True, slots=True)
class BatteryEmpty(Event):
    """The battery ran out; the robot stopped at ``(x, y)``."""

    NAME = "battery_empty"
    x: float
    y: float

    def fields(self) -> dict[str, Any]:
        return {"x": self.x, "y": self.y}


@dataclass(frozen=True, slots=True)
class BatterySwapped(Event):
    NAME = "battery_swapped"

    def fields(self) -> dict[str, Any]:
        return {}


@dataclass(frozen=True, slots=True)
class FaultStarted(Event):
    """An injected fault; ``applied`` is false when it found nothing to act on (a motion failure at rest)."""

    NAME = "fault"
    kind: str
    duration: float = 0.0
    applied: bool = True

    def fields(self) -> dict[str, Any]:
        out: dict[str, Any] = {"kind": self.kind}
        if self.duration:
            out["duration"] = self.duration
        if not self.applied:
            out["applied"] = False
        return out


@dataclass(frozen=True, slots=True)
class FaultEnded(Event):
    """A breakdown is repaired, a link is back."""

    NAME = "fault_end"
    kind: str

    def fields(self) -> dict[str, Any]:
        return {"kind": self.kind}


@dataclass(frozen=True, slots=True)
class Collision(Event):
    """The footprints of this robot and ``other`` started to overlap, around ``(x, y)``."""

    NAME = "collision"
    other: str
    x: float
    y: float

    def fields(self) -> dict[str, Any]:
        return {"other": self.other, "x": self.x, "y": self.y}


# --- traffic (docs/contract.md §12): safety fields, blocks, deadlocks ---------------------------------------------------


@dataclass(frozen=True, slots=True)
class Blocked(Event):
    """Robot ``other`` entered this robot's empty protective field, this robot being at ``(x, y)``: it brakes."""

    NAME = "blocked"
    other: str
    x: float
    y: float

    def fields(self) -> dict[str, Any]:
        return {"other": self.other, "x": self.x, "y": self.y}


@dataclass(frozen=True, slots=True)
class Unblocked(Event):
    """The robot's field is clear again, or it was given new work or stopped from outside: it was blocked
    for ``duration`` seconds (since its ``blocked``)."""

    NAME = "unblocked"
    duration: float

    def fields(self) -> dict[str, Any]:
        return {"duration": self.duration}


@dataclass(frozen=True, slots=True)
class Deadlock(Event):
    """The robot is deadlocked (docs/contract.md §12), blocked for ``duration`` seconds by now: ``kind`` "cycle", robots
    stopped on one another (this robot, the first in fleet order, waits for the first of ``other``, each of
    ``other`` for the next, the last for this robot), or "bound", blocked for the scenario's bound (``other``:
    the robots in its field). ``other`` lists robot ids separated by ", " (ids hold no whitespace)."""

    NAME = "deadlock"
    kind: str
    other: str
    duration: float

    def fields(self) -> dict[str, Any]:
        return {"kind": self.kind, "other": self.other, "duration": self.duration}
