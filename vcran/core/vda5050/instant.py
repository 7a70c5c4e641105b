"""Instant actions (§6.9) as a vehicle performs them; part of :class:`~vcran.core.vda5050.vehicle.Vehicle`.

Each instant action gets an actionState when it arrives. The vehicle does some itself, at once:
cancelOrder (§6.6.3), startPause/stopPause (FINISHED when the pause mode is on/off, §6.8.2),
initPosition, stateRequest, factsheetRequest; the body does the others (startCharging, stopCharging,
finePositioning, waitForTrigger, and action types the configuration adds), RUNNING until it reports. One
message's actions run in order: a stopCharging behind a startCharging still starting the charge waits for it
(:meth:`InstantActionsMixin.start_deferred`; docs/vda5050.md).

An instant action the vehicle cannot perform (an unknown type, one not usable as an instant action, a
blocking type or a parameter it does not accept, an actionId already in use) is FAILED (or, for a used
actionId, not listed at all) and reported as an ``instantActionError`` warning naming the actionId.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

from vcran.core.vda5050 import errors
from vcran.core.vda5050.actions import FAILED, FINISHED, RUNNING, WAITING, Run
from vcran.core.vda5050.codec import Invalid
from vcran.core.vda5050.config import ActionSpec
from vcran.core.vda5050.effects import Place, PublishFactsheet, Where
from vcran.core.vda5050.enums import ActionScope
from vcran.core.vda5050.order import Action
from vcran.core.vda5050.state import Error

if TYPE_CHECKING:
    from vcran.core.vda5050.actions import ActionBook
    from vcran.core.vda5050.config import VehicleConfig
    from vcran.core.vda5050.effects import Effect, NodeTag


class InstantActionsMixin:
    """The instant-action part of a Vehicle (the attributes below are the Vehicle's)."""

    config: VehicleConfig
    actions: ActionBook
    route: list[NodeTag]
    paused: bool
    broken: bool
    charging: bool
    last_node_id: str
    last_node_sequence_id: int
    _out: list[Effect]
    _deferred: list[Run]
    _forced: bool
    _odometer_at_node: float | None

    if TYPE_CHECKING:
        @property
        def executing(self) -> bool: ...

        def cancel_order(self, now: float, run: Run) -> None: ...

        def set_paused(self, on: bool) -> None: ...

        def _warn(self, e: Error) -> None: ...

    def instant(self, now: float, action: Action, where: Where) -> None:
        """Perform instant action ``action`` (module docstring)."""
        refs = [("actionId", action.action_id), ("actionType", action.action_type)]
        if self.actions.get(action.action_id) is not None:
            self._warn(errors.error(errors.INSTANT_ACTION, f"actionId {action.action_id!r} is taken by another "
                                    "action of the vehicle", refs))
            return
        spec = self.config.action(action.action_type)
        run = Run(action, ActionScope.INSTANT, -1, spec.interruptible if spec else True)
        self.actions.add(run, announce=True)
        problem = _problem(action, spec)
        if problem is not None:
            self._fail(run, problem[0], [*refs, *problem[1]])
            return
        kind = action.action_type
        if kind == "cancelOrder":
            self.cancel_order(now, run)
        elif kind in ("startPause", "stopPause"):
            self._pause(run, kind == "startPause")
        elif kind == "initPosition":
            self._init_position(run, where)
        elif kind == "stateRequest":
            self.actions.set(run, FINISHED)
            self._forced = True
        elif kind == "factsheetRequest":
            self.actions.set(run, FINISHED)
            self.publish_factsheet()
        elif kind == "stopCharging" and self._charge_starting():
            self._deferred.append(run)  # stops the charge once started: the actions in their order (§6.9)
        elif (kind == "startCharging" and self.charging) or (kind == "stopCharging" and not self.charging):
            self.actions.set(run, FINISHED)  # idempotent (§6.8.1)
        elif kind == "startCharging" and self.route:
            self._fail(run, "the vehicle charges standing, not while driving", refs)
        elif spec is not None and not spec.body:
            self._fail(run, f"{kind!r} is not an action vcran performs", refs)
        elif self.paused or self.broken or self._deferred:
            self._deferred.append(run)  # WAITING until the vehicle goes on (§6.8.2: all actions paused), in order
        else:
            self.actions.start(run)

    def start_deferred(self) -> None:
        """Start the instant actions that wait, in their order, up to a stopCharging whose startCharging is
        still starting the charge: it waits on, and those after it with it. Once the charge has started, the
        stopCharging stops it; if none started (the startCharging FAILED), it is FINISHED as any stopCharging
        while not charging (§6.8.1)."""
        waiting, self._deferred[:] = [r for r in self._deferred if r.status is WAITING], []
        for i, run in enumerate(waiting):
            if run.action.action_type == "stopCharging":
                if self._charge_starting():
                    self._deferred[:] = waiting[i:]
                    return
                if not self.charging:
                    self.actions.set(run, FINISHED)
                    continue
            self.actions.start(run)

    def _charge_starting(self) -> bool:
        """A startCharging runs: the body is starting the charge (FINISHED once it charges, §6.8.2)."""
        return any(r.status is RUNNING and r.action.action_type == "startCharging" for r in self.actions.runs.values())

    def invalid_error(self, invalid: Invalid) -> Error:
        """§6.6.4.1 ``validationError``, with the references of §7.1 that were readable."""
        refs: list[tuple[str, str | int]] = [("topic", invalid.topic.value)]
        for key, value in (("headerId", invalid.header_id), ("orderId", invalid.order_id),
                           ("orderUpdateId", invalid.order_update_id)):
            if value is not None:
                refs.append((key, value))
        refs.append(("field", invalid.path))
        return errors.error(errors.VALIDATION, f"{invalid.path}: {invalid.problem}", refs)

    def publish_factsheet(self) -> None:
        self._out.append(PublishFactsheet())

    def _fail(self, run: Run, why: str, refs: list[tuple[str, str]]) -> None:
        self.actions.set(run, FAILED)
        self._warn(errors.error(errors.INSTANT_ACTION, why, refs))

    def _pause(self, run: Run, on: bool) -> None:
        """startPause/stopPause: FINISHED once pause mode is on (off), at once (§6.8.2)."""
        self.set_paused(on)
        self.actions.set(run, FINISHED)

    def _init_position(self, run: Run, where: Where) -> None:
        """initPosition: the pose and lastNodeId are set (§6.8.2); refused while an order runs."""
        refs = [("actionId", run.id), ("actionType", "initPosition")]
        if self.route or self.executing:
            self._fail(run, "initPosition while an order runs", refs)
            return
        action = run.action
        values: dict[str, Any] = {}
        for key, kind in (("x", float), ("y", float), ("theta", float), ("mapId", str), ("lastNodeId", str)):
            value = action.parameter(key)
            ok = isinstance(value, str) if kind is str else (
                isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value))
            if not ok:
                self._fail(run, f"parameter {key} must be a {'string' if kind is str else 'number'}",
                           [*refs, ("parameter", key)])
                return
            values[key] = value
        if values["mapId"] != self.config.map_id:
            self._fail(run, f"map {values['mapId']!r} is not on the vehicle", [*refs, ("mapId", values["mapId"])])
            return
        theta = math.remainder(float(values["theta"]), math.tau)
        self._out.append(Place(float(values["x"]), float(values["y"]), theta, values["mapId"]))
        self.last_node_id, self.last_node_sequence_id = values["lastNodeId"], 0
        self._odometer_at_node = where.odometer
        self.actions.set(run, FINISHED)


def _problem(action: Action, spec: ActionSpec | None) -> tuple[str, list[tuple[str, str]]] | None:
    if spec is None or ActionScope.INSTANT not in spec.scopes:
        return f"the vehicle cannot perform {action.action_type!r} as an instant action", []
    if action.blocking_type not in spec.blocking:
        allowed = ", ".join(sorted(b.value for b in spec.blocking))
        return (f"{action.action_type!r} cannot be {action.blocking_type.value}: {allowed}",
                [("blockingType", action.blocking_type.value)])
    if action.action_type == "initPosition":
        return None  # its parameters are checked with their types (InstantActionsMixin._init_position)
    for p in spec.parameters:
        if not p.is_optional and action.parameter(p.key) is None:
            return f"{action.action_type!r} needs parameter {p.key!r}", [("parameter", p.key)]
    return None
