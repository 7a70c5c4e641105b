"""RanLogic's process for one robot: OPIL's vehicle logic around the shared body (docs/contract.md §1, docs/protocols.md).

The process decides nothing. It hands each arriving signal (an inbound message routed by the RAN, the body's
reports, a due R7 deadline) to the pure :class:`~vcran.core.opil.ranlogic.RanLogic` and carries out the effects it
returns: commands become the body's commands (:mod:`vcran.sim.body`), every other effect is an event for the
log. OPIL's motions are the body's waypoints as they are (:meth:`RanNode.leg_to` plans a leg to one).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Generator
from dataclasses import dataclass
from functools import partial
from operator import attrgetter
from typing import Any

import simpy

from vcran.core.events import Event
from vcran.core.motion import Leg
from vcran.core.opil.effects import (
    Abandon,
    ClearTimer,
    DispatchAction,
    DispatchPath,
    Effect,
    Published,
    Reason,
    SkipMotion,
    StartTimer,
    StopAfterLeg,
)
from vcran.core.opil.ids import Id
from vcran.core.opil.messages import ActionAssignment, CancelTask, Message, MotionAssignment, PolygonStamped
from vcran.core.opil.ranlogic import RanLogic
from vcran.sim.agvaction import Acted
from vcran.sim.body import Body, Reached
from vcran.sim.holds import Halted, InService
from vcran.sim.mailbox import Mailbox
from vcran.sim.timing import DEADLINE, at

Process = Generator[simpy.events.Event, Any, None]

# --- signals from the RAN and the deadlines ----------------------------------------------------------------
# Made once, read once, never changed; ``Decoded`` (two a task) is not frozen, as the body's reports.


@dataclass(slots=True)
class Decoded:
    """RAN -> RanLogic: an inbound message for this robot."""

    message: Message


@dataclass(frozen=True, slots=True)
class Malformed:
    """RAN -> RanLogic: an inbound payload for this robot that did not decode (R12)."""

    attribute: str
    detail: str


@dataclass(frozen=True, slots=True, eq=False)
class TimerFired:
    """Deadline -> RanLogic: the R7 deadline of ``task`` is due; ``deadline`` says which one (a task id
    can be seen again after its history entry is evicted, with a new timer)."""

    task: Id
    deadline: simpy.events.Event


_current_task = attrgetter("current_task")


class RanNode:
    """RanLogic and its process for one robot's :class:`~vcran.sim.body.Body`. ``log`` receives
    ``(body, event)`` for every event, ``changed`` the body when RanLogic's status changed."""

    def __init__(
        self, body: Body, logic: RanLogic, log: Callable[[Body, Event], None], changed: Callable[[Body], None],
    ) -> None:
        self.body, self.logic, self.env = body, logic, body.env
        self.id, self.index, self.config = body.id, body.index, body.config
        self._log, self._changed = log, changed
        self.inbox = Mailbox(body.env)
        self.footprint = PolygonStamped.from_xy(body.config.footprint)
        self._timers: dict[Id, simpy.events.Event] = {}
        body.tell = self.inbox.put
        body.current = partial(_current_task, logic)
        body.plan = self.leg_to
        body.changed = changed
        body.log = log
        body.report = self.report
        body.env.process(self._ranlogic())

    def _ranlogic(self) -> Process:
        logic, inbox, commands, log, body = self.logic, self.inbox, _COMMANDS, self._log, self.body
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
                    log(body, effect)
                else:
                    command(self, effect)
            if logic.version != version:
                self._changed(body)

    def leg_to(self, m: MotionAssignment) -> Leg:
        """The body's plan for OPIL's motions: a leg from the pose to ``m``'s point, within the limits it asks."""
        body = self.body
        x, y, theta = body.pose
        goal = m.point.theta if m.use_orientation else None
        velocity = m.max_velocity
        limits = body.limits(velocity.linear.x, m.max_acceleration.linear.x, velocity.angular.z)
        return Leg(self.env.now, x, y, theta, m.point.x, m.point.y, goal, limits)

    def report(self, code: str, message: str, severity: str = "warning") -> None:
        """Publish a ``ran_error`` for a docs/contract.md §4 incident RanLogic does not see itself."""
        count = self.logic.count_error()
        self._log(self.body, Published(code, message, severity, count=count))

    # --- commands ---------------------------------------------------------------------------------------

    def _on_timer(self, now: float, item: TimerFired) -> list[Effect] | None:
        if self._timers.get(item.task) is not item.deadline:
            return None  # cleared meanwhile, or an older timer of a task id seen again
        del self._timers[item.task]
        return self.logic.on_timer(now, item.task)

    def _dispatch_path(self, effect: DispatchPath) -> None:
        body = self.body  # Body.drive, written out: a call less a task
        body.route = deque(effect.motions)
        body.wake(effect.task)

    def _skip_motion(self, effect: SkipMotion) -> None:
        motion = effect.motion
        self.body.skip(lambda m: m.motion_id == motion)

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


def _halted(node: RanNode, now: float, item: Halted) -> list[Effect]:
    return node.logic.on_halt(now, Reason(item.why), item.why, item.message, item.out_of_service)


# --- RanLogic's dispatch tables ---------------------------------------------------------------------------
# By exact type, one dict lookup per inbox item and per effect, where isinstance chains tested up to eight
# classes each (RobotNode._ranlogic, now RanNode._ranlogic, was 29% inclusive at 1000 robots, issue 14 item 5). Each entry returns
# the effects to carry out, or None for a signal that turned out stale.

_MESSAGES: dict[type, Callable[[RanLogic, float, Any], list[Effect]]] = {
    MotionAssignment: RanLogic.on_motion,
    ActionAssignment: RanLogic.on_action,
    CancelTask: RanLogic.on_cancel,
}

_INBOX: dict[type, Callable[[RanNode, float, Any], list[Effect] | None]] = {
    Decoded: lambda node, now, item: _MESSAGES[type(item.message)](node.logic, now, item.message),
    Reached: lambda node, now, item: node.logic.on_motion_finished(now, item.waypoint.motion_id),
    Acted: lambda node, now, item: node.logic.on_action_finished(now, item.tag, item.ok, item.code, item.message),
    TimerFired: RanNode._on_timer,
    Halted: _halted,
    InService: lambda node, now, item: node.logic.on_service(now),
    Malformed: lambda node, now, item: node.logic.on_malformed(now, item.attribute, item.detail),
}

#: The effects that are commands to the body; every other effect is an Event for the log.
_COMMANDS: dict[type, Callable[[RanNode, Any], object]] = {
    DispatchPath: RanNode._dispatch_path,
    DispatchAction: lambda node, effect: node.body.act((effect.task, effect.action.kind, effect.action.action_id)),
    StopAfterLeg: lambda node, effect: node.body.route.clear(),  # Body.stop_after_leg, written out (R8)
    SkipMotion: RanNode._skip_motion,
    Abandon: lambda node, effect: node.body.abandon(),
    StartTimer: lambda node, effect: node._start_timer(effect.task, effect.at),
    ClearTimer: lambda node, effect: node._timers.pop(effect.task, None),
}
