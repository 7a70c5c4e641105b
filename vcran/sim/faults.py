"""Injected faults, carried out at their instants (docs/contract.md §4 Faults; docs/robots.md says what each does).

One process plays the scenario's ``[[faults]]`` in time order; one per robot and random source draws that
robot's seeded stream lazily (:meth:`vcran.core.faults.RandomFaults.stream`), so an hour of faults for a
thousand robots costs no memory up front. Faults act at priority FAULT: after the completions of the same
instant (docs/determinism.md).
"""

from __future__ import annotations

from collections.abc import Callable, Generator, Iterable
from typing import Any

import simpy

from vcran.core.faults import FaultSpec
from vcran.core.incidents import FaultEnded, FaultStarted
from vcran.sim.body import Body
from vcran.sim.holds import MOTION_FAILED, Halted
from vcran.sim.timing import FAULT, at


class Faults:
    """Applies faults to robots; ``link`` takes a robot and a duration and cuts its link (the RAN's part)."""

    def __init__(self, env: simpy.Environment, robots: dict[str, Body], link: Callable[[Body, float], None]) -> None:
        self.env, self.robots, self._link = env, robots, link

    def play(self, faults: Iterable[FaultSpec]) -> Generator[simpy.events.Event, Any, None]:
        for fault in faults:
            yield at(self.env, fault.t, FAULT)
            self.apply(fault)

    def apply(self, fault: FaultSpec) -> None:
        robot = self.robots[fault.robot]
        kind, duration = fault.kind, fault.duration
        if kind == "pause":
            applied = "pause" not in robot.holds
        elif kind == "resume":
            applied = "pause" in robot.holds
        elif kind == "motion_failure":
            applied = robot.driving or robot.index in robot.fleet.held
        else:
            applied = True
        robot.log_incident(FaultStarted(kind, duration, applied))
        if not applied:
            return
        if kind == "breakdown":
            robot.report("breakdown", f"breakdown for {duration:g} s: the robot stopped where it is [§4]")
            robot.hold(kind)
            self._later(duration, lambda: self._repaired(robot, kind))
        elif kind == "pause":
            robot.report("paused", "paused: the robot stopped where it is until resumed [§4]")
            robot.hold(kind)
        elif kind == "resume":
            robot.release("pause")
        elif kind == "motion_failure":
            robot.halt(Halted(MOTION_FAILED, "injected motion failure: the robot stopped where it is [§4]"))
        elif kind == "action_failure":
            robot.fail_next_action = True
        elif kind == "trigger":
            pass  # the protocol's logic hears it through the log (VDA 5050's waitForTrigger: vcran.sim.vda5050.node)
        else:
            assert kind == "link_down"
            self._later(duration, lambda: robot.log_incident(FaultEnded(kind)))  # before the RAN's backlog (if it holds one)
            self._link(robot, duration)

    @staticmethod
    def _repaired(robot: Body, kind: str) -> None:
        robot.release(kind)
        robot.log_incident(FaultEnded(kind))

    def _later(self, delay: float, then: Callable[[], None]) -> None:
        at(self.env, self.env.now + delay, FAULT).callbacks.append(lambda _: then())
