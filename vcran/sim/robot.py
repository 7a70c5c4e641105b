"""One robot's three processes: RanLogic, AGV and AgvAction, talking through mailboxes (seed §2).

The processes decide nothing. RanLogic's process hands each arriving signal to the pure
:class:`~vcran.core.ranlogic.RanLogic` and carries out the effects it returns; the AGV drives the legs it is
given (analytically, one event per leg however long the leg); AgvAction waits out an action's duration
and applies it to the stations.
"""

from __future__ import annotations

from collections.abc import Callable, Generator
from dataclasses import dataclass
from typing import Any

import simpy

from vcran.core.effects import (
    ClearTimer,
    DispatchAction,
    DispatchPath,
    Effect,
    Event,
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


@dataclass(frozen=True, slots=True)
class Stop:
    """RanLogic -> AGV: stop at the end of the running leg (R8)."""


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
        env.process(self._ranlogic())
        env.process(self._agv())
        env.process(self._agv_action())

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
                self.agv_commands.put(effect)
            elif isinstance(effect, DispatchAction):
                self.action_orders.put(effect)
            elif isinstance(effect, StopAfterLeg):
                self.agv_commands.put(Stop())
            elif isinstance(effect, StartTimer):
                self._start_timer(effect.task, effect.at)
            else:
                assert isinstance(effect, ClearTimer)
                self._timers.pop(effect.task, None)

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

    # --- AGV --------------------------------------------------------------------------------------------

    def _agv(self) -> Process:
        while True:
            command = yield self.agv_commands.get()
            if isinstance(command, Stop):
                continue  # the path it meant has already ended
            for motion in command.motions:
                leg = self._leg(motion)
                self.fleet.start(self.index, leg)
                yield after(self.env, leg.duration, COMPLETION)
                self.fleet.finish(self.index)
                self.pose = (leg.x1, leg.y1, leg.end_theta)
                self.inbox.put(MotionDone(motion.motion_id))
                if any(isinstance(c, Stop) for c in self.agv_commands.items):
                    yield self.agv_commands.get()  # consume the Stop: the rest of the path is dropped (R8)
                    break

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
            order = yield self.action_orders.get()
            action: ActionAssignment = order.action
            kind = action.kind
            yield after(self.env, self.durations[kind.value], COMPLETION)
            x, y, _ = self.pose
            outcome, carrying = perform(kind, x, y, self.carrying, self.config.capacity, self.stations, self._capable)
            if outcome.ok and kind is ActionKind.UNLOAD:
                self.parts_moved += 1
            self.carrying = carrying
            self.inbox.put(ActionDone(action.action_id, outcome.ok, outcome.code, outcome.message))

