"""A minimal SimPy body for :class:`vcran.sim.traffic.SafetyFields` in the tests: what the robot's shared body
does with safety fields (issue 30's body, docs/robots.md "Traffic"), and no more.

Each robot drives a route of points leg by leg (each leg from rest to rest, turning first), in one SimPy
process: it tells the fields every leg it starts (``drive``) and every rest it comes to (``rest``). A
``brake`` interrupts the process: the running leg stops now (``FleetKinematics.stop``) and the braked stretch
is driven; a ``drive_on`` interrupts it again with the rest of the motion, whose end completes the motion
(the braked stretch's end does not). ``halt`` stops the robot for good where it is (a cancel: the route
is dropped). The log holds ``(t, what, robot, detail)``; the events SafetyFields writes go there too.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import simpy

from vcran.core.events import Event
from vcran.core.motion import FleetKinematics, Leg, Limits
from vcran.core.scenario import RobotConfig, Scenario, Settings, TrafficSettings
from vcran.core.traffic.braking import Braking
from vcran.sim.timing import COMPLETION, Environment, at
from vcran.sim.traffic import SafetyFields

HALT = "halt"
Log = list[tuple[float, str, str, Any]]


class Robot:
    def __init__(self, fleet: Fleet, index: int, route: Sequence[tuple[float, float]], start: float = 0.0) -> None:
        self.fleet, self.index, self.route, self.start = fleet, index, list(route), start
        self.env = fleet.env
        self.process = self.env.process(self._run())

    # what SafetyFields asks (vcran.sim.traffic.Body)
    def brake(self, braking: Braking) -> None:
        self.process.interrupt(braking)

    def drive_on(self, leg: Leg) -> None:
        self.process.interrupt(leg)

    def halt(self) -> None:
        self.process.interrupt(HALT)

    def _run(self):  # type: ignore[no-untyped-def]
        env, kin, i, fields = self.env, self.fleet.kinematics, self.index, self.fleet.fields
        if self.start > env.now:
            yield at(env, self.start, COMPLETION)
        for x, y in self.route:
            leg = Leg(env.now, *kin.rest[i], x, y, None, self.fleet.limits[i])
            kin.start(i, leg)
            fields.drive(i, leg)
            if not (yield from self._drive(leg)):
                return
            self.fleet.log.append((env.now, "arrived", self.fleet.ids[i], (x, y)))
            fields.rest(i, kin.rest[i])

    def _drive(self, leg: Leg | None):  # type: ignore[no-untyped-def]
        """Drive ``leg`` to the end of its motion (True), braking and driving on as told; False: halted."""
        env, kin, i = self.env, self.fleet.kinematics, self.index
        braked = False  # driving (or resting at the end of) a braked stretch: its end is not the motion's
        while True:
            try:
                yield at(env, leg.t_end, COMPLETION) if leg is not None else env.event()
            except simpy.Interrupt as irq:
                cause = irq.cause
                if isinstance(cause, Braking):
                    kin.stop(i, env.now)
                    leg, braked = cause.stop, True
                    if leg is not None:
                        kin.start(i, leg)
                elif isinstance(cause, Leg):
                    if i in kin.current:  # the braked stretch ends at this very instant
                        kin.finish(i)
                    leg, braked = cause, False
                    kin.start(i, leg)
                else:
                    assert cause == HALT
                    if i in kin.current:
                        kin.stop(i, env.now)
                    self.fleet.log.append((env.now, "halted", self.fleet.ids[i], kin.rest[i][:2]))
                    self.fleet.fields.rest(i, kin.rest[i])
                    return False
                continue
            kin.finish(i)
            if not braked:
                return True
            leg = None  # stopped: wait for drive_on


class Fleet:
    """Robots of ``scenario`` (poses, footprints, limits, fields) driving ``routes`` in a SimPy environment."""

    def __init__(self, scenario: Scenario) -> None:
        self.env = Environment(0.0)
        self.ids = [r.id for r in scenario.robots]
        self.log: Log = []
        self.kinematics = FleetKinematics([r.pose for r in scenario.robots])
        self.limits = [Limits(r.max_velocity, r.max_acceleration, r.max_deceleration, r.max_angular_velocity)
                       for r in scenario.robots]
        fields = SafetyFields.of(self.env, scenario, self._event)
        assert fields is not None
        self.fields = fields
        self.robots: list[Robot] = []

    def send(self, robot: str, route: Sequence[tuple[float, float]], start: float = 0.0) -> Robot:
        i = self.ids.index(robot)
        body = Robot(self, i, route, start)
        self.fields.attach(i, body)
        self.robots.append(body)
        return body

    def run(self, until: float) -> Log:
        self.env.run(until=until)
        return self.log

    def _event(self, robot: int, event: Event) -> None:
        self.log.append((self.env.now, event.NAME, self.ids[robot], event.fields()))


def scenario(robots: Sequence[RobotConfig], traffic: TrafficSettings) -> Scenario:
    return Scenario(Settings(duration=600.0), tuple(robots), (), (), traffic=traffic)
