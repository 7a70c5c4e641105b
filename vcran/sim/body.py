"""A robot's body: the AGV that drives legs and AgvAction that performs actions (docs/contract.md §1, docs/contract.md §4), shared by
every protocol (docs/protocols.md).

The body decides nothing a protocol decides. A protocol's pure vehicle logic (OPIL: RanLogic; VDA 5050: the
Vehicle) runs in a process of its protocol's glue (:mod:`vcran.sim.opil.node`), which turns the logic's effects
into the body's commands and feeds the body's reports back to the logic. The AGV (here) drives the legs it is
given, analytically, one event per leg however long the leg; AgvAction (:mod:`vcran.sim.agvaction`) performs
actions at stations and chargers; :mod:`vcran.sim.holds` holds and halts them, :mod:`vcran.sim.energy` runs
their battery. Each is a mixin of :class:`Body`.

Commands (what a logic's effects become):

* ``route``: the waypoints still to drive, a deque the glue edits; :meth:`Body.drive` replaces it (OPIL's
  DispatchPath), :meth:`Body.extend` appends to it, also while a leg runs (VDA 5050's Drive),
  :meth:`Body.stop_after_leg` empties it (R8), :meth:`Body.skip` drops waypoints not driven yet (R13),
  :meth:`Body.stop_now` stops where the robot is and drops the route; ``wake(token)`` tells the AGV a route
  is there (what ``drive`` and ``extend`` do after editing it);
* ``act((token, kind, tag))`` queues an action (an :class:`~vcran.core.actions.ActionKind`), performed one at
  a time, in order, as the robot's work; :meth:`~vcran.sim.agvaction.AgvAction.perform` starts one at once
  beside everything else (several at once, also while driving), and
  :meth:`~vcran.sim.agvaction.AgvAction.interrupt` stops such a one, nothing of it happening;
* :meth:`~vcran.sim.holds.Holds.abandon` (R14: the leg or action that began at this instant does not
  happen), :meth:`~vcran.sim.holds.Holds.hold` / :meth:`~vcran.sim.holds.Holds.release` (pause, breakdown:
  resume exactly where it stopped), :meth:`~vcran.sim.holds.Holds.halt` (stop for good, reported);
  :meth:`Body.place` sets the pose of a body at rest.

``token`` names the work a route or a queued action belongs to: when the AGV or AgvAction gets to it, it runs
only if ``token == current()`` (the work may have ended while it waited, e.g. when the body halted meanwhile).

Reports, handed to the glue's ``tell`` hook in the order they happen: :class:`Reached` (a waypoint),
:class:`~vcran.sim.agvaction.Acted` (an action's tag, ok, code, message), :class:`~vcran.sim.holds.Halted`
(why, message, out of service), :class:`~vcran.sim.holds.InService`. Read-only state: ``pose`` (at rest),
:meth:`~vcran.sim.energy.Energy.position`, :meth:`Body.motion` (pose and speeds now), :meth:`Body.odometer`,
``driving``, ``working``, ``holds``, ``beside``, ``carrying``, ``parts_moved``, ``empty``, and the battery's
:meth:`~vcran.sim.energy.Energy.charge`.

Hooks the glue sets before :meth:`Body.start`: ``tell(report)``, ``current()``, ``plan(waypoint) -> Leg``
(how its waypoints become legs; the default, :meth:`Body.leg_to`, takes a :class:`Waypoint`),
``changed(body)`` (what the body shows changed: the load), ``log(body, event)`` (every incident for the run's
log: faults starting and ending, battery low, empty, swapped, collisions; a protocol whose logic takes some
of them as inputs takes them there) and ``report(code, message, severity)`` (an incident the fleet manager
would notice, for the protocol to publish; OPIL: a ``ran_error``).
"""

from __future__ import annotations

import dataclasses
from collections import deque
from collections.abc import Callable, Generator, Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import simpy

from vcran.core.actions import ActionKind
from vcran.core.battery import DRIVE, REST, FleetBattery, leg_cut, linear_empty_after
from vcran.core.motion import FleetKinematics, Leg, Limits
from vcran.core.scenario import RobotConfig
from vcran.core.stations import StationMap
from vcran.core.traffic.braking import Braking
from vcran.sim.agvaction import AgvAction
from vcran.sim.energy import Energy
from vcran.sim.holds import ABANDON, HOLD, RELEASE, STOP, Cause, Halted, Holds
from vcran.sim.mailbox import Mailbox
from vcran.sim.timing import COMPLETION, after, at

if TYPE_CHECKING:
    from vcran.sim.traffic import SafetyFields

Process = Generator[simpy.events.Event, Any, None]

# --- reports ----------------------------------------------------------------------------------------------
# Made by one process and read once by another, never changed. The two sent for every task are not
# ``frozen``: a frozen dataclass pays an ``object.__setattr__`` per field to build (issue 14).


@dataclass(slots=True)
class Reached:
    """The body reached ``waypoint`` (the route's item, as the glue gave it)."""

    waypoint: Any


@dataclass(frozen=True, slots=True)
class Waypoint:
    """A waypoint of the default plan (:meth:`Body.leg_to`): drive to ``(x, y)``, turn to ``theta`` there if
    given, within the robot's limits lowered by those asked for (0: none)."""

    x: float
    y: float
    theta: float | None = None
    speed: float = 0.0
    accel: float = 0.0
    turn_rate: float = 0.0
    tag: Any = None


def _unreported(code: str, message: str, severity: str = "warning") -> None:
    """The ``report`` hook of a body without a protocol: nobody to tell."""


class Body(Holds, Energy, AgvAction):
    """One robot's AGV and AgvAction (module docstring)."""

    def __init__(
        self,
        env: simpy.Environment,
        index: int,
        config: RobotConfig,
        fleet: FleetKinematics,
        stations: StationMap,
        durations: dict[str, float],
        battery: FleetBattery | None = None,
    ) -> None:
        self.env, self.index, self.config = env, index, config
        self.id = config.id
        self.fleet, self.stations, self.durations = fleet, stations, durations
        self.pose = config.pose
        self._carrying = config.carrying
        self.parts_moved = 0
        self._capable = frozenset(ActionKind(a) for a in config.actions)
        #: The last leg limits built, with what they were asked for (:meth:`limits`).
        self._last_limits: tuple[tuple[float, float, float], Limits] | None = None
        #: The waypoints still to drive (module docstring). ``_commands`` only wakes the AGV up.
        self.route: deque[Any] = deque()
        self._commands = Mailbox(env)
        self._orders = Mailbox(env)
        self.wake: Callable[[Any], None] = self._commands.put
        self.act: Callable[[tuple[Any, ActionKind, Any]], None] = self._orders.put
        self._init_holds()
        self._init_energy(battery)
        self._init_actions()
        self._agv_process: simpy.Process | None = None
        if self.battery is not None:
            self._capable |= {ActionKind.CHARGE}
        self.fail_next_action = False
        #: Observers of "this robot's occupancy changed" (collision detection), called with the body.
        self.on_move: Callable[[Body], None] | None = None
        #: The fleet's safety fields (docs/contract.md §12; None: none), told of every leg and rest (vcran.sim.traffic).
        self.fields: SafetyFields | None = None
        # The glue's hooks (module docstring); these defaults serve a body driven without a protocol.
        self.tell: Callable[[object], None] = lambda report: None
        self.current: Callable[[], Any] = lambda: None
        self.plan: Callable[[Any], Leg] = self.leg_to
        self.changed: Callable[[Body], None] = lambda body: None
        self.log: Callable[[Body, Any], None] = lambda body, event: None
        self.report: Callable[..., None] = _unreported  # (code, message, severity="warning")

    def start(self) -> None:
        """Start the AGV and AgvAction (after the glue's own process, if it has one)."""
        self._agv_process = self.env.process(self._agv())
        self.env.process(self._agv_action())

    @property
    def carrying(self) -> int:
        """The parts on board. A protocol's status shows them (OPIL: ``ran_status``, docs/contract.md §2), so a change
        is a change of what the body shows: ``changed`` is called."""
        return self._carrying

    @carrying.setter
    def carrying(self, parts: int) -> None:
        if parts != self._carrying:
            self._carrying = parts
            self.changed(self)

    @property
    def driving(self) -> bool:
        return self.index in self.fleet.current

    def motion(self) -> tuple[float, float, float, float, float]:
        """``(x, y, theta, linear speed, angular speed)`` now: on the running leg, or at rest."""
        leg = self.fleet.current.get(self.index)
        return leg.pose_at(self.env.now) if leg is not None else (*self.pose, 0.0, 0.0)

    def odometer(self) -> float:
        """Metres driven since the run began, the running leg's so far included."""
        return self.fleet.distance(self.index, self.env.now)

    def log_incident(self, event: Any) -> None:
        self.log(self, event)

    # --- commands on the route --------------------------------------------------------------------------

    def drive(self, waypoints: Iterable[Any], token: Any = None) -> None:
        """Drive these waypoints in place of any not driven yet."""
        self.route = deque(waypoints)
        self.wake(token)

    def extend(self, waypoints: Iterable[Any], token: Any = None) -> None:
        """Drive these waypoints after those already on the route (also while a leg runs)."""
        self.route.extend(waypoints)
        self.wake(token)

    def stop_after_leg(self) -> None:
        """The running leg finishes; nothing after it (R8)."""
        self.route.clear()

    def skip(self, dropped: Callable[[Any], bool]) -> None:
        """Drop the waypoints not driven yet for which ``dropped`` holds (R13)."""
        self.route = deque(w for w in self.route if not dropped(w))

    def stop_now(self) -> None:
        """Stop where the robot is, mid-leg if need be, and drop the route (VDA 5050's StopNow): the running
        leg ends there, unreported; a held one ends where it was held. Actions are not affected."""
        self.route.clear()
        if self._worker is not None and self._worker is self._agv_process:  # driving, or held before or on a leg
            self._worker.interrupt(STOP)

    def place(self, x: float, y: float, theta: float) -> None:
        """Set the pose of a body at rest (VDA 5050's initPosition: in simulation, belief is truth)."""
        if self.driving or self.index in self.fleet.held:
            raise RuntimeError(f"{self.id}: a body is placed at rest, not during a leg")
        self.pose = (x, y, theta)
        self.fleet.place(self.index, self.env.now, self.pose)
        self._rested()

    # --- AGV --------------------------------------------------------------------------------------------

    def _agv(self) -> Process:
        while True:
            token = yield self._commands.get()  # a route of ``token`` is there
            if token != self.current():
                continue  # the work it meant has already ended (the robot stopped on its own)
            while self.route:
                waypoint = self.route.popleft()
                if self._holds:
                    halt = yield from self._held()
                    if halt is not None:
                        self._stopped(halt)
                        break
                leg = self.plan(waypoint)
                halt = yield from self._drive(leg)
                if halt is not None:
                    self._stopped(halt)
                    break
                self.fleet.finish(self.index)
                self.pose = self.fleet.rest[self.index]  # the leg's end (or, braked on it, the rest's: docs/contract.md §12)
                self.tell(Reached(waypoint))
                if not self.route or self._holds:  # else the next leg starts now, from this pose
                    self._segment(REST)
                    self._rested()

    def _drive(self, leg: Leg) -> Generator[simpy.events.Event, Any, Cause]:
        """Drive ``leg`` to its end (None), until the robot stops on its own (the :class:`Halted`), or
        :data:`ABANDON` (R14: the robot stays where the leg began), or :data:`STOP` (stop_now).

        A hold stops the robot where it is and later resumes the same leg shifted in time by the hold's
        length, so the rest of the leg (and the task) ends exactly that much later (docs/contract.md §4 breakdown).

        With safety fields (docs/contract.md §12, :class:`vcran.sim.traffic.SafetyFields`) a robot blocked brakes: the
        running stretch stops where it is and the braked stretch is driven (:meth:`brake`), then the robot
        waits at rest, its leg not done, until it drives the rest of it (:meth:`drive_on`), whose end is the
        leg's. A hold or a stop ends a block (the fields are told the robot rests); a hold released then
        drives the rest of the leg from where the robot stands, as a new leg.
        """
        i, env, fields = self.index, self.env, self.fields
        self.fleet.start(i, leg)
        if fields is not None:
            fields.drive(i, leg)
        level = self._segment(DRIVE)
        self._moved()
        stretch: Leg | None = leg  # what the robot drives now; None: stopped after braking, waiting
        braked = False  # the stretch is a braked one, or the robot waits after one: its end is not the leg's
        while True:
            if stretch is None:
                cut = (linear_empty_after(self._level(), self._rate()) if self.battery is not None and not self.empty
                       else float("inf"))
                reaches = False
                end = after(env, cut, COMPLETION) if cut != float("inf") else env.event()
            else:
                if self.battery is None or self.empty:
                    cut = float("inf")
                else:
                    c = self.config.battery
                    assert c is not None
                    cut = leg_cut(c, stretch, self._level() if level is None else level, env.now)
                reaches = cut >= stretch.t_end - env.now
                end = at(env, stretch.t_end, COMPLETION) if reaches else after(env, cut, COMPLETION)
            level = None
            cause = yield from self._work(end)
            if cause is RELEASE:
                continue
            if type(cause) is Braking:  # docs/contract.md §12: stop this stretch where it is, drive the braked one
                self.pose = self.fleet.stop(i, env.now)
                stretch, braked = cause.stop, True
                if stretch is not None:
                    self.fleet.start(i, stretch)
                self._segment(REST if stretch is None else DRIVE)
                self._moved()
                continue
            if type(cause) is Leg:  # docs/contract.md §12: drive the rest of the leg
                if i in self.fleet.current:  # the braked stretch ends at this very instant
                    self.fleet.finish(i)
                stretch, braked = cause, False
                self.fleet.start(i, stretch)
                level = self._segment(DRIVE)
                self._moved()
                continue
            if cause is None:
                if reaches:
                    if not braked:
                        return None
                    self.fleet.finish(i)  # stopped after braking: wait to drive on
                    self.pose, stretch = self.fleet.rest[i], None
                    self._segment(REST)
                    self._moved()
                    continue
                cause = self._battery_empty_halt()
            elif cause is ABANDON:
                if i in self.fleet.current:
                    self.fleet.abandon(i, env.now)
                self._segment(REST)
                self._rested()
                return cause
            elif cause is HOLD:
                t_hold = env.now
                if stretch is not None:
                    self.pose = self.fleet.hold(i, t_hold)
                self._segment(REST)
                self._rested()
                cause = yield from self._held()
                if cause is None:
                    if braked:  # the hold ended the block: the rest of the leg from here, as a new leg
                        if stretch is not None:
                            self.fleet.drop_held(i)
                        stretch, braked = Leg(env.now, *self.pose, leg.x1, leg.y1, leg.theta_goal, leg.limits), False
                        self.fleet.start(i, stretch)
                    else:
                        assert stretch is not None
                        stretch = dataclasses.replace(stretch, t0=stretch.t0 + (env.now - t_hold))
                        self.fleet.resume(i, stretch, env.now)
                    if fields is not None:
                        fields.drive(i, stretch)
                    self._segment(DRIVE)
                    self._moved()
                    continue
                if i in self.fleet.held:
                    self.fleet.drop_held(i)
                return cause
            assert cause is STOP or isinstance(cause, Halted)  # stop_now ends the leg here, as a halt, unreported
            if i in self.fleet.current:
                self.pose = self.fleet.stop(i, env.now)
            self._segment(REST)
            self._rested()
            return cause

    def brake(self, braking: Braking) -> None:
        """docs/contract.md §12 (:class:`vcran.sim.traffic.Body`): the robot's field was entered; brake now."""
        assert self._agv_process is not None and self._worker is self._agv_process, "braking a robot not driving"
        self._agv_process.interrupt(braking)

    def drive_on(self, leg: Leg) -> None:
        """docs/contract.md §12 (:class:`vcran.sim.traffic.Body`): the field is clear; drive ``leg``, the rest of the leg."""
        assert self._agv_process is not None and self._worker is self._agv_process, "driving on a robot not waiting"
        self._agv_process.interrupt(leg)

    def _rested(self) -> None:
        """The robot rests and does not drive on (a leg's end, a hold, a stop, a new pose): observers and
        fields are told."""
        self._moved()
        if self.fields is not None:
            self.fields.rest(self.index, self.pose)

    def leg_to(self, w: Waypoint) -> Leg:
        """The default plan: a straight leg from the pose to a :class:`Waypoint`."""
        x, y, theta = self.pose
        return Leg(self.env.now, x, y, theta, w.x, w.y, w.theta, self.limits(w.speed, w.accel, w.turn_rate))

    def limits(self, speed: float, accel: float, turn_rate: float) -> Limits:
        """The limits of a leg: the robot's, lowered by those asked for (0: none asked). The last ones are
        kept: a fleet manager sends the same limits leg after leg (a script: none at all)."""
        key = (speed, accel, turn_rate)
        last = self._last_limits
        if last is not None and last[0] == key:
            return last[1]
        c = self.config
        top = min(speed, c.max_velocity) if speed > 0 else c.max_velocity
        up, down = c.max_acceleration, c.max_deceleration
        if accel > 0:
            up = min(up, accel) if up > 0 else accel
            down = min(down, accel) if down > 0 else accel
        rates = [r for r in (turn_rate, c.max_angular_velocity) if r > 0]
        limits = Limits(top, up, down, min(rates) if rates else 0.0)
        self._last_limits = (key, limits)
        return limits

    def _moved(self) -> None:
        if self.on_move is not None:
            self.on_move(self)
