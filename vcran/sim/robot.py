"""One robot's three processes: RanLogic, AGV and AgvAction, talking through mailboxes (seed §2).

The processes decide nothing. RanLogic's process hands each arriving signal to the pure
:class:`~vcran.core.ranlogic.RanLogic` and carries out the effects it returns; the AGV drives the legs it is
given (analytically, one event per leg however long the leg); AgvAction waits out an action's duration
and applies it to the stations.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Generator
from dataclasses import dataclass
from typing import Any

import simpy

from vcran.core.effects import (
    Abandon,
    ClearTimer,
    DispatchAction,
    DispatchPath,
    Effect,
    Event,
    SkipMotion,
    StartTimer,
    StopAfterLeg,
)
from vcran.core.ids import Id
from vcran.core.messages import ActionAssignment, ActionKind, CancelTask, Message, MotionAssignment, PolygonStamped
from vcran.core.motion import FleetKinematics, Leg, Limits
from vcran.core.ranlogic import RanLogic
from vcran.core.scenario import RobotConfig
from vcran.core.stations import StationMap, perform
from vcran.sim.mailbox import Mailbox
from vcran.sim.timing import COMPLETION, DEADLINE, after, at

Process = Generator[simpy.events.Event, Any, None]

# --- signals through the stores -------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class Decoded:
    """RAN -> RanLogic: an inbound message for this robot."""

    message: Message


@dataclass(frozen=True, slots=True)
class Malformed:
    """RAN -> RanLogic: an inbound payload for this robot that did not decode (R12)."""

    attribute: str
    detail: str


@dataclass(frozen=True, slots=True)
class MotionDone:
    """AGV -> RanLogic: the point of ``motion`` is reached."""

    motion: Id


@dataclass(frozen=True, slots=True)
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


class RobotNode:
    """RanLogic + AGV + AgvAction of one robot. ``log`` receives ``(robot, event)`` for every event."""

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
        self.carrying = config.carrying
        self.parts_moved = 0
        self._capable = frozenset(ActionKind(a) for a in config.actions)
        self._timers: dict[Id, simpy.events.Event] = {}
        #: The points of the dispatched path still to drive. RanLogic's commands edit it: StopAfterLeg
        #: empties it (R8), SkipMotion drops a point (R13). ``agv_commands`` only wakes the AGV up.
        self._route: deque[MotionAssignment] = deque()
        #: The dispatched action not yet begun; ``action_orders`` only wakes AgvAction up.
        self._order: ActionAssignment | None = None
        self._leg_running = self._acting = False
        self._agv_process = env.process(self._agv())
        self._action_process = env.process(self._agv_action())
        env.process(self._ranlogic())

    # --- RanLogic ---------------------------------------------------------------------------------------

    def _ranlogic(self) -> Process:
        logic = self.logic
        while True:
            item = yield self.inbox.get()
            now = self.env.now
            version = logic.version
            if isinstance(item, Decoded):
                msg = item.message
                if isinstance(msg, MotionAssignment):
                    effects = logic.on_motion(now, msg)
                elif isinstance(msg, ActionAssignment):
                    effects = logic.on_action(now, msg)
                else:
                    assert isinstance(msg, CancelTask)
                    effects = logic.on_cancel(now, msg)
            elif isinstance(item, MotionDone):
                effects = logic.on_motion_finished(now, item.motion)
            elif isinstance(item, ActionDone):
                effects = logic.on_action_finished(now, item.action, item.ok, item.code, item.message)
            elif isinstance(item, TimerFired):
                if self._timers.get(item.task) is not item.deadline:
                    continue  # cleared meanwhile, or an older timer of a task id seen again
                del self._timers[item.task]
                effects = logic.on_timer(now, item.task)
            else:
                assert isinstance(item, Malformed)
                effects = logic.on_malformed(now, item.attribute, item.detail)
            self._apply(effects)
            if logic.version != version:
                self._changed(self)

    def _apply(self, effects: list[Effect]) -> None:
        for effect in effects:
            if isinstance(effect, Event):
                self._log(self, effect)
            elif isinstance(effect, DispatchPath):
                self._route = deque(effect.motions)
                self.agv_commands.put(effect.task)
            elif isinstance(effect, DispatchAction):
                self._order = effect.action
                self.action_orders.put(effect.task)
            elif isinstance(effect, StopAfterLeg):
                self._route.clear()  # the running leg finishes; nothing after it (R8)
            elif isinstance(effect, SkipMotion):
                self._route = deque(m for m in self._route if m.motion_id != effect.motion)
            elif isinstance(effect, Abandon):
                self._abandon()
            elif isinstance(effect, StartTimer):
                self._start_timer(effect.task, effect.at)
            else:
                assert isinstance(effect, ClearTimer)
                self._timers.pop(effect.task, None)

    def _start_timer(self, task: Id, when: float) -> None:
        deadline = at(self.env, when, DEADLINE)
        self._timers[task] = deadline
        deadline.callbacks.append(lambda event: self.inbox.put(TimerFired(task, event)))

    def _abandon(self) -> None:
        """R14: the leg or action that began at this instant does not happen (a new one may follow)."""
        self._route.clear()
        self._order = None
        if self._leg_running:
            self._agv_process.interrupt()
        if self._acting:
            self._action_process.interrupt()

    # --- AGV --------------------------------------------------------------------------------------------

    def _agv(self) -> Process:
        while True:
            yield self.agv_commands.get()  # a path was dispatched into self._route (maybe emptied since)
            while self._route:
                motion = self._route.popleft()
                leg = self._leg(motion)
                self.fleet.start(self.index, leg)
                self._leg_running = True
                try:
                    yield after(self.env, leg.duration, COMPLETION)
                except simpy.Interrupt:  # abandoned as it began (R14): the robot stays where it was
                    self.fleet.abandon(self.index)
                    break
                finally:
                    self._leg_running = False
                self.fleet.finish(self.index)
                self.pose = (leg.x1, leg.y1, leg.end_theta)
                self.inbox.put(MotionDone(motion.motion_id))

    def _leg(self, m: MotionAssignment) -> Leg:
        c = self.config
        requested = m.max_velocity.linear.x
        speed = min(requested, c.max_velocity) if requested > 0 else c.max_velocity
        accel, decel = c.max_acceleration, c.max_deceleration
        asked = m.max_acceleration.linear.x
        if asked > 0:
            accel = min(accel, asked) if accel > 0 else asked
            decel = min(decel, asked) if decel > 0 else asked
        rates = [r for r in (m.max_velocity.angular.z, c.max_angular_velocity) if r > 0]
        x, y, theta = self.pose
        goal = m.point.theta if m.use_orientation else None
        return Leg(self.env.now, x, y, theta, m.point.x, m.point.y, goal,
                   Limits(speed, accel, decel, min(rates) if rates else 0.0))

    # --- AgvAction --------------------------------------------------------------------------------------

    def _agv_action(self) -> Process:
        while True:
            yield self.action_orders.get()
            action, self._order = self._order, None
            if action is None:
                continue  # abandoned before it began (R14)
            kind = action.kind
            # A robot without the capability fails the action as it is dispatched, not after its duration (R14).
            self._acting = True
            try:
                yield after(self.env, self.durations[kind.value] if kind in self._capable else 0.0, COMPLETION)
            except simpy.Interrupt:  # abandoned as it began (R14): nothing is performed
                continue
            finally:
                self._acting = False
            x, y, _ = self.pose
            outcome, carrying = perform(kind, x, y, self.carrying, self.config.capacity, self.stations, self._capable)
            if outcome.ok and kind is ActionKind.UNLOAD:
                self.parts_moved += 1
            self.carrying = carrying
            self.inbox.put(ActionDone(action.action_id, outcome.ok, outcome.code, outcome.message))
