"""The errors a vcran vehicle reports in ``state.errors`` (§6.10.5), and how long each stays.

Two lifetimes (docs/vda5050.md lists every type with its cause):

- *warnings about a message or an action*: a refused order (``validationError``, ``orderError``,
  ``orderUpdateError``, §6.6.4: "The warning shall be reported until the vehicle has accepted a new
  order"), a refused instant action (``noOrderToCancel``, ``instantActionError``), a failed action
  (``actionFailed``), an order the vehicle had to give up (``motionFailed``, ``collision``). They stay
  until an order or order update is accepted; the same warning twice is listed once, and at most
  :data:`WARNINGS` are kept (the oldest go first), so a master that floods a vehicle with bad orders
  does not grow its state without bound;
- *conditions*: ``batteryLow`` (WARNING), ``batteryEmpty`` and ``breakdown`` (FATAL, "the AGV is not in
  running condition, user intervention required"), reported while they last.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import replace

from vcran.core.vda5050.enums import ErrorLevel, Version
from vcran.core.vda5050.state import Error, ErrorReference

VALIDATION = "validationError"
ORDER = "orderError"
ORDER_UPDATE = "orderUpdateError"
NO_ORDER_TO_CANCEL = "noOrderToCancel"
INSTANT_ACTION = "instantActionError"
ACTION_FAILED = "actionFailed"
MOTION_FAILED = "motionFailed"
COLLISION = "collision"
BATTERY_LOW = "batteryLow"
BATTERY_EMPTY = "batteryEmpty"
BREAKDOWN = "breakdown"

#: How many warnings ``state.errors`` keeps at most.
WARNINGS = 32


def error(error_type: str, description: str, references: Iterable[tuple[str, str | int]] = (),
          level: ErrorLevel = ErrorLevel.WARNING, hint: str | None = None) -> Error:
    refs = tuple(ErrorReference(reference_key=k, reference_value=str(v)) for k, v in references)
    return Error(error_type=error_type, error_references=refs or None, error_description=description,
                 error_hint=hint, error_level=level)


class ErrorBook:
    """The active errors of one vehicle, in the order they were raised (conditions first)."""

    def __init__(self, version: Version) -> None:
        self._hints = version.at_least(Version.V2_1_0)  # errorHint exists from 2.1.0 on
        self._warnings: dict[Error, None] = {}
        self._conditions: dict[str, Error] = {}
        self._listed: tuple[Error, ...] | None = ()

    def warn(self, e: Error) -> Error | None:
        """Add warning ``e``; returns it as listed, or None if the same warning is listed already."""
        e = self._fit(e)
        if e in self._warnings:
            return None
        self._warnings[e] = None
        while len(self._warnings) > WARNINGS:
            del self._warnings[next(iter(self._warnings))]
        self._listed = None
        return e

    def clear_warnings(self) -> list[Error]:
        """An order was accepted: the warnings go (the conditions stay)."""
        gone = list(self._warnings)
        if gone:
            self._warnings.clear()
            self._listed = None
        return gone

    def set_condition(self, e: Error) -> Error | None:
        """Report condition ``e`` (keyed by its type) while it lasts; None if it is reported already."""
        e = self._fit(e)
        if self._conditions.get(e.error_type) == e:
            return None
        self._conditions[e.error_type] = e
        self._listed = None
        return e

    def clear_condition(self, error_type: str) -> Error | None:
        gone = self._conditions.pop(error_type, None)
        if gone is not None:
            self._listed = None
        return gone

    def fatal(self) -> Error | None:
        """The first FATAL error, if any: the vehicle takes no new order while one is reported."""
        return next((e for e in self._conditions.values() if e.error_level is ErrorLevel.FATAL), None)

    def has(self, error_type: str) -> bool:
        return error_type in self._conditions or any(e.error_type == error_type for e in self._warnings)

    def listed(self) -> tuple[Error, ...]:
        if self._listed is None:
            self._listed = (*self._conditions.values(), *self._warnings)
        return self._listed

    def _fit(self, e: Error) -> Error:
        if e.error_hint is not None and not self._hints:
            return replace(e, error_hint=None)
        return e
