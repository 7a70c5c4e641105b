"""VDA 5050 vehicles and a master in simulated time, without SimPy: a pure harness for masters (docs/contract.md §11).

A :class:`Yard` runs a :class:`~vcran.core.vda5050.master.Master` against a scenario's robots, each one the
pure :class:`~vcran.core.vda5050.vehicle.Vehicle` with a plain body:

- it drives each leg for its kinematic duration (:class:`vcran.core.motion.Leg`: turn, trapezoidal speed
  profile from rest to rest, at the robot's limits and the edge's ``maxSpeed``), and a hold (pause, a
  blocking instant action) stops it where it is until released;
- it performs ``pick`` and ``drop`` for the scenario's ``load`` and ``unload`` durations at the station
  named by ``stationName``, within the station's reach: a pick takes a part from the station's stock and
  fails at an empty one, a drop puts the part back; ``startCharging`` within a charger's reach charges at
  the battery's ``charge_rate`` until full (then the vehicle is told), ``stopCharging`` stops it where the
  battery stands; ``waitForTrigger`` runs until the test presses the vehicle's trigger (:meth:`Yard.trigger`);
  ``finePositioning`` takes the scenario's ``fine_positioning`` duration (if any); other actions take no time;
- its battery (the robot's ``[robots.battery]``) drains ``per_metre`` with each leg driven, and the
  vehicle is told when it is below the ``low`` level (as it comes up, after a leg) and at the instant a
  charge lifts it to that level again.

Master and vehicles talk over a link of fixed ``latency`` each way, which loses the messages ``lose(serial,
topic)`` says it does (MQTT's QoS 0, §6.2: any topic but ``connection``). What the master sends is encoded and
decoded as on the wire (so its orders are validated against the official schema as a real vehicle would);
what vehicles publish reaches the master as the models they built. Within an instant the order is the
simulation's (vcran/sim/timing.py): messages reaching vehicles, completions, injected faults, messages
reaching the master, jobs, the master's timers.

It is not the simulation (no collisions, fields, production or random faults; no loss on the link): a
test injects what it needs with :meth:`Yard.call_at` (a part produced, :meth:`Yard.halt`). ``vcran.simulate``
runs the same master against the simulation's vehicles (:mod:`vcran.sim.vda5050.loop`); the Yard stays for fast
unit tests.
"""

from __future__ import annotations

import heapq
import itertools
import math
import random
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any

from vcran.core.jobs import JobBook
from vcran.core.motion import Leg, Limits
from vcran.core.vda5050 import codec
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
from vcran.core.vda5050.enums import ConnectionState, Topic
from vcran.core.vda5050.fleet import Agv, MasterFleet
from vcran.core.vda5050.master import HOOKS, Heard, Master, MasterHandle, topic_of
from vcran.core.vda5050.order import InstantActions, Order
from vcran.core.vda5050.state import Load, State
from vcran.core.vda5050.vehicle import Vehicle

if TYPE_CHECKING:  # types only: VDA 5050 imports nothing of OPIL's, which the scenario module still does
    from vcran.core.scenario import Job, Scenario

# Priorities within an instant (vcran/sim/timing.py's order).
INBOUND, COMPLETION, FAULT, UPDATE, JOB, TIMER = 1, 3, 4, 6, 7, 8


class Yard:
    """A scenario's robots as VDA 5050 vehicles and ``master`` in the loop (module docstring).

    ``events`` collects what a run's events.jsonl would: the jobs' events and each vehicle's (an order
    accepted or rejected, a node traversed, an action's status, an error), as dicts with ``t``, ``robot``
    and ``event``; ``legs`` every leg driven, ``(serial, leg)``.
    """

    def __init__(self, scenario: Scenario, master: Master, *, latency: float = 0.05,
                 configs: Sequence[VehicleConfig] | None = None,
                 lose: Callable[[str, Topic], bool] | None = None) -> None:
        if not latency > 0:
            raise ValueError(f"the link's latency must be positive, got {latency}")
        self.scenario, self.master, self.latency, self.lose = scenario, master, latency, lose
        self.fleet = MasterFleet.of(scenario, configs)
        self.now = 0.0
        self.events: list[dict[str, Any]] = []
        self.legs: list[tuple[str, Leg]] = []
        self.stock = {s.id: s.parts for s in scenario.stations}
        self.jobs = JobBook(lambda t, robot, event, fields: self.events.append(
            {"t": t, "robot": robot, "event": event, **fields}))
        self._queue: list[tuple[float, int, int, Callable[..., Any], tuple[Any, ...]]] = []
        self._seq = itertools.count()
        self.handle = _YardHandle(self, random.Random(f"manager:{scenario.settings.seed}"))
        self.bodies = {agv.serial_number: _Body(self, agv) for agv in self.fleet.vehicles}
        master._bind(self.fleet, self.handle)
        for body in self.bodies.values():
            body.start()
        master.on_start()
        self._workload = scenario.workload()
        self._next_job()

    # --- running -----------------------------------------------------------------------------------------

    def run(self, until: float) -> None:
        """Everything up to and including simulated time ``until``, in order."""
        while self._queue and self._queue[0][0] <= until:
            t, _, _, fn, args = heapq.heappop(self._queue)
            self.now = t
            fn(*args)
        self.now = max(self.now, until)

    def call_at(self, when: float, fn: Callable[..., Any], *args: Any, priority: int = FAULT) -> None:
        """Call ``fn(*args)`` at ``when`` (a test's injection: a part produced, a halt)."""
        if when < self.now:
            raise ValueError(f"call_at({when}): in the past (now {self.now})")
        heapq.heappush(self._queue, (when, priority, next(self._seq), fn, args))

    def halt(self, serial: str, why: str, message: str = "") -> None:
        """The body of ``serial`` stops for good where it is (``battery_empty``, ``motion_failed``,
        ``collision``: docs/contract.md §4), its leg and actions over."""
        body = self.bodies[serial]
        body.stop_leg()
        body.route.clear()
        body.acting.clear()
        body.apply(body.vehicle.on_halted(self.now, why, message))

    def trigger(self, serial: str) -> None:
        """Press the trigger of ``serial`` (a button on the vehicle): every waitForTrigger it waits in finishes
        (§6.8.2 "Trigger has been triggered"), whatever its triggerType; a press nobody waits for is lost."""
        self.bodies[serial].triggered()

    def states(self, serial: str) -> list[State]:
        """Every state ``serial`` published, in order."""
        return self.bodies[serial].states

    def _next_job(self) -> None:
        job = next(self._workload, None)
        if job is not None:
            self.call_at(job.t, self._arrive, job, priority=JOB)

    def _arrive(self, job: Job) -> None:
        self.jobs.arrived(self.now, job)
        self.master.on_job(job)
        self._next_job()

    def _to_master(self, serial: str, message: Heard) -> None:
        if self.lose is None or not self.lose(serial, topic_of(message)):
            self.call_at(self.now + self.latency, self._heard, serial, message, priority=UPDATE)

    def _heard(self, serial: str, message: Heard) -> None:
        self.handle._heard(serial, message)
        topic = topic_of(message)
        if self.master.hears(topic):
            getattr(self.master, HOOKS[topic])(serial, message)


class _Timer:
    __slots__ = ("when", "cancelled")

    def __init__(self, when: float) -> None:
        self.when, self.cancelled = when, False

    def cancel(self) -> None:
        self.cancelled = True


class _YardHandle(MasterHandle):
    def __init__(self, yard: Yard, rng: random.Random) -> None:
        super().__init__(yard.fleet, yard.jobs, rng)
        self.yard = yard

    @property
    def now(self) -> float:
        return self.yard.now

    def call_at(self, when: float, fn: Callable[..., Any], *args: Any, **kwargs: Any) -> Any:
        if not math.isfinite(when) or when < self.yard.now:
            raise ValueError(f"call_at({when}): not a finite time from now ({self.yard.now}) on")
        timer = _Timer(when)
        self.yard.call_at(when, lambda: None if timer.cancelled else fn(*args, **kwargs), priority=TIMER)
        return timer

    def _publish(self, serial: str, topic: Topic, message: Order | InstantActions) -> None:
        body = self.yard.bodies[serial]
        raw = codec.encode(message, body.vehicle.config.version)
        if self.yard.lose is not None and self.yard.lose(serial, topic):
            return
        self.yard.call_at(self.now + self.yard.latency, body.receive, topic, raw, priority=INBOUND)


class _Body:
    """One vehicle's logic and its plain body (module docstring)."""

    def __init__(self, yard: Yard, agv: Agv) -> None:
        self.yard, self.serial, robot = yard, agv.serial_number, agv.robot
        self.vehicle = Vehicle(agv.config)
        self.x, self.y, self.theta = robot.pose
        self.odometer = 0.0
        self.limits = Limits(robot.max_velocity, robot.max_acceleration, robot.max_deceleration,
                             robot.max_angular_velocity)
        self.route: list[Waypoint] = []
        self.leg: Leg | None = None
        self.acting: dict[str, Act] = {}
        self.holds: set[str] = set()
        self.timers: dict[str, float] = {}
        self.loads: list[Load] = []
        self.states: list[State] = []
        self.battery = robot.battery
        self.level = self.battery.start_level if self.battery is not None else 0.0
        self.charging_since: float | None = None
        self.low = False
        self._leg = self._charge = 0  # bumped whenever the running leg (charge) is cut short

    def start(self) -> None:
        self.yard._to_master(self.serial, self.vehicle.connection(0.0, ConnectionState.ONLINE))
        self.apply(self.vehicle.start(0.0))
        self.check_low()

    # --- inputs ------------------------------------------------------------------------------------------

    def receive(self, topic: Topic, raw: bytes) -> None:
        version, now = self.vehicle.config.version, self.yard.now
        if topic is Topic.ORDER:
            self.apply(self.vehicle.on_order(now, codec.decode_order(raw, version), self.where()))
        else:
            self.apply(self.vehicle.on_instant_actions(now, codec.decode_instant_actions(raw, version), self.where()))

    def reached(self, token: int) -> None:
        if token != self._leg or self.leg is None:
            return
        leg, self.leg = self.leg, None
        self.x, self.y, self.theta = leg.x1, leg.y1, leg.end_theta
        self.odometer += leg.distance
        waypoint = self.route.pop(0)
        self.drain(leg.distance)
        self.apply(self.vehicle.on_reached(self.yard.now, waypoint.tag, self.where()))

    def acted(self, action_id: str) -> None:
        act = self.acting.pop(action_id, None)
        if act is None:  # interrupted, or the body halted
            return
        ok, message = self.perform(act)
        self.apply(self.vehicle.on_acted(self.yard.now, action_id, ok, message))

    def timer(self, key: str, at: float) -> None:
        if self.timers.get(key) == at:
            del self.timers[key]
            self.apply(self.vehicle.on_timer(self.yard.now, key))

    def triggered(self) -> None:
        for action_id in [a.action_id for a in self.acting.values() if a.action_type == "waitForTrigger"]:
            del self.acting[action_id]
            self.apply(self.vehicle.on_acted(self.yard.now, action_id))

    def restored(self, token: int) -> None:
        """The charge ``token`` lifted the battery to its low level, now (computed when it started)."""
        if token == self._charge and self.charging_since is not None and self.low:
            self.low = False
            self.apply(self.vehicle.on_battery_low(self.yard.now, False))

    def full(self, token: int) -> None:
        if token == self._charge and self.charging_since is not None:
            self.level, self.charging_since = self.battery.capacity if self.battery else 0.0, None
            self.apply(self.vehicle.on_charging_ended(self.yard.now))
            self.check_low()

    # --- what the body does ------------------------------------------------------------------------------

    def apply(self, effects: list[Effect]) -> None:
        yard, now = self.yard, self.yard.now
        for e in effects:
            if isinstance(e, Drive):
                self.route.extend(e.route)
            elif isinstance(e, StopAfterLeg):
                del self.route[1:]
            elif isinstance(e, StopNow | Abandon):
                self.stop_leg()
                self.route.clear()
            elif isinstance(e, Act):
                self.acting[e.action_id] = e
                if e.action_type != "waitForTrigger":  # that one waits for Yard.trigger
                    yard.call_at(now + self.duration(e.action_type), self.acted, e.action_id, priority=COMPLETION)
            elif isinstance(e, Interrupt):
                self.acting.pop(e.action_id, None)
            elif isinstance(e, Hold):
                self.holds.add(e.kind)
                self.stop_leg()
            elif isinstance(e, Release):
                self.holds.discard(e.kind)
            elif isinstance(e, Place):
                self.x, self.y, self.theta = e.x, e.y, e.theta
            elif isinstance(e, PublishState):
                state = self.vehicle.state(now, self.body())
                self.states.append(state)
                yard._to_master(self.serial, state)
            elif isinstance(e, PublishFactsheet):
                yard._to_master(self.serial, self.vehicle.factsheet(now))
            elif isinstance(e, StartTimer):
                self.timers[e.key] = e.at
                yard.call_at(e.at, self.timer, e.key, e.at, priority=TIMER)
            else:
                fields = {k: getattr(e, k) for k in e.__dataclass_fields__}  # type: ignore[union-attr]
                yard.events.append({"t": now, "robot": self.serial, "event": type(e).__name__, **fields})
        if self.leg is None and self.route and not self.holds:
            self.drive()

    def drive(self) -> None:
        w = self.route[0]
        speed = self.limits.speed if w.max_speed is None else min(w.max_speed, self.limits.speed)
        limits = Limits(speed, self.limits.accel, self.limits.decel, self.limits.turn_rate)
        self.leg = leg = Leg(self.yard.now, self.x, self.y, self.theta, w.x, w.y, w.theta, limits)
        self.yard.legs.append((self.serial, leg))
        self.yard.call_at(leg.t_end, self.reached, self._leg, priority=COMPLETION)

    def stop_leg(self) -> None:
        """The running leg ends here and now (its waypoint stays first on the route)."""
        if self.leg is not None:
            x, y, theta, _, _ = self.leg.pose_at(self.yard.now)
            self.odometer += self.leg.distance_at(self.yard.now)
            self.drain(self.leg.distance_at(self.yard.now))
            self.x, self.y, self.theta, self.leg = x, y, theta, None
            self._leg += 1

    def perform(self, act: Act) -> tuple[bool, str]:
        """A pick, drop, startCharging or stopCharging ends: whether it worked, and why not."""
        kind, station = act.action_type, act.parameter("stationName")
        if kind in ("pick", "drop"):
            if station not in self.yard.stock or not self.in_reach(station):
                return False, f"no station {station!r} in reach"
            if kind == "pick" and self.yard.stock[station] == 0:
                return False, f"no part at {station}"
            if kind == "drop" and not self.loads:
                return False, "nothing to drop"
            if kind == "drop":
                self.yard.stock[station] += 1
                self.loads.pop()
            else:
                self.yard.stock[station] -= 1
                self.loads.append(Load(load_id=act.parameter("loadId", station)))
        elif kind == "startCharging":
            charger = next((s.id for s in self.yard.scenario.stations if s.charger and self.in_reach(s.id)), None)
            if charger is None or self.battery is None or self.battery.charge_rate <= 0:
                return False, "no charger in reach"
            self.level, self.charging_since = self.charge(), self.yard.now
            self._charge += 1
            due = self.yard.now + (self.battery.capacity - self.level) / self.battery.charge_rate
            self.yard.call_at(due, self.full, self._charge, priority=COMPLETION)
            if self.low:
                lifted = self.yard.now + (self.battery.low * self.battery.capacity - self.level) / self.battery.charge_rate
                self.yard.call_at(max(lifted, self.yard.now), self.restored, self._charge, priority=COMPLETION)
        elif kind == "stopCharging":
            self.level, self.charging_since = self.charge(), None
            self._charge += 1
            self.check_low()
        return True, ""

    def duration(self, action_type: str) -> float:
        durations = self.yard.scenario.settings.durations
        return {"pick": durations.get("load", 0.0), "drop": durations.get("unload", 0.0),
                "finePositioning": durations.get("fine_positioning", 0.0)}.get(action_type, 0.0)

    def in_reach(self, station_id: str) -> bool:
        s = next(s for s in self.yard.scenario.stations if s.id == station_id)
        return math.hypot(s.position[0] - self.x, s.position[1] - self.y) <= s.reach

    # --- the battery -------------------------------------------------------------------------------------

    def charge(self) -> float:
        """The battery's level now (Ah)."""
        if self.battery is None or self.charging_since is None:
            return self.level
        return min(self.battery.capacity, self.level + self.battery.charge_rate * (self.yard.now - self.charging_since))

    def drain(self, metres: float) -> None:
        if self.battery is not None:
            self.level = max(0.0, self.level - self.battery.per_metre * metres)
            self.check_low()

    def check_low(self) -> None:
        if self.battery is not None and (self.charge() < self.battery.low * self.battery.capacity) != self.low:
            self.low = not self.low
            self.apply(self.vehicle.on_battery_low(self.yard.now, self.low))

    def where(self) -> Where:
        return Where(self.x, self.y, self.theta, self.odometer)

    def body(self) -> Body:
        percent = None if self.battery is None else 100.0 * self.charge() / self.battery.capacity
        return Body(self.where(), battery=percent, loads=tuple(self.loads))
