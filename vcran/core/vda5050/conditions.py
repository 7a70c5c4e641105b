"""What the body tells a VDA 5050 vehicle about itself (docs/contract.md §4, §12); part of
:class:`~vcran.core.vda5050.vehicle.Vehicle`.

docs/contract.md §4's faults as VDA 5050 sees them (docs/vda5050.md, "Errors"): a breakdown is a FATAL error while
it lasts and the order resumes after it; an empty battery is FATAL until the vehicle is serviced; a
motion failure and a collision are warnings; in those three halts the vehicle gives its order up. The
pause button (docs/contract.md §4's pause and resume) is the hardware side of startPause (§6.10.6 ``paused``: "either
because of the push of a physical button on the AGV or because of an instantAction"). A protective field
violation (docs/contract.md §12) is reported in ``safetyState``; the body brakes by itself.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from vcran.core.vda5050 import errors
from vcran.core.vda5050.effects import Effect, Hold, Release
from vcran.core.vda5050.enums import ErrorLevel
from vcran.core.vda5050.state import Error

if TYPE_CHECKING:
    from vcran.core.vda5050.actions import ActionBook
    from vcran.core.vda5050.effects import NodeTag
    from vcran.core.vda5050.path import Path

#: Why a body halts for good (docs/contract.md §4), and the error each is reported as.
HALTS: dict[str, tuple[str, ErrorLevel]] = {
    "battery_empty": (errors.BATTERY_EMPTY, ErrorLevel.FATAL),
    "motion_failed": (errors.MOTION_FAILED, ErrorLevel.WARNING),
    "collision": (errors.COLLISION, ErrorLevel.WARNING),
    "deadlock": ("deadlock", ErrorLevel.WARNING),  # docs/contract.md §12's on_deadlock = "cancel"
}


class ConditionsMixin:
    """The body-condition inputs of a Vehicle (the attributes below are the Vehicle's)."""

    actions: ActionBook
    errors: errors.ErrorBook
    path: Path
    route: list[NodeTag]
    order_id: str | None
    last_node_id: str
    paused: bool
    broken: bool
    out_of_service: bool
    charging: bool
    field_violation: bool
    _out: list[Effect]
    _entered: set[int]
    _active: bool
    _cancel: object

    if TYPE_CHECKING:
        def _begin(self, now: float) -> None: ...

        def _end(self) -> list[Effect]: ...

        def _advance(self, now: float) -> None: ...

        def _finish_cancel(self) -> None: ...

        def _end_order(self, how: str) -> None: ...

        def _warn(self, e: Error) -> None: ...

        def _raised(self, e: Error | None) -> None: ...

        def _cleared(self, e: Error | None) -> None: ...

    def on_halted(self, now: float, why: str, message: str = "") -> list[Effect]:
        """The body stopped for good (docs/contract.md §4): ``battery_empty``, ``motion_failed`` or ``collision``. Its
        running leg and actions are over; the order is given up: what had not ended FAILED, nodeStates and
        edgeStates emptied, orderId kept. An empty battery is FATAL until :meth:`on_serviced`."""
        self._begin(now)
        error_type, level = HALTS[why]
        refs = [("lastNodeId", self.last_node_id)]
        if self._active:
            refs.append(("orderId", self.order_id or ""))
        self.route.clear()
        self._entered.clear()
        self.actions.halt()
        self.path.clear()
        if self._cancel is not None:
            self._finish_cancel()
        if self._active:
            self._end_order(why)
        found = errors.error(error_type, message or why.replace("_", " "), refs, level)
        if level is ErrorLevel.FATAL:
            self.out_of_service = True
            self._raised(self.errors.set_condition(found))
        else:
            self._warn(found)
        self._advance(now)
        return self._end()

    def on_serviced(self, now: float) -> list[Effect]:
        """The empty battery was charged or swapped: the vehicle takes orders again."""
        self._begin(now)
        self.out_of_service = False
        self._cleared(self.errors.clear_condition(errors.BATTERY_EMPTY))
        return self._end()

    def on_breakdown(self, now: float, message: str = "") -> list[Effect]:
        """The body broke down (docs/contract.md §4): it holds where it is until :meth:`on_repaired`; FATAL meanwhile."""
        self._begin(now)
        self.broken = True
        self.actions.hold(True)
        self._raised(self.errors.set_condition(errors.error(
            errors.BREAKDOWN, message or "the vehicle broke down", [("lastNodeId", self.last_node_id)],
            ErrorLevel.FATAL)))
        return self._end()

    def on_repaired(self, now: float) -> list[Effect]:
        self._begin(now)
        self.broken = False
        self.actions.hold(self.paused)
        self._cleared(self.errors.clear_condition(errors.BREAKDOWN))
        self._advance(now)
        return self._end()

    def on_battery_low(self, now: float, low: bool) -> list[Effect]:
        """The battery fell below (``low``) or rose above the scenario's warning level (docs/contract.md §4)."""
        self._begin(now)
        if low:
            self._raised(self.errors.set_condition(errors.error(errors.BATTERY_LOW, "battery low")))
        else:
            self._cleared(self.errors.clear_condition(errors.BATTERY_LOW))
        return self._end()

    def on_charging_ended(self, now: float) -> list[Effect]:
        """The body stopped charging on its own (battery full, §6.8.1 stopCharging)."""
        self._begin(now)
        self.charging = False
        self._advance(now)
        return self._end()

    def on_field_violation(self, now: float, violated: bool) -> list[Effect]:
        """Another robot entered (left) the protective field: the body brakes (drives on) by itself
        (docs/contract.md §12); the state says ``safetyState.fieldViolation``."""
        self._begin(now)
        self.field_violation = violated
        return self._end()

    def on_pause_button(self, now: float, pressed: bool) -> list[Effect]:
        """The pause button was pressed (released): the vehicle pauses (goes on) as on startPause
        (stopPause), without an actionState (docs/contract.md §4's pause and resume faults)."""
        self._begin(now)
        self.set_paused(pressed)
        self._advance(now)
        return self._end()

    def set_paused(self, on: bool) -> None:
        """Pause mode on or off: the body holds (goes on) and running actions pause (resume) with it."""
        if on and not self.paused:
            self.paused = True
            self._out.append(Hold("pause"))
            self.actions.hold(True)
        elif not on and self.paused:
            self.paused = False
            self._out.append(Release("pause"))
            self.actions.hold(self.broken)
