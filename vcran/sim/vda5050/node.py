"""The Vehicle's process for one robot: VDA 5050's vehicle logic around the shared body (docs/protocols.md).

The process decides nothing. It hands each arriving signal (an order or instantActions routed by the glue, the
body's reports, a due timer, an incident the logic takes as an input) to the pure
:class:`~vcran.core.vda5050.vehicle.Vehicle` with ``now`` and what the body shows, and carries out the
effects it returns, in order: commands become the body's commands (the mapping table of docs/protocols.md),
``PublishState`` and ``PublishFactsheet`` become messages built there and then, every other effect is an
event for the log. How the body serves the Vehicle's actions (docs/vda5050.md, "In the simulation"), as the Yard's
body does (vcran.testing.vda5050.yard): pick and drop are its load and unload; startCharging starts its charge
(FAILED at once where the charge could not start) and stopCharging ends it where the battery stands (§6.8.2: each
FINISHED once the charging process is started, stopped); waitForTrigger runs until the scenario's ``trigger``
fault presses the vehicle's trigger; finePositioning takes the scenario's ``fine_positioning`` action duration
(beside the rest, paused with the vehicle; none given: no time), the scenario's own types end as they start.
The battery's low warning reaches the Vehicle from the power tick, raised and, once a charge or a swap has
lifted the battery to its low level again, cleared.
"""

from __future__ import annotations

from collections.abc import Callable, Generator
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import simpy

from vcran.core.actions import ActionKind
from vcran.core.incidents import BatteryLow, FaultEnded, FaultStarted
from vcran.core.motion import Leg
from vcran.core.validity.fleet import FINE_POSITIONING
from vcran.core.vda5050 import effects as fx
from vcran.core.vda5050.codec import Invalid
from vcran.core.vda5050.enums import ActionStatus, Topic
from vcran.core.vda5050.order import InstantActions, Order
from vcran.core.vda5050.state import Load
from vcran.core.vda5050.vehicle import Vehicle
from vcran.sim.agvaction import Acted
from vcran.sim.body import Body, Reached
from vcran.sim.holds import Halted, InService
from vcran.sim.mailbox import Mailbox
from vcran.sim.timing import DEADLINE, at

if TYPE_CHECKING:
    from vcran.sim.vda5050.glue import Vda5050

Process = Generator[simpy.events.Event, Any, None]

#: The body's actions for the Vehicle's pick and drop (docs/contract.md §4's load and unload, at the station in reach).
PERFORMED = {"pick": ActionKind.LOAD, "drop": ActionKind.UNLOAD}
#: The body's holds are counted by kind: the Vehicle's own (pause, a blocking instant action) are kept apart
#: from the faults' (a docs/contract.md §4 pause or breakdown), which the Vehicle also hears of as inputs.
HOLD_PREFIX = "vda5050."
#: docs/contract.md §4's faults the Vehicle hears of when they start (a breakdown's end too): the pause button, a breakdown,
#: and the trigger a waitForTrigger waits for (its button pressed, §6.8.1).
VEHICLE_FAULTS = ("breakdown", "pause", "resume", "trigger")


@dataclass(frozen=True, slots=True)
class Received:
    """Glue -> Vehicle: an ``order`` or ``instantActions`` for this vehicle, decoded (or the Invalid)."""

    topic: Topic
    message: Order | InstantActions | Invalid


@dataclass(frozen=True, slots=True, eq=False)
class TimerFired:
    key: str
    deadline: simpy.events.Event


@dataclass(frozen=True, slots=True)
class Incident:
    """Body -> Vehicle: an incident the Vehicle takes as an input (breakdown, pause button, battery low)."""

    event: Any


@dataclass(frozen=True, slots=True)
class BatteryRestored:
    """Power tick -> Vehicle: the battery is back at or above its low level (docs/contract.md §4)."""


@dataclass(frozen=True, slots=True)
class FieldViolation:
    """Safety fields -> Vehicle: another robot is in (out of) this one's protective field (docs/contract.md §12)."""

    violated: bool


#: The tag of the body's charge a startCharging began: its end (full, or refused) ends the vehicle's charging.
CHARGE_TAG = "vda5050.charge"


class VehicleNode:
    """The Vehicle and its process for one robot's :class:`~vcran.sim.body.Body`; ``glue`` logs its events
    and publishes its messages."""

    def __init__(self, body: Body, vehicle: Vehicle, glue: Vda5050) -> None:
        self.body, self.vehicle, self.glue, self.env = body, vehicle, glue, body.env
        self.id, self.index = body.id, body.index
        self.inbox = Mailbox(body.env)
        self.errors = 0
        self._timers: dict[str, simpy.events.Event] = {}
        #: The waitForTrigger actions the body waits in, in the order they started.
        self._waiting: list[str] = []
        #: The ``loads`` a state lists by the number of parts carried (:meth:`shown`).
        self._loads: dict[int, tuple[Load, ...]] = {}
        body.tell = self.inbox.put
        body.plan = self.leg_to
        body.log = self._incident
        body.battery_restored = lambda: self.inbox.put(BatteryRestored())
        body.env.process(self._run())

    # --- the process --------------------------------------------------------------------------------------

    def _run(self) -> Process:
        vehicle, inbox = self.vehicle, self.inbox
        self.apply(vehicle.start(self.env.now))
        while True:
            item = yield inbox.get()
            effects = _INBOX[type(item)](self, self.env.now, item)
            if effects is not None:
                self.apply(effects)

    def apply(self, effects: list[fx.Effect]) -> None:
        for effect in effects:
            command = _COMMANDS.get(type(effect))
            if command is None:
                if type(effect) is fx.ErrorRaised:
                    self.errors += 1
                self.glue.log(self, effect)
            else:
                command(self, effect)

    # --- what the body shows --------------------------------------------------------------------------------

    def where(self) -> fx.Where:
        x, y, theta, _, _ = self.body.motion()
        return fx.Where(x, y, theta, self.body.odometer())

    def shown(self) -> fx.Body:
        """The body as a state or visualization shows it: pose and speeds now (``vx`` along the vehicle's
        heading, its own frame, §6.10.6), odometer, charge in percent, one load per part carried."""
        body = self.body
        x, y, theta, speed, omega = body.motion()
        charge = body.charge()
        battery = body.config.battery
        percent = None if charge is None or battery is None else 100.0 * charge / battery.capacity
        carrying = body.carrying
        loads = self._loads.get(carrying)
        if loads is None:  # the same tuple for every state while the count stays: built once per count
            loads = self._loads[carrying] = tuple(Load(load_id=f"{self.id}_part_{i + 1}") for i in range(carrying))
        return fx.Body(fx.Where(x, y, theta, body.odometer()), vx=speed, vy=0.0, omega=omega, battery=percent,
                       loads=loads)

    def leg_to(self, w: fx.Waypoint) -> Leg:
        """The body's plan for the Vehicle's waypoints: a straight leg to the node, its edge's ``maxSpeed``
        lowering the robot's own limit."""
        body = self.body
        x, y, theta = body.pose
        return Leg(self.env.now, x, y, theta, w.x, w.y, w.theta, body.limits(w.max_speed or 0.0, 0.0, 0.0))

    # --- commands -------------------------------------------------------------------------------------------

    def _act(self, effect: fx.Act) -> None:
        performed = PERFORMED.get(effect.action_type)
        if performed is not None:
            self.body.perform(performed, effect.action_id)
            return
        kind = effect.action_type
        if kind == "waitForTrigger":
            self._waiting.append(effect.action_id)  # until the trigger (a ``trigger`` fault) or an Interrupt
            return
        if kind == "startCharging":
            # The body's charge is its work, to the full battery unless stopped (docs/protocols.md); the action
            # is FINISHED once the charge runs (§6.8.2), FAILED if it cannot start (no charger in reach).
            refused = self.body.charge_refused()
            if refused is not None:
                self.inbox.put(Acted(effect.action_id, False, refused.code, refused.message))
                return
            self.body.act((None, ActionKind.CHARGE, CHARGE_TAG))
        elif kind == "stopCharging":
            self.body.stop_charging()  # FINISHED: "the charging process is stopped" (§6.8.2)
        elif kind == "finePositioning" and self.body.durations.get(FINE_POSITIONING):
            self.body.perform_for(self.body.durations[FINE_POSITIONING], effect.action_id)
            return
        self.inbox.put(Acted(effect.action_id, True))

    def _interrupt(self, effect: fx.Interrupt) -> None:
        if effect.action_id in self._waiting:
            self._waiting.remove(effect.action_id)
        else:
            self.body.interrupt(effect.action_id)

    def _triggered(self, now: float) -> list[fx.Effect]:
        """The vehicle's trigger: every waitForTrigger it waits in is FINISHED ("Trigger has been triggered",
        §6.8.2), whatever its triggerType; one nobody waits for is lost. Those the Vehicle ended meanwhile (a
        halt fails them without an Interrupt) are forgotten."""
        waiting, self._waiting = self._waiting, []
        out: list[fx.Effect] = []
        for action_id in waiting:
            run = self.vehicle.actions.get(action_id)
            if run is not None and run.status is ActionStatus.RUNNING:
                out += self.vehicle.on_acted(now, action_id)
        return out

    def _start_timer(self, effect: fx.StartTimer) -> None:
        deadline = at(self.env, effect.at, DEADLINE)
        key = effect.key
        self._timers[key] = deadline
        deadline.callbacks.append(lambda event: self._due(key, event))

    def _due(self, key: str, deadline: simpy.events.Event) -> None:
        if self._timers.get(key) is deadline:
            self.inbox.put(TimerFired(key, deadline))

    def _on_timer(self, now: float, item: TimerFired) -> list[fx.Effect] | None:
        if self._timers.get(item.key) is not item.deadline:
            return None  # replaced meanwhile
        del self._timers[item.key]
        return self.vehicle.on_timer(now, item.key)

    def _publish_state(self, effect: fx.PublishState) -> None:
        self.glue.publish(self, "state", self.vehicle.state(self.env.now, self.shown()))

    def _publish_factsheet(self, effect: fx.PublishFactsheet) -> None:
        self.glue.publish(self, "factsheet", self.vehicle.factsheet(self.env.now))

    # --- reports ----------------------------------------------------------------------------------------------

    def _received(self, now: float, item: Received) -> list[fx.Effect]:
        if item.topic is Topic.ORDER:
            return self.vehicle.on_order(now, item.message, self.where())  # type: ignore[arg-type]
        return self.vehicle.on_instant_actions(now, item.message, self.where())  # type: ignore[arg-type]

    def _acted(self, now: float, item: Acted) -> list[fx.Effect]:
        if item.tag == CHARGE_TAG:
            return self.vehicle.on_charging_ended(now)
        return self.vehicle.on_acted(now, item.tag, item.ok, item.message)

    def _incident(self, body: Body, event: Any) -> None:
        """Every incident goes to the run's log; those the Vehicle takes as inputs (docs/contract.md §4's breakdown and its
        repair, the pause and resume faults, the battery's warning level) go to it too, through the inbox (the
        body reports them from within its own processes)."""
        self.glue.log_incident(self, event)
        kind = type(event)
        if kind is BatteryLow or (kind is FaultStarted and event.applied and event.kind in VEHICLE_FAULTS) or (
                kind is FaultEnded and event.kind == "breakdown"):
            self.inbox.put(Incident(event))

    def _on_incident(self, now: float, item: Incident) -> list[fx.Effect]:
        event, vehicle = item.event, self.vehicle
        if type(event) is BatteryLow:
            return vehicle.on_battery_low(now, True)
        if type(event) is FaultEnded:
            return vehicle.on_repaired(now)
        if event.kind == "breakdown":
            return vehicle.on_breakdown(now)
        if event.kind == "trigger":
            return self._triggered(now)
        return vehicle.on_pause_button(now, event.kind == "pause")


def _field(node: VehicleNode, now: float, item: Any) -> list[fx.Effect]:
    return node.vehicle.on_field_violation(now, item.violated)


_INBOX: dict[type, Callable[[VehicleNode, float, Any], list[fx.Effect] | None]] = {
    Received: VehicleNode._received,
    Reached: lambda node, now, item: node.vehicle.on_reached(now, item.waypoint.tag, node.where()),
    Acted: VehicleNode._acted,
    TimerFired: VehicleNode._on_timer,
    Halted: lambda node, now, item: node.vehicle.on_halted(now, item.why, item.message),
    InService: lambda node, now, item: node.vehicle.on_serviced(now),
    BatteryRestored: lambda node, now, item: node.vehicle.on_battery_low(now, False),
    Incident: VehicleNode._on_incident,
    FieldViolation: _field,
}

#: The effects that are commands (docs/protocols.md's mapping table); every other effect is an event.
_COMMANDS: dict[type, Callable[[VehicleNode, Any], object]] = {
    fx.Drive: lambda node, effect: node.body.extend(effect.route),
    fx.StopAfterLeg: lambda node, effect: node.body.stop_after_leg(),
    fx.StopNow: lambda node, effect: node.body.stop_now(),
    fx.Abandon: lambda node, effect: node.body.abandon(),
    fx.Act: VehicleNode._act,
    fx.Interrupt: VehicleNode._interrupt,
    fx.Hold: lambda node, effect: node.body.hold(HOLD_PREFIX + effect.kind),
    fx.Release: lambda node, effect: node.body.release(HOLD_PREFIX + effect.kind),
    fx.Place: lambda node, effect: node.body.place(effect.x, effect.y, effect.theta),
    fx.PublishState: VehicleNode._publish_state,
    fx.PublishFactsheet: VehicleNode._publish_factsheet,
    fx.StartTimer: VehicleNode._start_timer,
}
