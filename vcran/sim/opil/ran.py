"""The RAN: routes inbound messages to robots by entity id, and publishes the fleet's state (docs/contract.md §1).

One RAN serves the whole fleet. Inbound, it decodes raw NGSI payloads (R12) and puts each message into
the mailbox of the RanLogic that owns the entity, or reports and drops it (R11); routing is a lookup at
the instant of delivery, so it needs no process of its own. Outbound, one telemetry process
samples every robot's pose in a single numpy sweep per tick (``current_motion`` as a :class:`Frame`) and
publishes ``assignment_state`` and ``ran_status`` of the robots whose state changed since the last tick
(RanLogic's, or the load a robot carries: both are in ``ran_status``), so a tick costs O(changes), not
O(robots) Python work. ``robot_description`` goes out at start and then
every ``description_period``.
"""

from __future__ import annotations

from collections.abc import Callable, Generator
from typing import Any

import simpy

from vcran.core.opil.build import CATEGORY_OF
from vcran.core.opil.effects import ErrorReport
from vcran.core.opil.ids import id_for
from vcran.core.opil.messages import (
    ActionKind,
    AssignmentStatus,
    Message,
    PolygonStamped,
    RanError,
    RobotAction,
    RobotAgentProperties,
    Time,
)
from vcran.core.scenario import RobotConfig
from vcran.core.slots import unchecked
from vcran.core.wire import Frame, Inbound, Publish, Transport
from vcran.sim.body import Body
from vcran.sim.opil.node import Decoded, Malformed, RanNode
from vcran.sim.timing import FAULT, TELEMETRY, at

Decode = Callable[[str, Any], Message]

# Published messages are built from the model's own valid state: not re-validated (schema.unchecked).
_ran_error = unchecked(RanError)
_assignment_state = unchecked(AssignmentStatus)


class Ran:
    def __init__(
        self,
        env: simpy.Environment,
        robots: list[RanNode],
        transport: Transport,
        decode: Decode,
        reject_unknown: Callable[[Inbound], None],
    ) -> None:
        self.env, self.robots, self.transport = env, robots, transport
        self._by_entity = {r.id: r for r in robots}
        self._decode = decode
        self._reject_unknown = reject_unknown
        self._ids = tuple(r.id for r in robots)
        #: Indices of the robots whose status may have changed since the last tick. Only the set: each
        #: tick sorts plain ints (fleet order, robot i is ``robots[i]``) instead of robots by a key lambda.
        self._dirty: set[int] = set()
        self._published: dict[tuple[int, str], Message] = {}
        #: docs/contract.md §4 link_down: robots whose link is down -> what they missed (latest value per inbound
        #: attribute, as Orion holds it) and what they could not publish (latest per attribute, every ran_error).
        self._down: dict[str, tuple[dict[str, Inbound], dict[str, Publish], list[Publish]]] = {}
        #: ... and when each of those links is back: the end of the latest-ending link_down in force.
        self._up_at: dict[str, float] = {}
        #: Called after each telemetry tick's statuses (the battery's publications), if set.
        self.after_statuses: Callable[[float], None] | None = None

    # --- inbound ----------------------------------------------------------------------------------------

    def deliver(self, inbound: Inbound) -> None:
        """The transport's entry point: route ``inbound`` to its robot's mailbox at ``env.now``."""
        robot = self._by_entity.get(inbound.entity)
        if robot is None:
            self._reject_unknown(inbound)
            return
        down = self._down.get(robot.id) if self._down else None
        if down is not None:
            down[0].pop(inbound.attribute, None)
            down[0][inbound.attribute] = inbound  # Orion keeps the latest value; the robot reads it later
            return
        if inbound.message is not None:
            robot.inbox.put(Decoded(inbound.message))
            return
        try:
            message = self._decode(inbound.attribute, inbound.raw)
        except ValueError as exc:  # the codec's error type is a ValueError
            robot.inbox.put(Malformed(inbound.attribute, str(exc)))
        else:
            robot.inbox.put(Decoded(message))

    # --- outbound ---------------------------------------------------------------------------------------

    def changed(self, robot: RanNode | Body) -> None:
        self._dirty.add(robot.index)

    def publish_error(self, robot: Body, error: ErrorReport) -> None:
        message = _ran_error(
            code=error.code, severity=error.severity, message=error.message, task_id=error.task,
            motion_id=error.motion, action_id=error.action, stamp=Time.from_seconds(self.env.now),
            count=error.count,
        )
        self.send(Publish(self.env.now, robot.id, "ran_error", message))

    def send(self, out: Publish) -> None:
        """Publish one attribute of one robot, unless its link is down (then it waits for the link)."""
        down = self._down.get(out.robot) if self._down else None
        if down is None:
            self.transport.send(out)
        elif out.attribute == "ran_error":
            down[2].append(out)
        else:
            down[1].pop(out.attribute, None)
            down[1][out.attribute] = out

    def link_down(self, robot: Body, duration: float) -> None:
        """docs/contract.md §4 link_down: for ``duration`` the robot neither receives nor publishes.

        Back up, it reads what Orion holds (the latest value of each attribute written meanwhile, in the order
        they were last written), and publishes what it could not: the latest of each attribute, then every
        ``ran_error`` in order. Its rows in the fleet's ``current_motion`` frames keep flowing (a frame is
        one record for the whole fleet; docs/robots.md). A transport with a link of its own (a closed loop)
        cuts that link instead (:meth:`Transport.outage`), so the manager misses the robot's rows as well."""
        end = self.env.now + duration
        if self.transport.outage(robot.id, end):
            return
        if robot.id not in self._down:
            self._down[robot.id] = ({}, {}, [])
        elif end <= self._up_at[robot.id]:
            return  # within the link_down in force
        self._up_at[robot.id] = end  # link downs stack: the link is back when the last one ends
        at(self.env, end, FAULT).callbacks.append(lambda _: self._link_up(robot, end))

    @property
    def links_down(self) -> bool:
        """Whether some robot's link is down: what it missed and what it could not publish still wait."""
        return bool(self._down)

    def _link_up(self, robot: Body, end: float) -> None:
        if self._up_at.get(robot.id) != end:
            return  # extended by a link_down that ends later
        del self._up_at[robot.id]
        missed, held, errors = self._down.pop(robot.id)
        now = self.env.now
        for out in [*held.values(), *errors]:
            self.transport.send(Publish(now, out.robot, out.attribute, out.message))
        for inbound in missed.values():
            self.deliver(inbound)

    def telemetry(self, period: float, stop_when_idle: Callable[[], bool]) -> Generator[simpy.events.Event, Any, None]:
        """Every ``period``: the fleet's current_motion, then the changed statuses, in fleet order."""
        fleet = self.robots[0].body.fleet if self.robots else None
        k = 0
        while True:
            t = k * period
            yield at(self.env, t, TELEMETRY)
            if fleet is not None and self.transport.wants_frames:
                self.transport.send(Frame(t, self._ids, fleet.sample(t)))
            if k == 0:  # everything is "changed" at start
                for r in self.robots:
                    self.changed(r)
            dirty, self._dirty = sorted(self._dirty), set()
            for i in dirty:
                robot = self.robots[i]
                self._publish_if_new(t, robot, "assignment_state", self.assignment_state(robot))
                self._publish_if_new(t, robot, "ran_status", robot.logic.ran_status(robot.body.carrying))
            if self.after_statuses is not None:
                self.after_statuses(t)
            if stop_when_idle():
                return
            k += 1

    def descriptions(self, period: float) -> Generator[simpy.events.Event, Any, None]:
        """``robot_description`` of every robot at start and every ``period``: built once, it never changes."""
        messages = [(robot.id, description(robot.config, robot.footprint)) for robot in self.robots]
        j = 0
        while True:
            t = j * period
            yield at(self.env, t, TELEMETRY)
            for robot_id, message in messages:
                self.send(Publish(t, robot_id, "robot_description", message))
            j += 1

    def _publish_if_new(self, t: float, robot: RanNode, attribute: str, message: Message) -> None:
        key = (robot.index, attribute)
        last = self._published.get(key)
        if last is not message and last != message:  # a status kept unchanged is the very same object
            self._published[key] = message
            out = Publish(t, robot.id, attribute, message)
            if self._down:  # some link is down: send() holds what its robot cannot publish
                self.send(out)
            else:  # send()'s common case, without its call (two statuses per change of every robot)
                self.transport.send(out)

    def publish(self, t: float, robot: Body, attribute: str, message: Message) -> None:
        self.send(Publish(t, robot.id, attribute, message))

    @staticmethod
    def assignment_state(robot: RanNode) -> AssignmentStatus:
        logic = robot.logic
        return _assignment_state(
            current_task_id=logic.current_task,
            current_motion_id=logic.current_motion,
            current_action_id=logic.current_action,
            last_finished_motion=logic.last_finished_motion,
            last_finished_action=logic.last_finished_action,
            footprint=robot.footprint,
        )


def description(config: RobotConfig, footprint: PolygonStamped) -> RobotAgentProperties:
    """``robot_description`` from a robot's configuration (footprint, limits, capabilities)."""
    c = config
    return RobotAgentProperties(
        robot_id=id_for(c.id),
        footprint=footprint,
        payload=float(c.capacity),
        max_pos_x_vel=c.max_velocity,
        max_neg_x_vel=c.max_velocity,
        max_pos_x_acc=c.max_acceleration,
        max_neg_x_acc=c.max_deceleration,
        max_pos_ang_vel=c.max_angular_velocity,
        max_neg_ang_vel=c.max_angular_velocity,
        vendor=c.vendor,
        action_capability=tuple(
            RobotAction(CATEGORY_OF[ActionKind(a)], 0, (), a) for a in c.actions
        ) + ((RobotAction(CATEGORY_OF[ActionKind.CHARGE], 0, (), "charge"),) if c.battery is not None else ()),
        batt_capacity=c.battery.capacity if c.battery is not None else 0.0,
        batt_max_voltage=c.battery.voltage if c.battery is not None else 0.0,
    )
