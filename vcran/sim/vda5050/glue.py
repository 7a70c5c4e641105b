"""VDA 5050's part of a run (docs/protocols.md, docs/vda5050.md): a Vehicle per robot around its body.

:class:`Vda5050` is what :mod:`vcran.sim.protocols` hands the shared :class:`~vcran.sim.model.Model` for the
protocol ``vda5050`` (:class:`~vcran.sim.protocols.Glue`). It routes the transport's ``order`` and
``instantActions`` to the vehicles by robot id (a scripted run's messages come decoded; a live or replayed
one's raw, decoded and validated here against the vehicle's version, §6.6.4.1), publishes what the vehicles
send (``state`` on every event and at least every 30 s, ``factsheet``; ``visualization`` every telemetry
period, to a transport that takes it: :attr:`~vcran.core.wire.Transport.wants_visualization`), writes the vehicles' events to the log and keeps the model's
books from them: an order is the unit of work (``completed``: its orderId; ``cancelled``: orderId and how it
ended), busy from the first order accepted to the order's end.

``connection`` is not published here: connecting is the MQTT edge's (transports.mqtt), a network event no
simulated run has (docs/vda5050.md, "The connection topic").
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import fields, is_dataclass
from enum import Enum
from types import UnionType
from typing import TYPE_CHECKING, Any, get_args, get_type_hints

from vcran.core.vda5050 import codec
from vcran.core.vda5050 import effects as fx
from vcran.core.vda5050.enums import Topic, Version
from vcran.core.vda5050.fleet import vehicle_config
from vcran.core.vda5050.vehicle import Vehicle
from vcran.core.wire import Inbound, Publish, Transport
from vcran.sim.body import Body
from vcran.sim.timing import FAULT, TELEMETRY, at
from vcran.sim.vda5050.node import Received, VehicleNode
from vcran.sim.vda5050.traffic import VdaTraffic

if TYPE_CHECKING:
    from vcran.sim.model import Model
    from vcran.sim.power import Level

#: The topics a vehicle receives, by the transport's attribute name.
RECEIVED = {"order": Topic.ORDER, "instantActions": Topic.INSTANT_ACTIONS}
_DECODE = {Topic.ORDER: codec.decode_order, Topic.INSTANT_ACTIONS: codec.decode_instant_actions}
#: The event log's name of each of the Vehicle's events.
EVENT_NAMES = {
    fx.OrderAccepted: "order_accepted", fx.OrderRejected: "order_rejected", fx.OrderDiscarded: "order_discarded",
    fx.OrderEnded: "order_ended", fx.NodeTraversed: "node_traversed", fx.ActionChanged: "action_changed",
    fx.ErrorRaised: "error_raised", fx.ErrorCleared: "error_cleared",
}


class Vda5050:
    """VDA 5050's glue for one run of ``model`` (module docstring)."""

    def __init__(self, model: Model) -> None:
        self.model = model
        self.env, self.events = model.env, model.events
        self.nodes: list[VehicleNode] = []
        self._by_id: dict[str, VehicleNode] = {}
        self.transport: Transport | None = None
        self._after_tick: Callable[[float], None] | None = None
        #: docs/contract.md §4 link_down: robot -> (when its link is back, what it could not publish: the latest of each
        #: topic, as the MQTT edge holds it while its broker is away). What reaches it meanwhile is lost (§6.2).
        self._down: dict[str, tuple[float, dict[str, Publish]]] = {}

    def attach(self, body: Body) -> None:
        node = VehicleNode(body, Vehicle(vehicle_config(body.config, self.model.scenario.settings)), self)
        self.nodes.append(node)
        self._by_id[node.id] = node

    def connect(self, transport: Transport) -> None:
        self.transport = transport

    def start(self, telemetry_period: float, description_period: float, after_tick: Callable[[], bool]) -> None:
        self.env.process(self._ticks(telemetry_period, after_tick))

    def _ticks(self, period: float, stop_when_idle: Callable[[], bool]):  # type: ignore[no-untyped-def]
        """Every ``period``: each vehicle's visualization (to a transport that takes it), the batteries'
        tick, and whether the run is over."""
        transport = self.transport
        assert transport is not None
        k = 0
        while True:
            t = k * period
            yield at(self.env, t, TELEMETRY)
            if transport.wants_visualization:
                publish = self.publish
                for node in self.nodes:
                    publish(node, "visualization", node.vehicle.visualization(t, _moving(node.body)))
            if self._after_tick is not None:
                self._after_tick(t)
            if stop_when_idle():
                return
            k += 1

    # --- inbound ----------------------------------------------------------------------------------------------

    @property
    def deliver(self) -> Callable[[Inbound], None]:
        return self._deliver

    def _deliver(self, inbound: Inbound) -> None:
        node = self._by_id.get(inbound.entity)
        topic = RECEIVED.get(inbound.attribute)
        if node is None or topic is None:
            self._reject(inbound, node is None)
            return
        if node.id in self._down:
            self.events.write(self.env.now, node.id, "message_lost", {
                "code": "link_down", "message": f"{inbound.attribute} lost: the robot's link is down [§4, VDA 5050 §6.2]"})
            return
        message = inbound.message
        if message is None:
            message = _DECODE[topic](inbound.raw, node.vehicle.config.version)
        node.inbox.put(Received(topic, message))

    def _reject(self, inbound: Inbound, unknown_robot: bool) -> None:
        model = self.model
        model.fleet_errors += 1
        if unknown_robot:
            known = ", ".join(r.id for r in model.robots[:5]) + (", ..." if len(model.robots) > 5 else "")
            code, message = "unknown_robot", f"{inbound.attribute} for {inbound.entity}, which no vehicle is; robots: {known}"
        else:
            code, message = "unknown_topic", f"{inbound.attribute}: a vehicle receives order and instantActions only"
        self.events.write(self.env.now, inbound.entity, "rejected", {"code": code, "severity": "error", "message": message})

    # --- outbound ---------------------------------------------------------------------------------------------

    def publish(self, node: VehicleNode, attribute: str, message: Any) -> None:
        out = Publish(self.env.now, node.id, attribute, message)
        down = self._down.get(node.id) if self._down else None
        if down is not None:
            if attribute != "visualization":  # stale the moment it is late
                down[1].pop(attribute, None)
                down[1][attribute] = out
            return
        assert self.transport is not None
        self.transport.send(out)

    def link_down(self, body: Body, duration: float) -> None:
        """docs/contract.md §4 link_down: for ``duration`` the vehicle neither receives (MQTT's QoS 0: what is sent to it
        meanwhile is lost, §6.2) nor publishes; back up, it publishes the latest of each topic it held."""
        end = self.env.now + duration
        assert self.transport is not None
        if self.transport.outage(body.id, end):
            return
        down = self._down.get(body.id)
        if down is not None and end <= down[0]:
            return
        self._down[body.id] = (end, down[1] if down is not None else {})
        at(self.env, end, FAULT).callbacks.append(lambda _: self._link_up(body.id, end))

    def _link_up(self, robot: str, end: float) -> None:
        if self._down.get(robot, (None,))[0] != end:
            return  # extended by a link_down that ends later
        _, held = self._down.pop(robot)
        assert self.transport is not None
        for out in held.values():
            self.transport.send(Publish(self.env.now, out.robot, out.attribute, out.message))

    # --- what the model asks ----------------------------------------------------------------------------------

    def every_tick(self, then: Callable[[float], None]) -> None:
        self._after_tick = then

    def battery_states(self, t: float, levels: list[Level]) -> None:
        """Nothing of its own: VDA 5050 reports the battery in ``state.batteryState`` (§6.10.6)."""

    @property
    def links_down(self) -> bool:
        return bool(self._down)

    def idle(self) -> bool:
        """No vehicle has an order to execute (Figure 8 (3)) or a body still at work."""
        return all(not node.vehicle.executing and not node.body.working and not node.body.beside
                   for node in self.nodes)

    def errors(self, index: int) -> int:
        return self.nodes[index].errors

    def traffic(self) -> VdaTraffic:
        """docs/contract.md §12: a blocked vehicle reports ``safetyState.fieldViolation``; a deadlock cancel halts it."""
        return VdaTraffic(self.nodes)

    # --- the Vehicle's events ---------------------------------------------------------------------------------

    def log(self, node: VehicleNode, event: Any) -> None:
        now, kind, index = self.env.now, type(event), node.index
        logged = _LOGGED.get(kind) or _logged(kind)
        self.events.write(now, node.id, EVENT_NAMES[kind], logged(event, node.vehicle.config.version))
        model = self.model
        if kind is fx.OrderAccepted:
            if model.busy_since[index] is None:
                model.busy_since[index] = now
        elif kind is fx.OrderEnded:
            if event.how == "completed":
                model.completed[node.id].append(event.order_id)
                model.tasks_done += 1
            else:
                model.cancelled[node.id].append(event.order_id, event.how)
            since = model.busy_since[index]
            if since is not None:
                model.busy_seconds[index] += now - since
                model.busy_since[index] = None

    def log_incident(self, node: VehicleNode, event: Any) -> None:
        self.events.write(self.env.now, node.id, event.NAME, event.fields())


def _moving(body: Body) -> fx.Body:
    """The body as a visualization shows it (§6.13: position and velocity; ``vx`` along the heading, as
    :meth:`VehicleNode.shown`), without what only a state shows (odometer, charge, loads): a visualization per
    vehicle per tick is most of what a fleet publishes live, or to a master that hears it."""
    x, y, theta, speed, omega = body.motion()
    return fx.Body(fx.Where(x, y, theta), vx=speed, omega=omega)


#: Each event class's fields as the log writes them (:func:`_logged`).
_LOGGED: dict[type, Callable[[Any, Version], dict[str, Any]]] = {}
#: The field values that are JSON as they are: most of them (a str-valued enum is not one of these types).
_JSON = frozenset({str, int, float, bool, type(None)})


def _logged(kind: type) -> Callable[[Any, Version], dict[str, Any]]:
    """``fields(event, version)``: the fields of an event of class ``kind`` as the log writes them, written out
    once per class as a dict display, a field annotated with JSON types taken as it is and any other through
    :func:`_plain`: a vehicle logs an event per node, action and order (55,000 a 100-vehicle hour), and a
    call per field was a third of logging one (issue 31)."""
    hints = get_type_hints(kind)
    items = []
    for f in fields(kind):
        hint = hints[f.name]
        plain = all(t in _JSON for t in get_args(hint)) if isinstance(hint, UnionType) else hint in _JSON
        items.append(f"{f.name!r}: e.{f.name}" if plain else f"{f.name!r}: _plain(e.{f.name}, version)")
    names: dict[str, Any] = {"_plain": _plain}
    exec(f"def fields(e, version):\n    return {{{', '.join(items)}}}\n", names)  # noqa: S102 (the class's own fields)
    found = _LOGGED[kind] = names["fields"]
    return found  # type: ignore[no-any-return]


def _plain(value: Any, version: Version) -> Any:
    """An event's field as JSON: models in their wire form, enums by value."""
    if type(value) in _JSON:
        return value
    if isinstance(value, Enum):
        return value.value
    if is_dataclass(value):
        return codec.to_plain(value, version)
    return value


def glue(model: Model) -> Vda5050:
    """The entry :mod:`vcran.sim.protocols` names for ``vda5050``."""
    return Vda5050(model)
