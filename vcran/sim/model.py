"""The model: builds the fleet from a scenario, wires it to a transport, runs it, sums it up.

This is the one place where scenario, environment and transport meet inside the simulation (the CLI
chooses which ones). The same code runs on ``simpy.Environment`` (scripted, replay: as fast as possible)
and on ``simpy.rt.RealtimeEnvironment`` (live).
"""

from __future__ import annotations

import dataclasses
import math
from array import array
from collections.abc import Callable, Iterator
from typing import Any, Protocol

import simpy

from vcran.core.battery import FleetBattery
from vcran.core.events import Event
from vcran.core.motion import FleetKinematics
from vcran.core.opil.effects import ErrorReport, State, StateChanged, TaskCancelled, TaskCompleted
from vcran.core.opil.messages import Message
from vcran.core.opil.motion_area import motion_area_problem
from vcran.core.opil.ranlogic import RanLogic
from vcran.core.scenario import Scenario
from vcran.core.stations import Station, StationMap
from vcran.core.wire import Inbound, Transport
from vcran.sim.contacts import Contacts
from vcran.sim.faults import Faults
from vcran.sim.ran import Decode, Ran
from vcran.sim.robot import RobotNode
from vcran.sim.timing import END, PRODUCTION, Environment, at


class EventSink(Protocol):
    def write(self, t: float, robot: str, name: str, fields: dict[str, Any]) -> None: ...


def default_decode(attribute: str, raw: Any) -> Message:
    from vcran.core.opil.codec import decode_attribute  # imported on first raw payload only

    return decode_attribute(attribute, raw)


def _put_size(buf: bytearray, size: int) -> None:
    """Append ``size`` in LEB128: seven bits a byte, low bits first, the high bit saying "more follows"."""
    while size >= 0x80:
        buf.append(0x80 | size & 0x7F)
        size >>= 7
    buf.append(size)


def _get_size(buf: bytearray, i: int) -> tuple[int, int]:
    """The LEB128 number at ``buf[i]`` and the position after it."""
    size = shift = 0
    while True:
        byte = buf[i]
        i += 1
        size |= (byte & 0x7F) << shift
        if byte < 0x80:
            return size, i
        shift += 7


class Labels:
    """Task labels in order, for the summary, front-coded in one buffer, optionally with a second short
    text each (a cancel's reason).

    A run ends tens of thousands of tasks per robot-hour at fleet scale, and every one is listed in
    summary.json. A list of strings (and of dicts) was most of what a run's memory grew by; an offset
    per label still cost 8 bytes beside a label of about 10. A robot's task ids mostly differ from the
    previous one in their last characters (``r7_41_2`` after ``r7_41_1``), so each label is kept as how
    many UTF-8 bytes it shares with the previous one, then the rest (both lengths in LEB128: one byte
    each below 128): about 3 bytes a task. The labels are only ever read in order.
    """

    __slots__ = ("_text", "_last", "_count", "_tags", "_tag_names")

    def __init__(self) -> None:
        self._text = bytearray()
        self._last = b""
        self._count = 0
        self._tags = array("B")
        self._tag_names: list[str] = []

    def append(self, label: str, tag: str | None = None) -> None:
        data = label.encode("utf-8", "surrogatepass")
        last = self._last
        shared, most = 0, min(len(data), len(last))
        while shared < most and data[shared] == last[shared]:
            shared += 1
        _put_size(self._text, shared)
        _put_size(self._text, len(data) - shared)
        self._text += data[shared:]
        self._last = data
        self._count += 1
        if tag is not None:
            if tag not in self._tag_names:
                self._tag_names.append(tag)
            self._tags.append(self._tag_names.index(tag))

    def __len__(self) -> int:
        return self._count

    def __iter__(self) -> Iterator[str]:
        text, i, end, last = self._text, 0, len(self._text), b""
        while i < end:
            shared, i = _get_size(text, i)
            rest, i = _get_size(text, i)
            last = last[:shared] + text[i:i + rest]
            i += rest
            yield last.decode("utf-8", "surrogatepass")

    def __eq__(self, other: object) -> bool:
        """Equal to a list of the same labels (what callers compared before it was compact)."""
        if isinstance(other, (list, tuple, Labels)):
            return list(self) == list(other)
        return NotImplemented

    __hash__ = None  # type: ignore[assignment]

    def pairs(self) -> Iterator[tuple[str, str]]:
        return zip(self, (self._tag_names[i] for i in self._tags))


class Model:
    def __init__(
        self,
        scenario: Scenario,
        transport: Transport,
        events: EventSink,
        env: simpy.Environment | None = None,
        decode: Decode = default_decode,
        progress: Callable[[float, int], None] | None = None,
    ) -> None:
        """``progress``, if given, is called with (simulated time, tasks completed) at every telemetry tick:
        an observer for a progress display, which sees the run but cannot change it. It rides on the tick
        rather than on events of its own, so a run with a progress bar schedules exactly the same events."""
        self.scenario = scenario
        self.env = env if env is not None else Environment(0.0)  # times are floats from the start
        self.transport = transport
        self.events = events
        s = scenario.settings
        self.stations = [
            Station(c.id, c.position[0], c.position[1], c.reach, c.parts, c.capacity, c.produce_every,
                    c.produce_start if c.produce_start is not None else c.produce_every, c.produce_limit,
                    c.area, c.charger)
            for c in scenario.stations
        ]
        station_map = StationMap(self.stations)
        self.fleet = FleetKinematics([r.pose for r in scenario.robots])
        self.completed: dict[str, Labels] = {r.id: Labels() for r in scenario.robots}
        self.cancelled: dict[str, Labels] = {r.id: Labels() for r in scenario.robots}
        self.fleet_errors = 0
        self.tasks_done = 0
        self._busy = [0.0] * len(scenario.robots)            # seconds not WAITING, per robot ...
        self._busy_since: list[float | None] = [None] * len(scenario.robots)  # ... and since when, if now
        self.robots: list[RobotNode] = []
        configs = [r.battery for r in scenario.robots]
        self.battery = FleetBattery(configs) if any(c is not None for c in configs) else None
        for i, config in enumerate(scenario.robots):
            logic = RanLogic(config.id, task_timeout=s.task_timeout, history_limit=s.history_limit,
                             area_check=motion_area_problem)
            robot = RobotNode(self.env, i, config, logic, self.fleet, station_map, s.durations,
                              self._log, self._changed, self.battery)
            robot.idle_horizon = 2.0 * s.telemetry_period
            self.robots.append(robot)
        self.ran = Ran(self.env, self.robots, transport, decode, self._unknown_entity)
        if self.battery is not None:
            from vcran.sim.power import Power  # numpy's sweep of the fleet's batteries: only a fleet with some

            self.ran.after_statuses = Power(self.robots, self.battery, s.telemetry_period, self.ran.publish).tick
        self._start_faults()
        self.contacts = (Contacts(self.env, self.robots, s.collisions, s.collision_resolution)
                         if s.collisions != "off" and len(self.robots) > 1 else None)
        self.finished = self.env.event()
        after_tick = self._idle_stop if progress is None else self._reporting(progress)
        self.env.process(self.ran.telemetry(s.telemetry_period, after_tick))
        self.env.process(self.ran.descriptions(s.description_period))
        for station in self.stations:
            if station.producing:
                self.env.process(self._produce(station))
        transport.attach(self.env, self.ran.deliver)

    def run(self) -> float:
        """Run to the scenario's end (duration, or idle); return the simulated end time."""
        s = self.scenario.settings
        if s.duration is not None:
            at(self.env, s.duration, END).callbacks.append(self._finish)
        self.env.run(until=self.finished)
        return self.env.now

    # --- wiring -----------------------------------------------------------------------------------------

    def _start_faults(self) -> None:
        sc = self.scenario
        if not sc.faults and not sc.random_faults:
            return
        faults = Faults(self.env, {r.id: r for r in self.robots}, self.ran.link_down)
        if sc.faults:
            self.env.process(faults.play(sc.faults))
        earlier: dict[tuple[str, str], int] = {}  # sources of a kind already drawing for a robot
        for source in sc.random_faults:
            until = min(source.until, sc.settings.duration if sc.settings.duration is not None else math.inf)
            limited = dataclasses.replace(source, until=until)
            for r in self.robots:
                if not source.robots or r.id in source.robots:
                    n = earlier.get((source.kind, r.id), 0)
                    earlier[source.kind, r.id] = n + 1
                    self.env.process(faults.play(limited.stream(sc.settings.seed, r.id, n)))

    def _log(self, robot: RobotNode, event: Event) -> None:
        now = self.env.now
        if event.NAME:  # else a ran_error whose incident was logged on its own
            self.events.write(now, robot.id, event.NAME, event.fields())
        # By exact class where no subclass exists: nine events a task, most of which matched none of four
        # isinstance calls (issue 30).
        kind = type(event)
        if kind is StateChanged:
            if event.from_ is State.WAITING:  # type: ignore[attr-defined]
                self._busy_since[robot.index] = now
            elif event.to is State.WAITING:  # type: ignore[attr-defined]
                self._busy[robot.index] += now - (self._busy_since[robot.index] or 0.0)
                self._busy_since[robot.index] = None
        elif kind is TaskCompleted:
            task = event.task  # type: ignore[attr-defined]
            self.completed[robot.id].append(task.description or task.label)  # Event: the label without its call
            self.tasks_done += 1
        elif kind is TaskCancelled:
            self.cancelled[robot.id].append(event.task.label, event.reason.value)  # type: ignore[attr-defined]
        elif isinstance(event, ErrorReport):
            self.ran.publish_error(robot, event)

    def _changed(self, robot: RobotNode) -> None:
        self.ran.changed(robot)

    def _unknown_entity(self, inbound: Inbound) -> None:
        """R11: an entity no RanLogic owns is reported and dropped."""
        self.fleet_errors += 1
        known = ", ".join(r.id for r in self.robots[:5]) + (", ..." if len(self.robots) > 5 else "")
        self.events.write(self.env.now, inbound.entity, "rejected", {
            "code": "unknown_robot", "severity": "error",
            "message": f"{inbound.attribute} for entity {inbound.entity}, which no RanLogic owns; robots: {known} [R11]",
        })

    def _idle_stop(self) -> bool:
        if not self.scenario.settings.until_idle or self.finished.triggered:
            return self.finished.triggered
        if self.transport.exhausted and not self.ran.links_down and all(r.logic.idle for r in self.robots):
            # End after everything else of this instant (descriptions included): priority END.
            at(self.env, self.env.now, END).callbacks.append(self._finish)
            return True
        return False

    def stop(self) -> None:
        """End the run at the current instant, after everything else of it (live mode: SIGINT/SIGTERM)."""
        at(self.env, self.env.now, END).callbacks.append(self._finish)

    def _finish(self, _: object) -> None:
        if not self.finished.triggered:
            self.finished.succeed()

    def _produce(self, station: Station):  # type: ignore[no-untyped-def]
        k = 0
        while True:
            yield at(self.env, station.produce_start + k * station.produce_every, PRODUCTION)
            station.produce()
            k += 1

    def _reporting(self, progress: Callable[[float, int], None]) -> Callable[[], bool]:
        def after_tick() -> bool:
            progress(self.env.now, self.tasks_done)
            return self._idle_stop()

        return after_tick

    # --- results ----------------------------------------------------------------------------------------

    def _battery_summary(self, r: RobotNode, t: float) -> dict[str, float]:
        b = self.battery
        assert b is not None
        i = r.index
        b.begin(i, t, self.fleet.distance(i, t), b.kind[i])  # close the running segment's books
        return {"charge": b.level0[i], "percentage": b.level0[i] / b.capacity[i], "used": b.used[i],
                "charged": b.added[i]}

    def busy(self, index: int) -> float:
        """Seconds robot ``index`` has spent not WAITING so far (a task was current; the report's busy time)."""
        since = self._busy_since[index]
        return self._busy[index] + (self.env.now - since if since is not None else 0.0)

    def summary(self) -> dict[str, Any]:
        """summary.json (SPEC §8): deterministic, no wall-clock figures."""
        t = self.env.now
        robots = {}
        for r in self.robots:
            robots[r.id] = {
                "completed": list(self.completed[r.id]),
                "cancelled": [{"task": task, "reason": reason} for task, reason in self.cancelled[r.id].pairs()],
                "distance": self.fleet.distance(r.index, t),
                "final_pose": dict(zip(("x", "y", "theta"), map(float, self.fleet.pose(r.index, t)))),
                "carrying": r.carrying,
                "parts_moved": r.parts_moved,
                "errors": r.logic.error_count,
            }
            if self.battery is not None and r.battery is not None:
                robots[r.id]["battery"] = self._battery_summary(r, t)
            if self.contacts is not None and self.contacts.count[r.index]:
                robots[r.id]["collisions"] = self.contacts.count[r.index]
        return {
            "scenario": self.scenario.settings.name,
            "seed": self.scenario.settings.seed,
            "sim_time": t,
            "robots": robots,
            "stations": {s.name: {"parts": s.parts, "produced": s.produced} for s in self.stations},
            "errors": sum(r.logic.error_count for r in self.robots) + self.fleet_errors,
        }


