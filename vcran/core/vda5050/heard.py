"""The orders a master hears its vehicles hold, from their ``state`` messages alone (docs/vda5050.md, "Live over
MQTT"): what ``vcran manage --mqtt`` logs so that ``vcran report`` of its folder shows the vehicles' busy
time as the master heard it, as ``vcran manage --orion`` logs the robots' states for OPIL.

A vehicle works on an order while its state shows work of it left (the vehicle's own rule, Figure 8 (3)):
``nodeStates`` or ``edgeStates`` not empty, or an action of the order neither FINISHED nor FAILED. Instant
actions are listed in ``actionStates`` beside the order's (§6.10.6); those the master sent
(:meth:`HeardOrders.sent`) are not the order's work, as an instant startCharging is not work in a simulated
run's report (:mod:`vcran.report.vda5050`). So, heard state by heard state, an order is *accepted* when the
vehicle is first heard working on it and *ended* when it is first heard with no work of it left (or working
on another order: the states between were not heard). The events are those a simulated run logs,
``order_accepted`` and ``order_ended`` (docs/vda5050.md), heard instead of done: they lag the vehicle by the
link's latency, and an order begun and ended between two heard states is never heard at all.

How an order ended, as its last heard state shows it: a halt (docs/contract.md §4) where an error of the
halt's type names the order (vcran's vehicles: ``batteryEmpty``, ``motionFailed``, ...); ``cancelled``
where a cancelOrder the master sent is newly FINISHED (§6.6.3); ``completed`` otherwise. Pure, like the core.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from vcran.core.vda5050.conditions import HALTS
from vcran.core.vda5050.enums import ActionStatus
from vcran.core.vda5050.order import InstantActions, Order
from vcran.core.vda5050.state import State

#: The halt each error type says the vehicle gave its order up in (docs/contract.md §4).
_HALT_OF = {error_type: why for why, (error_type, _) in HALTS.items()}
_FINAL = (ActionStatus.FINISHED, ActionStatus.FAILED)

#: A heard event: its name and fields, as ``events.jsonl`` records them.
Heard = tuple[str, dict[str, Any]]


@dataclass(slots=True)
class _Vehicle:
    current: str | None = None  # the order heard open
    last: str | None = None  # the order heard last: one heard again is an update of it (§6.6.2)
    instant: set[str] = field(default_factory=set)  # instant actionIds sent, not heard ended yet


class HeardOrders:
    """Every vehicle's orders as the master hears them (module docstring); vehicles by robot id."""

    def __init__(self) -> None:
        self._vehicles: dict[str, _Vehicle] = {}

    def sent(self, robot: str, message: Order | InstantActions) -> None:
        """The master sent ``message`` to ``robot``: its instant actions are not an order's work."""
        if isinstance(message, InstantActions):
            self._vehicle(robot).instant.update(a.action_id for a in message.actions)

    def heard(self, robot: str, state: State) -> list[Heard]:
        """``robot``'s state reached the master: the order events it shows, in order (none, one or two)."""
        vehicle = self._vehicle(robot)
        instant = vehicle.instant
        working = bool(state.node_states or state.edge_states) or any(
            a.action_status not in _FINAL and a.action_id not in instant for a in state.action_states)
        out: list[Heard] = []
        if vehicle.current is not None and (not working or state.order_id != vehicle.current):
            out.append(("order_ended", {"order_id": vehicle.current, "how": self._how(vehicle, state)}))
            vehicle.current = None
        if working and vehicle.current is None:
            out.append(("order_accepted", {"order_id": state.order_id, "order_update_id": state.order_update_id,
                                           "update": state.order_id == vehicle.last}))
            vehicle.current = vehicle.last = state.order_id
        if instant:  # an instant action heard ended can no longer be taken for the order's
            instant.difference_update(a.action_id for a in state.action_states if a.action_status in _FINAL)
        return out

    def _how(self, vehicle: _Vehicle, state: State) -> str:
        for error in state.errors:
            why = _HALT_OF.get(error.error_type)
            if why is not None and any(r.reference_key == "orderId" and r.reference_value == vehicle.current
                                       for r in error.error_references or ()):
                return why
        if any(a.action_type == "cancelOrder" and a.action_status is ActionStatus.FINISHED
               and a.action_id in vehicle.instant for a in state.action_states):
            return "cancelled"
        return "completed"

    def _vehicle(self, robot: str) -> _Vehicle:
        vehicle = self._vehicles.get(robot)
        if vehicle is None:
            vehicle = self._vehicles[robot] = _Vehicle()
        return vehicle
