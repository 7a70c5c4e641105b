"""One robot's three processes: RanLogic, AGV and AgvAction, talking through mailboxes (seed §2).

The processes decide nothing. RanLogic's process hands each arriving signal to the pure
:class:`~vcran.core.opil.ranlogic.RanLogic` and carries out the effects it returns; the AGV drives the legs it is
given (analytically, one event per leg however long the leg); AgvAction waits out an action's duration
and applies it to the stations.
"""

from __future__ import annotations

import dataclasses
from collections import deque
from collections.abc import Callable, Generator
from dataclasses import dataclass
from typing import Any

import simpy
from simpy.events import Process as SimProcess

from vcran.core.battery import (
    ACT,
    CHARGE,
    DRIVE,
    EMPTY,
    REST,
    FleetBattery,
    leg_empty_after,
    linear_empty_after,
    linear_full_after,
)
from vcran.core.incidents import BatteryEmpty, BatterySwapped
from vcran.core.motion import FleetKinematics, Leg, Limits
from vcran.core.opil.effects import (
    Abandon,
    ClearTimer,
    DispatchAction,
    DispatchPath,
    Effect,
    Event,
    Published,
    Reason,
    SkipMotion,
    StartTimer,
    StopAfterLeg,
)
from vcran.core.opil.ids import Id
from vcran.core.opil.messages import ActionAssignment, ActionKind, CancelTask, Message, MotionAssignment, PolygonStamped
from vcran.core.opil.ranlogic import RanLogic
from vcran.core.scenario import RobotConfig
from vcran.core.stations import Outcome, StationMap, attempt, transfer
from vcran.sim.mailbox import Mailbox
from vcran.sim.timing import COMPLETION, DEADLINE, FAULT, after, at

Process = Generator[simpy.events.Event, Any, None]

# --- signals through the stores -------------------------------------------------------------------------
# Signals are made by one process and read once by another, never changed. The three sent for every task
# (Decoded, MotionDone, ActionDone: six a task) are not ``frozen``: a frozen dataclass pays an
# ``object.__setattr__`` per field to build, and these cost about 17k machine instructions a task more that way
# (callgrind, issue 14). The rare ones stay frozen.


@dataclass(slots=True)
class Decoded:
    """RAN -> RanLogic: an inbound message for this robot."""

    message: Message


@dataclass(frozen=True, slots=True)
class Malformed:
    """RAN -> RanLogic: an inbound payload for this robot that did not decode (R12)."""

    attribute: str
    detail: str


@dataclass(slots=True)
class MotionDone:
    """AGV -> RanLogic: the point of ``motion`` is reached."""

    motion: Id


@dataclass(slots=True)
class ActionDone:
    """AgvAction -> RanLogic: ``action`` finished, well or not."""

    action: Id
    ok: bool
    code: str = ""
    message: str = ""


@dataclass(frozen=True, slots=True, eq=False)
class TimerFired:
    """Deadline -> RanLogic: the R7 deadline of ``task`` is due; ``deadline`` says which one (a task id
    can be seen again after its history entry is evicted, with a new timer)."""

    task: Id
    deadline: simpy.events.Event


@dataclass(frozen=True, slots=True)
class Halted:
    """Robot -> RanLogic: the robot stopped where it is (SPEC §4: battery, motion failure, collision)."""

    reason: Reason
    code: str
    message: str
    out_of_service: bool = False


@dataclass(frozen=True, slots=True)
class InService:
    """Robot -> RanLogic: a fresh battery; take tasks again (SPEC §4)."""


#: Interrupt causes for a working process (besides a :class:`Halted`): stop in place / go on / the work
#: that began at this instant does not happen (R14: a cancel or timeout at the instant the previous ended).
HOLD, RELEASE, ABANDON = "hold", "release", "abandon"


class RobotNode:
    """RanLogic + AGV + AgvAction of one robot. ``log`` receives ``(robot, event)`` for every event.

    SPEC §4 adds what happens to a robot on its own. A *work* (a leg, an action) can be held in place
    (pause, breakdown: it resumes exactly where it stopped, its remaining time unchanged), or stopped for
    good (battery empty, motion failure, collision): the working process is interrupted (SimPy's
    ``Process.interrupt``, which costs nothing until used) and RanLogic is told through a :class:`Halted`.
    """

    def __init__(
        self,
        env: simpy.Environment,
        index: int,
        config: RobotConfig,
        logic: RanLogic,
        fleet: FleetKinematics,
        stations: StationMap,
        durations: dict[str, float],
        log: Callable[[RobotNode, Event], None],
        changed: Callable[[RobotNode], None],
        battery: FleetBattery | None = None,
    ) -> None:
        self.env, self.index, self.config, self.logic = env, index, config, logic
        self.id = config.id
        self.fleet, self.stations, self.durations = fleet, stations, durations
        self._log, self._changed = log, changed
        self.inbox = Mailbox(env)
        self.agv_commands = Mailbox(env)
        self.action_orders = Mailbox(env)
        self.pose = config.pose
        self.footprint = PolygonStamped.from_xy(config.footprint)
        self._carrying = config.carrying
        self.parts_moved = 0
        self._capable = frozenset(ActionKind(a) for a in config.actions)
        self._timers: dict[Id, simpy.events.Event] = {}
        #: The last leg limits built, with what the motion asked for (:meth:`_limits`).
        self._last_limits: tuple[tuple[float, float, float], Limits] | None = None
        #: The points of the dispatched path still to drive. RanLogic's commands edit it: StopAfterLeg
        #: empties it (R8), SkipMotion drops a point (R13). ``agv_commands`` only wakes the AGV up.
        self._route: deque[MotionAssignment] = deque()
        #: SPEC §4 state: the battery (shared fleet arrays; None when this robot has none), the process
        #: currently working (a leg or an action), the holds in force, an armed action failure.
        self.battery = battery if battery is not None and config.battery is not None else None
        if self.battery is not None:
            self._capable |= {ActionKind.CHARGE}
        self._worker: SimProcess | None = None
        self._holds: list[str] = []
        self.fail_next_action = False
        self.empty = False
        self._idle_check: simpy.events.Event | None = None
        #: How far ahead the power tick looks for a resting battery running out (2 telemetry periods).
        self.idle_horizon = 2.0
        #: Observers of "this robot's occupancy changed" (collision detection), called with the robot.
        self.on_move: Callable[[RobotNode], None] | None = None
        env.process(self._ranlogic())
        env.process(self._agv())
        env.process(self._agv_action())

    @property
    def carrying(self) -> int:
        """The parts on board. ``ran_status`` shows them (SPEC §2), so a change is a change of the robot's
        status: published at the next tick even when RanLogic's state did not change with it."""
        return self._carrying

    @carrying.setter
    def carrying(self, parts: int) -> None:
        if parts != self._carrying:
            self._carrying = parts
            self._changed(self)

    # --- RanLogic ---------------------------------------------------------------------------------------

    def _ranlogic(self) -> Process:
        logic, inbox, commands, log = self.logic, self.inbox, _COMMANDS, self._log
        while True:
            item = yield inbox.get()
            version = logic.version
            effects = _INBOX[type(item)](self, self.env.now, item)
            if effects is None:
                continue
            # The effects carried out here, not in a method of their own: six inputs a task (issue 30).
            # Most effects are events (~4 of 5): one dict miss sends them to the log, where an isinstance
            # chain tested up to 8 classes per effect (measured 9.9% inclusive at 1000 robots, issue 14).
            for effect in effects:
                command = commands.get(type(effect))
                if command is None:
                    assert isinstance(effect, Event), effect  # every effect not a command is an Event
                    log(self, effect)
                else:
                    command(self, effect)
            if logic.version != version:
                self._changed(self)

    def _on_timer(self, now: float, item: TimerFired) -> list[Effect] | None:
        if self._timers.get(item.task) is not item.deadline:
            return None  # cleared meanwhile, or an older timer of a task id seen again
        del self._timers[item.task]
        return self.logic.on_timer(now, item.task)

    def _dispatch_path(self, effect: DispatchPath) -> None:
        self._route = deque(effect.motions)
        self.agv_commands.put(effect.task)

    def _stop_after_leg(self, effect: StopAfterLeg) -> None:
        self._route.clear()  # the running leg finishes; nothing after it (R8)

    def _skip_motion(self, effect: SkipMotion) -> None:
        self._route = deque(m for m in self._route if m.motion_id != effect.motion)

    def _start_timer(self, task: Id, when: float) -> None:
        deadline = at(self.env, when, DEADLINE)
        self._timers[task] = deadline
        deadline.callbacks.append(lambda event: self._deadline_due(task, event))

    def _deadline_due(self, task: Id, deadline: simpy.events.Event) -> None:
        # Most deadlines are cleared long before they are due (the task was assembled in time): those
        # do not wake RanLogic at all. One still current is checked again when it is taken out of the
        # inbox, in case something of the same instant clears it first.
        if self._timers.get(task) is deadline:
            self.inbox.put(TimerFired(task, deadline))

    def _abandon(self) -> None:
        """R14: the leg or action that began at this instant does not happen (its task has ended; an
        action not begun yet is skipped as its task is no longer current)."""
        self._route.clear()
        if self._worker is not None:
            self._worker.interrupt(ABANDON)

    # --- AGV --------------------------------------------------------------------------------------------

    def _agv(self) -> Process:
        while True:
            task = yield self.agv_commands.get()  # a path of ``task`` went into self._route
            if task != self.logic.current_task:
                continue  # the path it meant has already ended (the robot stopped on its own)
            while self._route:
                motion = self._route.popleft()
                if self._holds:
                    halt = yield from self._held()
                    if halt is not None:
                        self._stopped(halt)
                        break
                leg = self._leg(motion)
                halt = yield from self._drive(leg)
                if halt is not None:
                    self._stopped(halt)
                    break
                self.fleet.finish(self.index)
                self.pose = (leg.x1, leg.y1, leg.end_theta)
                self.inbox.put(MotionDone(motion.motion_id))
                if not self._route or self._holds:  # else the next leg starts now, from this pose
                    self._segment(REST)
                    self._moved()

    def _drive(self, leg: Leg) -> Generator[simpy.events.Event, Any, Halted | str | None]:
        """Drive ``leg`` to its end (None), until the robot stops on its own (the :class:`Halted`), or
        :data:`ABANDON` (R14: the robot stays where the leg began).

        A hold stops the robot where it is and later resumes the same leg shifted in time by the hold's
        length, so the rest of the leg (and the task) ends exactly that much later (SPEC §4 breakdown).
        """
        i, env = self.index, self.env
        self.fleet.start(i, leg)
        level = self._segment(DRIVE)
        self._moved()
        while True:
            cut = self._leg_cut(leg, level)
            level = None
            reaches = cut >= leg.t_end - env.now
            cause = yield from self._work(at(env, leg.t_end, COMPLETION) if reaches else after(env, cut, COMPLETION))
            if cause is RELEASE:
                continue
            if cause is None:
                if reaches:
                    return None
                cause = self._battery_empty_halt()
            elif cause is ABANDON:
                self.fleet.abandon(i, env.now)
                self._segment(REST)
                self._moved()
                return cause
            elif cause is HOLD:
                t_hold = env.now
                self.pose = self.fleet.hold(i, t_hold)
                self._segment(REST)
                self._moved()
                cause = yield from self._held()
                if cause is None:
                    leg = dataclasses.replace(leg, t0=leg.t0 + (env.now - t_hold))
                    self.fleet.resume(i, leg, env.now)
                    self._segment(DRIVE)
                    self._moved()
                    continue
                self.fleet.drop_held(i)
                return cause
            assert isinstance(cause, Halted)
            self.pose = self.fleet.stop(i, env.now)
            self._segment(REST)
            self._moved()
            return cause

    def _leg(self, m: MotionAssignment) -> Leg:
        x, y, theta = self.pose
        goal = m.point.theta if m.use_orientation else None
        return Leg(self.env.now, x, y, theta, m.point.x, m.point.y, goal, self._limits(m))

    def _limits(self, m: MotionAssignment) -> Limits:
        """The limits of a leg to ``m``: the robot's, lowered by those ``m`` asks for. The last ones are
        kept: a fleet manager sends the same limits leg after leg (a script: none at all)."""
        velocity = m.max_velocity
        key = (velocity.linear.x, m.max_acceleration.linear.x, velocity.angular.z)
        last = self._last_limits
        if last is not None and last[0] == key:
            return last[1]
        requested, asked, turn = key
        c = self.config
        speed = min(requested, c.max_velocity) if requested > 0 else c.max_velocity
        accel, decel = c.max_acceleration, c.max_deceleration
        if asked > 0:
            accel = min(accel, asked) if accel > 0 else asked
            decel = min(decel, asked) if decel > 0 else asked
        rates = [r for r in (turn, c.max_angular_velocity) if r > 0]
        limits = Limits(speed, accel, decel, min(rates) if rates else 0.0)
        self._last_limits = (key, limits)
        return limits

    # --- AgvAction --------------------------------------------------------------------------------------

    def _agv_action(self) -> Process:
        while True:
            order = yield self.action_orders.get()
            if order.task != self.logic.current_task:
                continue  # its task ended while it waited (the robot stopped on its own)
            action: ActionAssignment = order.action
            kind = action.kind
            if self._holds:
                halt = yield from self._held()
                if halt is not None:
                    self._stopped(halt)
                    continue
            outcome = self._precheck(kind)
            if outcome is not None:
                # R14: it fails at once, yet as a completion of this instant like any action's end
                # (docs/determinism.md), so that a cancel of the same instant finds it running and abandons
                # it; reported straight away, the failure would reach RanLogic after that cancel had ended
                # the task. (No hold can come first: faults follow completions.)
                halt = yield from self._work(after(self.env, 0.0, COMPLETION))
                if halt is not None:
                    assert halt is ABANDON or isinstance(halt, Halted)
                    self._stopped(halt)
                    continue
                self.watch_idle()  # a resting battery that ran out meanwhile found the robot working
            else:
                duration = self._charge_time() if kind is ActionKind.CHARGE else self.durations[kind.value]
                halt = yield from self._act(kind, duration)
                if halt is not None:
                    self._stopped(halt)
                    continue
                outcome = self._finish(kind)
            self.inbox.put(ActionDone(action.action_id, outcome.ok, outcome.code, outcome.message))

    def _finish(self, kind: ActionKind) -> Outcome:
        """An action's duration has passed: its outcome, and its effect on parts and battery. An armed
        action failure fails an action that would have succeeded, and then moves nothing (SPEC §4): the
        part stays where it was, the robot carries what it carried before."""
        x, y, _ = self.pose
        outcome, station = attempt(kind, x, y, self.carrying, self.config.capacity, self.stations, self._capable)
        if outcome.ok and kind is ActionKind.CHARGE:
            self._charged()  # the energy went in during the action (its battery segment), whatever it reports
        if outcome.ok and self.fail_next_action:
            self.fail_next_action = False
            return Outcome(False, "action_fault", f"{kind.value}: injected action failure (§4)")
        if station is not None:
            self.carrying = transfer(kind, station, self.carrying)
            if kind is ActionKind.UNLOAD:
                self.parts_moved += 1
        return outcome

    def _precheck(self, kind: ActionKind) -> Outcome | None:
        """An action that cannot start fails at once, not after its duration (R14): one this robot is not
        capable of, a charge without battery, charger or a rate above the idle draw; else None."""
        if kind is not ActionKind.CHARGE:
            return None if kind in self._capable else Outcome(False, "action_not_capable", f"this robot is not configured to {kind.value}")
        if self.battery is None:
            return Outcome(False, "action_not_capable", "charge: this robot has no battery")
        x, y, _ = self.pose
        station = self.stations.nearest_in_reach(x, y, chargers=True)
        if station is None:
            return Outcome(False, "no_charger_in_reach", f"charge: no charger in reach at {x:.3f}, {y:.3f}")
        if self._charge_time() == float("inf"):
            return Outcome(False, "charge_too_slow", "charge: charge_rate does not exceed the idle draw")
        return None

    def _act(self, kind: ActionKind, duration: float) -> Generator[simpy.events.Event, Any, Halted | str | None]:
        """Wait out an action of ``duration``: held by pause/breakdown, cut short by an empty battery, or
        :data:`ABANDON` as it begins (R14: nothing is performed)."""
        env = self.env
        end = env.now + duration
        segment = CHARGE if kind is ActionKind.CHARGE else ACT
        self._segment(segment)
        while True:
            cut = linear_empty_after(self._level(), self._rate()) if self.battery is not None and not self.empty else float("inf")
            finishes = cut >= end - env.now
            cause = yield from self._work(at(env, end, COMPLETION) if finishes else after(env, cut, COMPLETION))
            if cause is RELEASE:
                continue
            if cause is None:
                if finishes:
                    self._segment(REST)
                    return None
                cause = self._battery_empty_halt()
            elif cause is HOLD:
                t_hold = env.now
                self._segment(REST)
                cause = yield from self._held()
                if cause is None:
                    end += env.now - t_hold
                    self._segment(segment)
                    continue
            assert cause is ABANDON or isinstance(cause, Halted)
            self._segment(REST)
            return cause

    # --- working, holding, stopping (SPEC §4) -----------------------------------------------------------

    def _work(self, event: simpy.events.Event) -> Generator[simpy.events.Event, Any, Halted | str | None]:
        """Wait for ``event`` (the end of a work); an interrupt returns its cause (HOLD or a Halted)."""
        self._worker = self.env.active_process
        try:
            yield event
            return None
        except simpy.Interrupt as irq:
            return irq.cause  # type: ignore[no-any-return]
        finally:
            self._worker = None

    def _held(self) -> Generator[simpy.events.Event, Any, Halted | str | None]:
        """Stay where the robot is until every hold is released (None), or it stops for good (a
        :class:`Halted`, or :data:`ABANDON`: the work it held does not happen, R14)."""
        while self._holds:
            cut = linear_empty_after(self._level(), self._rate()) if self.battery is not None else float("inf")
            event = after(self.env, cut, COMPLETION) if cut != float("inf") else self.env.event()
            cause = yield from self._work(event)
            if cause is None:
                return self._battery_empty_halt()
            if cause is ABANDON or isinstance(cause, Halted):
                return cause
        return None

    def hold(self, kind: str) -> None:
        """Stop in place until :meth:`release` of the same kind (pause, breakdown)."""
        self._holds.append(kind)
        if len(self._holds) == 1 and self._worker is not None:
            self._worker.interrupt(HOLD)

    def release(self, kind: str) -> bool:
        """End a hold of ``kind``; False when none was in force (a resume without a pause)."""
        if kind not in self._holds:
            return False
        self._holds.remove(kind)
        if not self._holds and self._worker is not None:
            self._worker.interrupt(RELEASE)
        return True

    @property
    def holds(self) -> tuple[str, ...]:
        return tuple(self._holds)

    @property
    def working(self) -> bool:
        return self._worker is not None

    @property
    def driving(self) -> bool:
        return self.index in self.fleet.current

    def halt(self, halted: Halted) -> None:
        """Stop for good now: the running work ends where it is, RanLogic cancels the current task."""
        if self._worker is not None:
            self._worker.interrupt(halted)
        else:
            self._halted(halted)

    def _halted(self, halted: Halted) -> None:
        self.inbox.put(halted)

    def _stopped(self, cause: Halted | str) -> None:
        """A work ended early: tell RanLogic when the robot stopped on its own; an abandoned one (R14)
        was RanLogic's own doing."""
        if isinstance(cause, Halted):
            self._halted(cause)

    def _moved(self) -> None:
        if self.on_move is not None:
            self.on_move(self)

    # --- battery (SPEC §4) ------------------------------------------------------------------------------

    def _segment(self, kind: int) -> float | None:
        """Begin a battery segment of ``kind`` now; returns the level it starts with (None: no battery)."""
        if self.battery is None or self.empty:
            return None
        t = self.env.now
        level = self.battery.begin(self.index, t, self.fleet.distance(self.index, t), kind)
        if kind == REST and level <= self.battery.idle[self.index] * self.idle_horizon:
            self.watch_idle()  # may run out before the power tick would notice
        return level

    def _level(self) -> float:
        b = self.battery
        assert b is not None
        t = self.env.now
        return b.level(self.index, t, self.fleet.distance(self.index, t))

    def _rate(self) -> float:
        assert self.battery is not None
        return self.battery.rate[self.index]

    def _leg_cut(self, leg: Leg, level: float | None = None) -> float:
        """Seconds from now until the battery empties on ``leg`` (inf: not before the leg ends);
        ``level``, when the caller has it, is the charge now."""
        b = self.battery
        if b is None or self.empty:
            return float("inf")
        c = self.config.battery
        assert c is not None
        if level is None:
            level = self._level()
        if c.per_idle_second * leg.duration + c.per_metre * leg.distance < level:
            return float("inf")  # the whole leg costs less than what is left: the common case, no roots
        now = self.env.now
        tau = max(now - leg.t0, 0.0)
        done = c.per_idle_second * tau + c.per_metre * leg.distance_at(now)
        return leg_empty_after(leg, level + done, c.per_idle_second, c.per_metre) - tau

    def _charge_time(self) -> float:
        c = self.config.battery
        assert c is not None
        return linear_full_after(self._level(), c.capacity, c.charge_rate - c.per_idle_second)

    def _charged(self) -> None:
        assert self.battery is not None
        self.battery.low_warned[self.index] = False

    def log_incident(self, event: Event) -> None:
        self._log(self, event)

    def _battery_empty_halt(self) -> Halted:
        """The battery just ran out (a work's cut fired): stop, out of service; swap if the scenario says."""
        self.empty = True
        assert self.battery is not None
        self.battery.begin(self.index, self.env.now, self.fleet.distance(self.index, self.env.now), EMPTY)
        x, y = self._position()
        self._log(self, BatteryEmpty(x, y))
        c = self.config.battery
        assert c is not None
        if c.swap_after is not None:
            at(self.env, self.env.now + c.swap_after, FAULT).callbacks.append(lambda _: self._swap())
        return Halted(Reason.BATTERY_EMPTY, "battery_empty", f"battery empty at {x:.3f}, {y:.3f}: the robot stopped [§4]", True)

    def _position(self) -> tuple[float, float]:
        if self.index in self.fleet.current:
            x, y, _, _, _ = self.fleet.current[self.index].pose_at(self.env.now)
            return x, y
        return self.pose[0], self.pose[1]

    def idle_empty(self) -> None:
        """The battery of this robot, at rest, is due to run out now (scheduled by the power tick)."""
        self._idle_check = None
        if self.empty or self._worker is not None or self.battery is None or self._level() > 0.0:
            return
        self._halted(self._battery_empty_halt())

    def watch_idle(self) -> None:
        """Schedule :meth:`idle_empty` at the instant the resting battery runs out, once."""
        if self._idle_check is not None or self.empty or self._worker is not None or self.battery is None:
            return
        cut = linear_empty_after(self._level(), self._rate())
        if cut != float("inf"):
            self._idle_check = after(self.env, cut, COMPLETION)
            self._idle_check.callbacks.append(lambda _: self.idle_empty())

    def _swap(self) -> None:
        assert self.battery is not None
        t = self.env.now
        self.empty = False
        self.battery.refill(self.index, t, self.fleet.distance(self.index, t))
        self._log(self, BatterySwapped())
        self.inbox.put(InService())

    def report(self, code: str, message: str, severity: str = "warning") -> None:
        """Publish a ``ran_error`` for a §4 incident RanLogic does not see itself."""
        count = self.logic.count_error()
        self._log(self, Published(code, message, severity, count=count))


# --- RanLogic's dispatch tables ---------------------------------------------------------------------------
# By exact type, one dict lookup per inbox item and per effect, where isinstance chains tested up to eight
# classes each (RobotNode._ranlogic was 29% inclusive at 1000 robots, issue 14 item 5). Each entry returns
# the effects to carry out, or None for a signal that turned out stale.

_MESSAGES: dict[type, Callable[[RanLogic, float, Any], list[Effect]]] = {
    MotionAssignment: RanLogic.on_motion,
    ActionAssignment: RanLogic.on_action,
    CancelTask: RanLogic.on_cancel,
}

_INBOX: dict[type, Callable[[RobotNode, float, Any], list[Effect] | None]] = {
    Decoded: lambda node, now, item: _MESSAGES[type(item.message)](node.logic, now, item.message),
    MotionDone: lambda node, now, item: node.logic.on_motion_finished(now, item.motion),
    ActionDone: lambda node, now, item: node.logic.on_action_finished(now, item.action, item.ok, item.code, item.message),
    TimerFired: RobotNode._on_timer,
    Halted: lambda node, now, item: node.logic.on_halt(now, item.reason, item.code, item.message, item.out_of_service),
    InService: lambda node, now, item: node.logic.on_service(now),
    Malformed: lambda node, now, item: node.logic.on_malformed(now, item.attribute, item.detail),
}

#: The effects that are commands to the robot's processes; every other effect is an Event for the log.
_COMMANDS: dict[type, Callable[[RobotNode, Any], object]] = {
    DispatchPath: RobotNode._dispatch_path,
    DispatchAction: lambda node, effect: node.action_orders.put(effect),
    StopAfterLeg: RobotNode._stop_after_leg,
    SkipMotion: RobotNode._skip_motion,
    Abandon: lambda node, effect: node._abandon(),
    StartTimer: lambda node, effect: node._start_timer(effect.task, effect.at),
    ClearTimer: lambda node, effect: node._timers.pop(effect.task, None),
}
