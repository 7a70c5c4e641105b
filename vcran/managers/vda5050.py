"""The reference VDA 5050 master: :class:`MasterControl` (docs/contract.md §11). docs/vda5050.md ("The reference master")
walks through it; it is OPIL's :class:`~vcran.managers.Dispatcher` told in orders instead of tasks. One concept,
the reference master's decisions, kept in one file (a little over 450 lines) so that it reads in one sitting.

* Jobs wait in a queue: higher ``priority`` first, then in arrival order.
* Whenever a job waits and a vehicle is idle, the job at the head goes to the idle vehicle nearest to its
  pickup: by route length on the roadmap (in a straight line without one); of equals, the one listed first.
* A job is two *errands* of that vehicle: to the pickup's dock to ``pick``, then to the drop-off's dock to
  ``drop`` (HARD node actions at the route's last node, with the station's ``stationName``). An errand is
  one order and its updates; when the drop is FINISHED the job is done.
* Routes run on the roadmap through node reservations (:mod:`vcran.core.traffic.reservations`): the
  order's base is the stretch reserved (up to the next waiting node, or the goal), its horizon the rest of
  the route. The next stretch is reserved when the vehicle stands at the end of its base (it asks with
  ``newBaseRequest`` on the way) and goes out as an order update; a route the reservations send to a
  waiting node first (a detour) goes on from there the same way. So vehicles neither meet nor deadlock.
  Without a roadmap (or with ``routing="straight"``) a vehicle drives straight to the dock, the whole order
  released, and vehicles may meet.
* Outcomes come from each vehicle's ``state``: the errand's order (its latest update) is over when no
  nodeStates are left and its action is FINISHED or FAILED. An action FAILED, an order given up
  (``motionFailed``, ``collision``, ``batteryEmpty``) or cancelled, or an order the vehicle refused, costs
  the job a try: the same vehicle tries again from where it stands (a pick that found nothing, in place)
  after ``retry_after`` seconds, doubled for each further try. After ``max_tries`` the job is failed with the
  reason. A vehicle with a FATAL error gets no order until the error has cleared.
* Messages travel at QoS 0 (§6.2) and may be lost (the scenario's ``[link] loss``; any broker): an order that a
  vehicle's state shows neither taken nor refused ``resend_after`` seconds after it went out is sent again; a
  vehicle on an errand that has been quiet for its state interval (30 s) plus ``resend_after`` (its periodic
  state was lost too) is sent a ``stateRequest``, again every ``resend_after`` until it is heard; a
  ``stopCharging`` is sent again when a state ``resend_after`` later still shows the vehicle charging. A lost
  state costs nothing else: every state carries the whole picture.
* Charging: a vehicle without a job whose battery is below ``charge_below`` (a fraction) goes to the
  nearest charger and ``startCharging`` there; at ``charge_until`` it is sent ``stopCharging`` (a vehicle
  that is full stops by itself) and works again.
* Parking: a vehicle left without work on a station's dock goes to the nearest free waiting node, since the
  reservations treat a vehicle at rest as a wall; a roadmap without waiting nodes leaves it there.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass, field

from vcran.core.manager import Timer
from vcran.core.scenario import Job
from vcran.core.traffic.reservations import Move, Reservations
from vcran.core.vda5050.builder import Stop, action
from vcran.core.vda5050.enums import ActionStatus, ErrorLevel
from vcran.core.vda5050.master import Master
from vcran.core.vda5050.order import Action
from vcran.core.vda5050.state import State

PICK, DROP, CHARGE, PARK = "pick", "drop", "charge", "park"
#: The error a state reports -> the reason a job fails for (vcran.core.jobs.FAILURE_REASONS).
REASONS = {"batteryEmpty": "battery_empty", "motionFailed": "motion_failed", "collision": "collision"}
REFUSALS = frozenset({"validationError", "orderError", "orderUpdateError"})


@dataclass(slots=True)
class Trip:
    """A job on its way: its phase (pick, then drop) and how many errands it lost."""

    job: Job
    arrival: int
    phase: str = PICK
    tries: int = 0

    @property
    def order(self) -> tuple[int, int]:
        return -self.job.priority, self.arrival


@dataclass(slots=True)
class Errand:
    """What a vehicle is doing: drive to ``goal`` (a roadmap node; a station without a roadmap) to perform
    ``kind`` there, as order ``order_id``; ``ahead``: the reserved nodes it has not reached, with sequenceIds."""

    kind: str
    station: str | None
    goal: str
    order_id: str
    action_id: str | None
    ahead: list[tuple[str, int]] = field(default_factory=list)


class MasterControl(Master):
    """FIFO jobs, nearest idle vehicle, routes reserved on the roadmap stretch by stretch, retries with
    back-off, charging below ``charge_below`` (module docstring)."""

    topics = frozenset({"state"})

    def __init__(self, max_tries: int = 3, retry_after: float = 10.0, charge_below: float = 0.3,
                 charge_until: float = 1.0, routing: str = "roadmap", resend_after: float = 5.0) -> None:
        if max_tries < 1:
            raise ValueError(f"max_tries must be at least 1, got {max_tries}")
        for name, value in (("retry_after", retry_after), ("resend_after", resend_after)):
            if not (value >= 0 and math.isfinite(value)) or (name == "resend_after" and value == 0):
                raise ValueError(f"{name} must be a finite number of seconds > 0, got {value}")
        if not 0.0 <= charge_below < charge_until <= 1.0:
            raise ValueError(f"0 <= charge_below < charge_until <= 1 (fractions), got {charge_below}, {charge_until}")
        if routing not in ("roadmap", "straight"):
            raise ValueError(f"routing is 'roadmap' or 'straight', got {routing!r}")
        self.max_tries, self.retry_after, self.resend_after = max_tries, retry_after, resend_after
        self.charge_below, self.charge_until, self.routing = charge_below, charge_until, routing

    def on_start(self) -> None:
        self.queue: list[Trip] = []                   # jobs waiting for a vehicle, head first
        self.movers = [s for s in self.fleet.serials  # vehicles that may get jobs
                       if self.fleet.vehicle(s).performs(PICK) and self.fleet.vehicle(s).performs(DROP)]
        self.idle: list[str] = list(self.movers)      # vehicles without work, in fleet order
        self.trips: dict[str, Trip] = {}              # vehicle -> the job it works on
        self.errands: dict[str, Errand] = {}          # vehicle -> what it is doing
        self.charging: set[str] = set()               # vehicles charging at a charger
        self.stopping: dict[str, float] = {}          # ... that were sent stopCharging, when
        self.stalled: set[str] = set()                # vehicles waiting for a FATAL error to clear
        self.heard: dict[str, float] = {}             # vehicle -> when its latest state arrived
        self.watchdogs: dict[str, Timer] = {}         # vehicle on an errand -> when to ask for its state
        self._rank = {s: i for i, s in enumerate(self.fleet.serials)}
        self._arrivals = self._errands = 0
        self.graph = self.fleet.graph if self.routing == "roadmap" else None
        self.reservations = Reservations(self.graph) if self.graph is not None else None
        self.parking: list[str] = []                  # waiting nodes, where idle vehicles stand aside
        if self.graph is not None and self.reservations is not None:
            for serial in self.fleet.serials:
                x, y, _ = self.fleet.vehicle(serial).robot.pose
                node = self.fleet.node_at(x, y, self.fleet.vehicle(serial).config.node_tolerance)
                if node is None:
                    raise ValueError(f"vehicle {serial} starts at ({x:g}, {y:g}), on no node of the roadmap")
                self.reservations.place(serial, node)
            self.parking = [n.id for n in self.graph.nodes.values() if n.waiting]
        self.docks = {self.goal(s.id) for s in self.fleet.stations} - set(self.parking)

    def on_job(self, job: Job) -> None:
        self._arrivals += 1
        bisect.insort(self.queue, Trip(job, self._arrivals), key=lambda trip: trip.order)
        self.dispatch()

    def on_state(self, serial: str, state: State) -> None:
        self.heard[serial] = self.handle.now
        errand = self.errands.get(serial)
        if errand is not None:
            self.follow(serial, errand, state)
        elif serial in self.charging:
            self.watch_charge(serial, state)
        elif serial in self.stalled and not _fatal(state):
            self.stalled.discard(serial)
            if serial in self.trips:
                self.retry(serial)
            else:
                self.available(serial)
        elif serial in self.idle and self.low(state) and self.fleet.chargers():
            self.idle.remove(serial)
            self.charge(serial)

    # --- decisions ----------------------------------------------------------------------------------------

    def dispatch(self) -> None:
        """Give waiting jobs to idle vehicles, head of the queue first (none can take them: ``unassignable``)."""
        if self.queue and not self.movers:
            for trip in self.queue:
                self.handle.job_failed(trip.job, "unassignable")
            self.queue.clear()
        while self.queue and self.idle:
            trip = self.queue.pop(0)
            serial = self.nearest_idle(trip.job.pickup)
            self.idle.remove(serial)
            self.trips[serial] = trip
            self.go(serial, self.errand(trip))

    def nearest_idle(self, station: str) -> str:
        """The idle vehicle with the shortest route to ``station``'s dock; of equals, the first listed."""
        return min(self.idle, key=lambda serial: self.distance(serial, self.goal(station)))

    def follow(self, serial: str, errand: Errand, state: State) -> None:
        """A state of a vehicle on an errand: release what it passed, and judge the order once it is over."""
        line = self.handle.line(serial)
        if _refused(state, errand.order_id, line.order_update_id):
            self.errand_failed(serial, errand, "rejected")
            return
        if state.order_id != errand.order_id:
            return  # the order is on its way
        if self.reservations is not None:
            passed = False
            while errand.ahead and errand.ahead[0][1] <= state.last_node_sequence_id:
                self.reservations.reached(serial, errand.ahead.pop(0)[0])
                passed = True
            if passed or state.new_base_request:
                self.advance()
        if state.order_update_id != line.order_update_id or state.node_states or state.driving:
            return
        status = next((a.action_status for a in state.action_states if a.action_id == errand.action_id), None)
        if errand.action_id is not None and status is not ActionStatus.FINISHED:
            if status is ActionStatus.FAILED:
                self.errand_failed(serial, errand, _reason(state, "action_failed"))
            elif status is None:  # never sent: the order ended before its goal
                self.ended_short(serial, errand, state)
            return
        at = self.at(serial, state)
        if at == errand.goal or (errand.kind == PARK and at in self.parking and not self.on_route(serial)):
            self.errand_done(serial, errand)  # parked: on the waiting node asked for, or one it was sent to first
        else:
            self.ended_short(serial, errand, state)

    def on_route(self, serial: str) -> bool:
        """Whether ``serial`` holds reserved nodes it has not reached yet."""
        return self.reservations is not None and len(self.reservations.held(serial)) > 1

    def ended_short(self, serial: str, errand: Errand, state: State) -> None:
        """The order is over but the vehicle is not at the goal: given up on the way (reserved nodes ahead
        of it it did not reach), or at the end of a detour or of a stretch (its route goes on when the next
        stretch is reserved), or at the end of a route reserved before (the goal is asked for now)."""
        if self.reservations is None or self.on_route(serial):
            self.errand_failed(serial, errand, _reason(state, "cancelled"))
        elif serial not in self.reservations.routes() and serial not in self.reservations.pending():
            self.reservations.request(serial, errand.goal)
            self.advance()

    def errand_done(self, serial: str, errand: Errand) -> None:
        self.end_errand(serial)
        trip = self.trips.get(serial)
        if errand.kind == CHARGE:
            self.charging.add(serial)
        elif errand.kind == PARK or trip is None:
            self.available(serial)
        elif trip.phase == PICK:
            trip.phase = DROP
            self.go(serial, self.errand(trip))
        else:
            self.handle.job_done(trip.job)
            del self.trips[serial]
            self.available(serial)

    def errand_failed(self, serial: str, errand: Errand, reason: str) -> None:
        """A try lost: again after the back-off, or the job failed after ``max_tries``; a charge or a park
        that failed leaves the vehicle idle (it charges, or parks, when next free) once it holds no route."""
        self.end_errand(serial)
        if self.reservations is not None and serial in self.reservations.pending():
            self.reservations.request(serial, self.reservations.held(serial)[0])  # withdrawn: it stays
        trip = self.trips.get(serial)
        if trip is None:  # a charge or a park
            if self.on_route(serial):
                self.available(serial)  # to the end of the route it holds, first
            else:
                self.idle_again(serial)
            return
        trip.tries += 1
        if trip.tries >= self.max_tries:
            self.handle.job_failed(trip.job, reason)
            del self.trips[serial]
            self.available(serial)
        else:
            self.handle.call_later(self.retry_after * 2 ** (trip.tries - 1), self.retry, serial)

    def retry(self, serial: str) -> None:
        """The back-off is over: the errand again, unless the vehicle is not in running condition."""
        if _fatal(self.handle.state(serial)):
            self.stalled.add(serial)  # on_state retries when the FATAL error has cleared
        else:
            self.go(serial, self.errand(self.trips[serial]))

    def watch_charge(self, serial: str, state: State) -> None:
        """Charging until ``charge_until``: then stopCharging; idle once the vehicle says it stopped."""
        battery = state.battery_state
        if not battery.charging:
            self.charging.discard(serial)
            self.stopping.pop(serial, None)
            self.available(serial)
        elif battery.battery_charge >= 100.0 * self.charge_until and \
                self.handle.now >= self.stopping.get(serial, -math.inf) + self.resend_after:
            self.stopping[serial] = self.handle.now  # again if it was lost: still charging resend_after later
            self.handle.instant(serial, "stopCharging")

    def low(self, state: State | None) -> bool:
        return state is not None and state.battery_state.battery_charge < 100.0 * self.charge_below

    # --- errands ------------------------------------------------------------------------------------------

    def errand(self, trip: Trip) -> Errand:
        """The errand of ``trip``'s phase, named ``{job}_{phase}{try}``."""
        station = trip.job.pickup if trip.phase == PICK else trip.job.dropoff
        name = f"{trip.job.id}_{trip.phase}{trip.tries + 1}"
        return Errand(trip.phase, station, self.goal(station), name, f"{name}_{trip.phase}")

    def charge(self, serial: str) -> None:
        """To the nearest charger, to charge there."""
        station = min(self.fleet.chargers(), key=lambda s: self.distance(serial, self.goal(s)))
        self._errands += 1
        name = f"charge{self._errands}_{serial}"
        self.go(serial, Errand(CHARGE, station, self.goal(station), name, f"{name}_startCharging"))

    def available(self, serial: str) -> None:
        """``serial`` has no work: to the end of a route it still holds, to a charger when low, off a dock
        when it stands on one, else idle."""
        state = self.handle.state(serial)
        route = self.reservations.routes().get(serial) if self.reservations is not None else None
        if _fatal(state):
            self.stalled.add(serial)
        elif route is not None:  # a job that failed on the way: drive on, or the nodes ahead stay held for good
            self._errands += 1
            self.go(serial, Errand(PARK, None, route[-1], f"park{self._errands}_{serial}", None))
        elif self.low(state) and self.fleet.chargers():
            self.charge(serial)
        elif not (self.reservations is not None and self.reservations.held(serial)[0] in self.docks
                  and self.park(serial)):
            self.idle_again(serial)

    def park(self, serial: str) -> bool:
        """To the nearest waiting node nobody holds or goes to; False if there is none."""
        assert self.reservations is not None
        taken = set(self.reservations.holder) | {e.goal for e in self.errands.values()}
        free = [n for n in self.parking if n not in taken]
        if not free:
            return False
        self._errands += 1
        node = min(free, key=lambda n: self.distance(serial, n))
        self.go(serial, Errand(PARK, None, node, f"park{self._errands}_{serial}", None))
        return True

    def idle_again(self, serial: str) -> None:
        bisect.insort(self.idle, serial, key=self._rank.__getitem__)
        self.dispatch()

    # --- orders -------------------------------------------------------------------------------------------

    def go(self, serial: str, errand: Errand) -> None:
        """Start ``errand``: an order straight to the dock; on the roadmap, from where the vehicle stands, the
        rest of a route it was reserved before (an order given up on the way), or a route asked for."""
        self.errands[serial] = errand
        if serial not in self.watchdogs:
            self.watch(serial, self.handle.now + self.quiet_after(serial))
        if self.reservations is None:
            here = self.here(serial)
            self.send(serial, errand, [here] if here.node_id == errand.goal else [here, self.dock(errand)], None)
            return
        route = self.reservations.routes().get(serial)
        held = self.reservations.held(serial)
        if route is not None:
            self.send(serial, errand, [self.here(serial), *self.fleet.stops(route)], len(held))
        elif held[0] == errand.goal:
            self.send(serial, errand, [self.here(serial)], None)
        else:
            self.reservations.request(serial, errand.goal)
            self.advance()

    def advance(self) -> None:
        """Reserve what can be now, and send each stretch reserved."""
        assert self.reservations is not None
        for move in self.reservations.step():
            self.drive(move)

    def drive(self, move: Move) -> None:
        """A stretch reserved: the errand's order if it has none yet, else the next update of it."""
        assert self.reservations is not None
        serial, errand = move.robot, self.errands[move.robot]
        stops = self.fleet.stops([self.reservations.held(serial)[0], *self.reservations.routes()[serial]])
        if self.handle.line(serial).order_id != errand.order_id:
            stops[0] = self.here(serial)
            self.send(serial, errand, stops, 1 + len(move.nodes))
            return
        actions = self.actions(errand) if stops[-1].node_id == errand.goal else ()
        order = self.handle.extend(serial, stops[1:], base=len(move.nodes), actions=actions)
        errand.ahead = [(n.node_id, n.sequence_id) for n in order.nodes[1:] if n.released]
        self.handle.call_later(self.resend_after, self.arrived, serial, order.order_id, order.order_update_id)

    def send(self, serial: str, errand: Errand, stops: list[Stop], base: int | None) -> None:
        """The errand's order along ``stops``, its action at the end if that is the goal."""
        actions = self.actions(errand) if stops[-1].node_id == errand.goal else ()
        trip = self.trips.get(serial) if errand.kind in (PICK, DROP) else None
        order = self.handle.order(serial, stops, base=base, actions=actions, order_id=errand.order_id,
                                  job=trip.job if trip is not None else None)
        errand.ahead = [(n.node_id, n.sequence_id) for n in order.nodes[1:] if n.released]
        self.handle.call_later(self.resend_after, self.arrived, serial, order.order_id, order.order_update_id)

    def arrived(self, serial: str, order_id: str, update_id: int) -> None:
        """``resend_after`` seconds after an order (update) went out: if it is still the vehicle's latest and
        its state shows it neither taken nor refused, it was lost (QoS 0, §6.2): again, and check again."""
        line, state, errand = self.handle.line(serial), self.handle.state(serial), self.errands.get(serial)
        if (line.order_id, line.order_update_id) != (order_id, update_id) or errand is None \
                or errand.order_id != order_id:
            return
        if state is not None and ((state.order_id, state.order_update_id) == (order_id, update_id)
                                  or _refused(state, order_id, update_id)):
            return
        self.handle.resend(serial)
        self.handle.call_later(self.resend_after, self.arrived, serial, order_id, update_id)

    def end_errand(self, serial: str) -> None:
        del self.errands[serial]
        watchdog = self.watchdogs.pop(serial, None)
        if watchdog is not None:
            watchdog.cancel()  # a pending timer would keep the run from ending

    def quiet_after(self, serial: str) -> float:
        """How long a vehicle on an errand may be quiet: its periodic state is then overdue by ``resend_after``."""
        return self.fleet.vehicle(serial).config.state_interval + self.resend_after

    def watch(self, serial: str, when: float) -> None:
        self.watchdogs[serial] = self.handle.call_at(when, self.quiet, serial)

    def quiet(self, serial: str) -> None:
        """The watchdog of a vehicle on an errand: not heard from for :meth:`quiet_after` seconds, its states
        (the periodic one too) were lost: ask for one (``stateRequest``), and again ``resend_after`` later."""
        due = self.heard.get(serial, 0.0) + self.quiet_after(serial)
        if self.handle.now < due:
            self.watch(serial, due)  # heard meanwhile: the same sum, so exactly then
        else:
            self.handle.instant(serial, "stateRequest")
            self.watch(serial, self.handle.now + self.resend_after)

    def actions(self, errand: Errand) -> list[Action]:
        if errand.action_id is None:
            return []
        if errand.kind == CHARGE:
            return [action("startCharging", errand.action_id, "HARD")]
        return [action(errand.kind, errand.action_id, "HARD", stationName=errand.station)]

    # --- where things are ---------------------------------------------------------------------------------

    def goal(self, station: str) -> str:
        """Where an errand to ``station`` ends: its dock's roadmap node, or the station itself."""
        node = self.fleet.dock_node(station) if self.graph is not None else None
        return node if node is not None else station

    def at(self, serial: str, state: State) -> str:
        """The node ``serial`` stands on: as reserved, or (without a roadmap) as its state says."""
        return self.reservations.held(serial)[0] if self.reservations is not None else state.last_node_id

    def here(self, serial: str) -> Stop:
        """Where ``serial`` stands, as the first node of a new order: the roadmap node (without a roadmap,
        the station's dock) it stands on, else a node of its own there."""
        x, y, _ = self.handle.position(serial)
        tolerance = self.fleet.vehicle(serial).config.node_tolerance
        if self.reservations is not None:
            node = self.reservations.held(serial)[0]
            if self.fleet.node_at(x, y, tolerance) == node:
                return self.fleet.stops([node])[0]
        else:
            for s in self.fleet.stations:
                if math.dist(self.fleet.dock(s.id)[:2], (x, y)) <= tolerance:
                    return Stop(s.id, x, y)
        return Stop(f"{serial}_here", x, y)

    def dock(self, errand: Errand) -> Stop:
        assert errand.station is not None
        x, y, theta = self.fleet.dock(errand.station)
        return Stop(errand.station, x, y, theta)

    def distance(self, serial: str, goal: str) -> float:
        """Route length from ``serial`` to ``goal`` on the roadmap (inf: no route), else a straight line."""
        if self.graph is not None and self.reservations is not None:
            route = self.graph.route(self.reservations.held(serial)[0], goal)
            return route.length if route is not None else math.inf
        x, y, _ = self.handle.position(serial)
        gx, gy, _ = self.fleet.dock(goal)
        return math.hypot(gx - x, gy - y)


def _fatal(state: State | None) -> bool:
    return state is not None and any(e.error_level is ErrorLevel.FATAL for e in state.errors)


def _reason(state: State, default: str) -> str:
    """Why an order ended short, from the errors it left (the first that names a halt), else ``default``."""
    return next((REASONS[e.error_type] for e in state.errors if e.error_type in REASONS), default)


def _refused(state: State, order_id: str, update_id: int) -> bool:
    """Whether ``state`` reports the vehicle refused that order (update): an error naming both ids."""
    for e in state.errors:
        if e.error_type in REFUSALS:
            refs = {r.reference_key: r.reference_value for r in e.error_references or ()}
            if refs.get("orderId") == order_id and refs.get("orderUpdateId") == str(update_id):
                return True
    return False
