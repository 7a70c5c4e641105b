"""OPIL's closed loop in simulated time (docs/contract.md §9): what an OPIL fleet manager hears of the robots, and its handle.

:class:`ClosedLoop` is the shared :class:`vcran.sim.loop.Loop` (jobs, timers, hooks, the link) for an
:class:`vcran.FleetManager`: the RAN's publications reach it as Orion would notify them (``on_update``
for each actual change of an attribute it subscribed to, every write of ``robot_description``), the
fleet's ``current_motion`` frames become its messages, and its :class:`SimHandle` writes assignments over
the link and reads what Orion holds.
"""

from __future__ import annotations

import random
from typing import Any

import simpy

from vcran.core.jobs import Log
from vcran.core.opil.build import motion_message
from vcran.core.opil.manager import FleetManager, OpilHandle
from vcran.core.opil.messages import FORCED_UPDATES, OUTBOUND, Message, Time
from vcran.core.scenario import Scenario
from vcran.core.wire import Frame, Outbound
from vcran.sim.loop import InSimTime, Loop

#: Attributes whose updates are periodic whatever happens: they never keep a run from ending idle.
PERIODIC = frozenset({"robot_description"})


class ClosedLoop(Loop):
    """The RAN's transport in a closed loop with an OPIL fleet manager. ``log`` receives the ``job_*`` events."""

    periodic = PERIODIC
    every = frozenset({"ran_error"})  # every error is published once the link is back; other attributes coalesce

    def __init__(self, scenario: Scenario, manager: FleetManager, log: Log) -> None:
        super().__init__(scenario, manager, log)
        self.manager: FleetManager = manager
        self._subscribed = manager.attributes
        self._latest: dict[tuple[str, str], Message] = {}
        self._frame: Frame | None = None
        self._index = {r: i for i, r in enumerate(self.fleet.robot_ids)}
        self._stale: dict[str, Frame] = {}  # robots missing from the latest frame (link down): their last one

    def make_handle(self, env: simpy.Environment, rng: random.Random) -> SimHandle:
        return SimHandle(env, self, rng)

    def notified(self, batch: list[Outbound], forced: frozenset[str] = FORCED_UPDATES) -> None:
        """One batch of the RAN's publications reaches the manager: Orion's view changes, and the
        manager is notified of each actual change of an attribute it subscribed to, and of every write
        of an attribute in ``forced``, changed or not: the periodic ``robot_description``, which live
        mode writes with Orion's forcedUpdate so that it reaches every subscriber (docs/contract.md §2). The link of
        ``vcran manage`` passes an empty ``forced`` for what a notification of the whole entity carries
        (there an unchanged value is no write of it)."""
        assert self.handle is not None
        now = self.handle.now
        wants = self._subscribed
        for out in batch:
            if isinstance(out, Frame):
                self._take_frame(out)
                if wants is None or "current_motion" in wants:
                    for robot in out.robots:
                        message = self.motion(robot)
                        assert message is not None
                        self._call("on_update", robot, "current_motion", message, now)
                continue
            key = (out.robot, out.attribute)
            if self._latest.get(key) == out.message and out.attribute not in forced:
                continue  # no actual change: Orion notifies nobody
            self._latest[key] = out.message
            if wants is None or out.attribute in wants:
                self._call("on_update", out.robot, out.attribute, out.message, now)

    def _take_frame(self, frame: Frame) -> None:
        """Keep the latest frame; a robot missing from it (its link is down) keeps its last known row."""
        previous = self._frame
        if previous is not None and len(frame.robots) < len(self._index):
            present = set(frame.robots)
            for robot in previous.robots:
                if robot not in present and robot not in self._stale:
                    self._stale[robot] = previous
        if self._stale:
            for robot in frame.robots:
                self._stale.pop(robot, None)
        self._frame = frame

    def latest(self, robot: str, attribute: str) -> Message | None:
        if attribute == "current_motion" and self._frame is not None:
            return self.motion(robot)
        return self._latest.get((robot, attribute))

    def motion(self, robot: str) -> Message | None:
        """``current_motion`` of ``robot`` as Orion holds it, built (like live mode) from the frame row."""
        frame = self._stale.get(robot, self._frame)
        if frame is None:
            return None
        if len(frame.robots) == len(self._index):
            i = self._index[robot]
        elif robot in frame.robots:
            i = frame.robots.index(robot)
        else:
            return None
        x, y, theta, v, w = (float(c) for c in frame.columns[i])
        return motion_message(Time.from_seconds(frame.t), x, y, theta, v, w)


class SimHandle(InSimTime, OpilHandle):
    """The handle of an OPIL manager in simulated time: writes go over the link, timers are SimPy events."""

    _loop: ClosedLoop

    def __init__(self, env: simpy.Environment, loop: ClosedLoop, rng: random.Random) -> None:
        super().__init__(loop.fleet, loop.jobs, rng)
        self.env, self._loop = env, loop

    def _write(self, robot: str, attribute: str, message: Message | None, raw: Any = None) -> None:
        assert self._loop.link is not None
        self._loop.link.write(robot, attribute, message, raw)

    def latest(self, robot: str, attribute: str) -> Message | None:
        if attribute not in OUTBOUND:  # what the manager writes is not kept: None for ever, say so instead
            raise ValueError(f"latest: {attribute!r} is not an attribute robots publish; known: {', '.join(OUTBOUND)}")
        return self._loop.latest(self._robot(robot), attribute)
