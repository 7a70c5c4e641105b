"""A VDA 5050 vehicle on a bench: the pure vehicle plus a body that does exactly what it is told, when the
test says so (docs/contract.md §11). For tests of the vehicle's rules, a user's master in pure Python, and the
acceptance tests derived from the specification's diagrams.

The bench keeps what the effects ask for: the waypoints to drive, the actions running, the holds, the
timers; :meth:`Bench.reach` drives to the next waypoint (the body moves there in one step and its odometer
counts the distance), :meth:`Bench.finish` ends an action. Every published state message is kept, built
from the bench's body, so a test reads the sequence a master would receive (:meth:`Bench.seen` gives
the parts a test usually compares).
"""

from __future__ import annotations

import math
from typing import Any

from vcran.core.vda5050 import codec
from vcran.core.vda5050.codec import Invalid
from vcran.core.vda5050.config import VehicleConfig
from vcran.core.vda5050.effects import (
    Abandon,
    Act,
    Body,
    Drive,
    Effect,
    Hold,
    Interrupt,
    Place,
    PublishFactsheet,
    PublishState,
    Release,
    StartTimer,
    StopAfterLeg,
    StopNow,
    Waypoint,
    Where,
)
from vcran.core.vda5050.order import InstantActions, Order
from vcran.core.vda5050.state import Load, State
from vcran.core.vda5050.vehicle import Vehicle
from vcran.testing.vda5050.plans import MANUFACTURER, SERIAL


class Bench:
    def __init__(self, config: VehicleConfig | None = None, *, x: float = 0.0, y: float = 0.0,
                 theta: float = 0.0, now: float = 0.0) -> None:
        self.config = config or VehicleConfig(MANUFACTURER, SERIAL)
        self.vehicle = Vehicle(self.config)
        self.now = now
        self.x, self.y, self.theta, self.odometer = x, y, theta, 0.0
        self.battery: float | None = None
        self.loads: list[Load] = []
        self.route: list[Waypoint] = []
        self.stop_after_leg = False
        self.acting: dict[str, Act] = {}
        self.holds: set[str] = set()
        self.timers: dict[str, float] = {}
        self.states: list[State] = []
        self.factsheets = 0
        self.effects: list[Effect] = []
        self.apply(self.vehicle.start(now))

    # --- the master ---------------------------------------------------------------------------------------

    def order(self, message: Order | Invalid | bytes) -> list[Effect]:
        """Send an order (a model, or JSON text decoded as the vehicle's version decodes it)."""
        if isinstance(message, bytes):
            message = codec.decode_order(message, self.config.version)
        return self.apply(self.vehicle.on_order(self.now, message, self.where()))

    def instant(self, message: InstantActions | Invalid | bytes) -> list[Effect]:
        if isinstance(message, bytes):
            message = codec.decode_instant_actions(message, self.config.version)
        return self.apply(self.vehicle.on_instant_actions(self.now, message, self.where()))

    # --- the body -----------------------------------------------------------------------------------------

    def reach(self) -> list[Effect]:
        """The body arrives at its next waypoint (the test decides when)."""
        assert self.route, "no waypoint to reach"
        assert not self.holds, f"the body is held ({', '.join(sorted(self.holds))})"
        w = self.route.pop(0)
        self.odometer += math.hypot(w.x - self.x, w.y - self.y)
        self.x, self.y = w.x, w.y
        if w.theta is not None:
            self.theta = w.theta
        if self.stop_after_leg:
            self.route.clear()
            self.stop_after_leg = False
        return self.apply(self.vehicle.on_reached(self.now, w.tag, self.where()))

    def finish(self, action_id: str, ok: bool = True, message: str = "") -> list[Effect]:
        """The body ends action ``action_id``. A pick adds a load named by its loadId, a drop removes one."""
        act = self.acting.pop(action_id)
        if ok and act.action_type == "pick":
            self.loads.append(Load(load_id=act.parameter("loadId", action_id)))
        elif ok and act.action_type == "drop" and self.loads:
            self.loads.pop()
        return self.apply(self.vehicle.on_acted(self.now, action_id, ok, message))

    def at(self, now: float) -> list[Effect]:
        """Time passes to ``now``: due timers fire at their instants, in order."""
        out: list[Effect] = []
        while True:
            due = sorted((at, key) for key, at in self.timers.items() if at <= now)
            if not due:
                break
            at, key = due[0]
            del self.timers[key]
            self.now = at
            out += self.apply(self.vehicle.on_timer(at, key))
        self.now = now
        return out

    def call(self, name: str, *args: Any) -> list[Effect]:
        """Any other input: ``bench.call("on_breakdown")``, ``bench.call("on_battery_low", True)``."""
        method = getattr(self.vehicle, name)
        return self.apply(method(self.now, *args))

    def where(self) -> Where:
        return Where(self.x, self.y, self.theta, self.odometer)

    def body(self) -> Body:
        return Body(self.where(), battery=self.battery, loads=tuple(self.loads))

    # --- effects ------------------------------------------------------------------------------------------

    def apply(self, effects: list[Effect]) -> list[Effect]:
        for e in effects:
            if isinstance(e, Drive):
                self.route.extend(e.route)
            elif isinstance(e, StopAfterLeg):
                assert self.route, "stop after a leg, with no leg running"
                del self.route[1:]
                self.stop_after_leg = True
            elif isinstance(e, (StopNow, Abandon)):
                assert self.route, f"{type(e).__name__} with no leg running"
                self.route.clear()
            elif isinstance(e, Act):
                assert e.action_id not in self.acting, f"{e.action_id} started twice"
                self.acting[e.action_id] = e
            elif isinstance(e, Interrupt):
                del self.acting[e.action_id]
            elif isinstance(e, Hold):
                self.holds.add(e.kind)
            elif isinstance(e, Release):
                self.holds.discard(e.kind)
            elif isinstance(e, Place):
                self.x, self.y, self.theta = e.x, e.y, e.theta
            elif isinstance(e, PublishState):
                self.states.append(self.vehicle.state(self.now, self.body()))
            elif isinstance(e, PublishFactsheet):
                self.factsheets += 1
            elif isinstance(e, StartTimer):
                self.timers[e.key] = e.at
        self.effects += effects
        return effects

    @property
    def last(self) -> State:
        return self.states[-1]

    def seen(self, state: State | None = None) -> dict[str, Any]:
        """The parts of a state (the latest by default) that order handling changes, compactly."""
        s = self.last if state is None else state
        return {
            "order": (s.order_id, s.order_update_id),
            "last": (s.last_node_id, s.last_node_sequence_id),
            "nodes": [f"{n.node_id}{n.sequence_id}{'' if n.released else '?'}" for n in s.node_states],
            "edges": [f"{e.edge_id}{'' if e.released else '?'}" for e in s.edge_states],
            "actions": {a.action_id: a.action_status.value for a in s.action_states},
            "driving": s.driving,
            "errors": [e.error_type for e in s.errors],
        }

