"""What the VDA 5050 vehicle is told about its body, what it asks the body and the world to do, and what
it reports: frozen, slotted values (the house style of :mod:`vcran.core.opil.effects`).

Every input of :class:`~vcran.core.vda5050.vehicle.Vehicle` returns a list of effects in the order they
happen. Commands map one to one onto the robot body's commands (the shared AGV and AgvAction processes):

=====================  ==========================================================================
effect                 body / world
=====================  ==========================================================================
:class:`Drive`         ``drive(route)``: append these waypoints to the route being driven
:class:`StopAfterLeg`  ``stop_after_leg()``: finish the running leg, drop the rest of the route
:class:`StopNow`       stop at once where the body is, drop the route (vehicles that can stop
                       between nodes)
:class:`Abandon`       ``abandon()``: the leg that began at this very instant does not happen
:class:`Act`           ``act(kind, tag)``: perform one action; the body answers ``acted``
:class:`Interrupt`     stop one running action now; nothing of it happens, no ``acted`` follows
:class:`Hold`          ``hold(kind)``: stop driving and running actions, resumable
:class:`Release`       ``release(kind)``
:class:`Place`         set the body's pose (initPosition: in simulation, belief is truth)
:class:`PublishState`  publish ``state`` now (build it with ``Vehicle.state``)
:class:`PublishFactsheet`  publish ``factsheet`` now (``Vehicle.factsheet``)
:class:`StartTimer`    call ``Vehicle.on_timer(at, key)`` at ``at``; replaces a timer of that key
=====================  ==========================================================================

The rest are events for the run's log (``events.jsonl``); what a master sees is in the state message.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from vcran.core.slots import slot_init
from vcran.core.vda5050.enums import ActionStatus
from vcran.core.vda5050.order import ActionParameter
from vcran.core.vda5050.state import Error, Load

# --- what the vehicle is told about its body -------------------------------------------------------------


@slot_init
@dataclass(frozen=True, slots=True)
class Where:
    """The body at an input's instant: pose on the vehicle's map and the distance it has driven in all
    (an odometer; ``distanceSinceLastNode`` is its difference since the last node)."""

    x: float
    y: float
    theta: float
    odometer: float = 0.0


@slot_init
@dataclass(frozen=True, slots=True)
class Body:
    """What the body shows at the instant a ``state`` or ``visualization`` message is built."""

    where: Where
    vx: float = 0.0
    vy: float = 0.0
    omega: float = 0.0
    #: State of charge in percent; None: the robot has no battery model (reported as 100).
    battery: float | None = None
    #: What the body carries (``state.loads``); None: the body cannot tell (the field is left out).
    loads: tuple[Load, ...] | None = ()


# --- commands ---------------------------------------------------------------------------------------------


@slot_init
@dataclass(frozen=True, slots=True)
class NodeTag:
    """A waypoint's tag: the node of the order it stands for. Sequence ids are unique within an order."""

    order_id: str
    node_id: str
    sequence_id: int


@slot_init
@dataclass(frozen=True, slots=True)
class Waypoint:
    """Drive to ``(x, y)`` along a straight leg at no more than ``max_speed`` (the edge's ``maxSpeed``;
    None: the robot's own limit), and turn to ``theta`` there when it is given (the node's ``theta``)."""

    x: float
    y: float
    theta: float | None
    max_speed: float | None
    tag: NodeTag
    edge_id: str


@slot_init
@dataclass(frozen=True, slots=True)
class Drive:
    route: tuple[Waypoint, ...]


@slot_init
@dataclass(frozen=True, slots=True)
class StopAfterLeg:
    pass


@slot_init
@dataclass(frozen=True, slots=True)
class StopNow:
    pass


@slot_init
@dataclass(frozen=True, slots=True)
class Abandon:
    pass


@slot_init
@dataclass(frozen=True, slots=True)
class Act:
    """Perform action ``action_id`` of type ``action_type`` (pick, drop, startCharging, stopCharging,
    finePositioning, waitForTrigger, or a type the vehicle's configuration adds); the body reports
    ``Vehicle.on_acted(now, action_id, ok, message)`` when it ends."""

    action_type: str
    action_id: str
    parameters: tuple[ActionParameter, ...] = ()

    def parameter(self, key: str, default: Any = None) -> Any:
        for p in self.parameters:
            if p.key == key:
                return p.value
        return default


@slot_init
@dataclass(frozen=True, slots=True)
class Interrupt:
    action_id: str


@slot_init
@dataclass(frozen=True, slots=True)
class Hold:
    """``kind``: ``pause`` (startPause) or ``instant`` (a SOFT or HARD instant action is running)."""

    kind: str


@slot_init
@dataclass(frozen=True, slots=True)
class Release:
    kind: str


@slot_init
@dataclass(frozen=True, slots=True)
class Place:
    x: float
    y: float
    theta: float
    map_id: str


@slot_init
@dataclass(frozen=True, slots=True)
class PublishState:
    pass


@slot_init
@dataclass(frozen=True, slots=True)
class PublishFactsheet:
    pass


@slot_init
@dataclass(frozen=True, slots=True)
class StartTimer:
    key: str
    at: float


# --- events -----------------------------------------------------------------------------------------------


@slot_init
@dataclass(frozen=True, slots=True)
class OrderAccepted:
    order_id: str
    order_update_id: int
    update: bool


@slot_init
@dataclass(frozen=True, slots=True)
class OrderRejected:
    """Nothing of the order was taken over; ``error`` is what ``state.errors`` shows for it."""

    order_id: str | None
    order_update_id: int | None
    error: Error


@slot_init
@dataclass(frozen=True, slots=True)
class OrderDiscarded:
    """§6.6.4.3: the same orderId and orderUpdateId again; ignored."""

    order_id: str
    order_update_id: int


@slot_init
@dataclass(frozen=True, slots=True)
class OrderEnded:
    """``how``: ``completed``, ``cancelled``, or why the vehicle gave it up (``battery_empty``,
    ``motion_failed``, ``collision``)."""

    order_id: str
    how: str


@slot_init
@dataclass(frozen=True, slots=True)
class NodeTraversed:
    node_id: str
    sequence_id: int


@slot_init
@dataclass(frozen=True, slots=True)
class ActionChanged:
    action_id: str
    action_type: str
    status: ActionStatus


@slot_init
@dataclass(frozen=True, slots=True)
class ErrorRaised:
    error: Error


@slot_init
@dataclass(frozen=True, slots=True)
class ErrorCleared:
    error: Error


class LocalProtocolError(RuntimeError):
    """The driver misused the vehicle (time going backwards, a waypoint or action it never started): a bug
    of the driver's, never the master's (h11's LocalProtocolError; OPIL's RanLogic has its own)."""


Command = (Drive | StopAfterLeg | StopNow | Abandon | Act | Interrupt | Hold | Release | Place | PublishState
           | PublishFactsheet | StartTimer)
Event = (OrderAccepted | OrderRejected | OrderDiscarded | OrderEnded | NodeTraversed | ActionChanged | ErrorRaised
         | ErrorCleared)
Effect = Command | Event
