"""The model: builds the fleet from a scenario, wires it to a transport, runs it, sums it up.

This is the one place where scenario, environment and transport meet inside the simulation (the CLI
chooses which ones). The same code runs on ``simpy.Environment`` (scripted, replay: as fast as possible)
and on ``simpy.rt.RealtimeEnvironment`` (live). It is shared by every protocol (docs/protocols.md): it builds
the robots' bodies, stations, batteries, faults and collisions, and takes the rest from the protocol's glue
(:mod:`vcran.sim.protocols`): each body's vehicle logic, routing and publishing, the logics' books.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from typing import Any, Protocol

import simpy

from vcran.core.battery import FleetBattery
from vcran.core.events import Event
from vcran.core.motion import FleetKinematics
from vcran.core.scenario import Scenario
from vcran.core.stations import Station, StationMap
from vcran.core.wire import Transport
from vcran.sim.body import Body
from vcran.sim.contacts import Contacts
from vcran.sim.faults import Faults
from vcran.sim.labels import Labels
from vcran.sim.protocols import glue
from vcran.sim.timing import END, PRODUCTION, Environment, at
from vcran.sim.traffic import SafetyFields


class EventSink(Protocol):
    def write(self, t: float, robot: str, name: str, fields: dict[str, Any]) -> None: ...


class Model:
    def __init__(
        self,
        scenario: Scenario,
        transport: Transport,
        events: EventSink,
        env: simpy.Environment | None = None,
        progress: Callable[[float, int], None] | None = None,
        protocol: str = "opil",
    ) -> None:
        """``progress``, if given, is called with (simulated time, tasks completed) at every telemetry tick:
        an observer for a progress display, which sees the run but cannot change it. It rides on the tick
        rather than on events of its own, so a run with a progress bar schedules exactly the same events.
        ``protocol`` names the robots' protocol (:mod:`vcran.sim.protocols`)."""
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
        # The books a protocol's glue keeps from its logic's events: tasks ended, and busy time.
        self.completed: dict[str, Labels] = {r.id: Labels() for r in scenario.robots}
        self.cancelled: dict[str, Labels] = {r.id: Labels() for r in scenario.robots}
        self.fleet_errors = 0
        self.tasks_done = 0
        self.busy_seconds = [0.0] * len(scenario.robots)            # seconds busy (OPIL: not WAITING) ...
        self.busy_since: list[float | None] = [None] * len(scenario.robots)  # ... and since when, if now
        self.robots: list[Body] = []
        configs = [r.battery for r in scenario.robots]
        self.battery = FleetBattery(configs) if any(c is not None for c in configs) else None
        self.protocol = glue(protocol)(self)
        for i, config in enumerate(scenario.robots):
            body = Body(self.env, i, config, self.fleet, station_map, s.durations, self.battery)
            body.idle_horizon = 2.0 * s.telemetry_period
            self.protocol.attach(body)
            body.start()
            self.robots.append(body)
        self.protocol.connect(transport)
        if self.battery is not None:
            from vcran.sim.power import Power  # numpy's sweep of the fleet's batteries: only a fleet with some

            self.protocol.every_tick(Power(self.robots, self.battery, s.telemetry_period,
                                           self.protocol.battery_states).tick)
        self._start_faults()
        self.contacts = (Contacts(self.env, self.robots, s.collisions, s.collision_resolution)
                         if s.collisions != "off" and len(self.robots) > 1 else None)
        self.fields = SafetyFields.of(self.env, scenario, self._incident)
        if self.fields is not None:  # docs/contract.md §12: robots brake for what enters their protective field
            for body in self.robots:
                self.fields.attach(body.index, body)
                body.fields = self.fields
            self.fields.signals = self.protocol.traffic()
        self.finished = self.env.event()
        after_tick = self._idle_stop if progress is None else self._reporting(progress)
        self.protocol.start(s.telemetry_period, s.description_period, after_tick)
        for station in self.stations:
            if station.producing:
                self.env.process(self._produce(station))
        transport.attach(self.env, self.protocol.deliver)

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
        faults = Faults(self.env, {r.id: r for r in self.robots}, self.protocol.link_down)
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

    def _incident(self, index: int, event: Event) -> None:
        """An event of robot ``index`` for the run's log (the protocol's ``log`` hook on its body)."""
        self.robots[index].log_incident(event)

    def _idle_stop(self) -> bool:
        if not self.scenario.settings.until_idle or self.finished.triggered:
            return self.finished.triggered
        if self.transport.exhausted and not self.protocol.links_down and self.protocol.idle():
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

    def _battery_summary(self, r: Body, t: float) -> dict[str, float]:
        b = self.battery
        assert b is not None
        i = r.index
        b.begin(i, t, self.fleet.distance(i, t), b.kind[i])  # close the running segment's books
        return {"charge": b.level0[i], "percentage": b.level0[i] / b.capacity[i], "used": b.used[i],
                "charged": b.added[i]}

    def busy(self, index: int) -> float:
        """Seconds robot ``index`` has spent busy so far (OPIL: not WAITING, a task was current; the report's
        busy time)."""
        since = self.busy_since[index]
        return self.busy_seconds[index] + (self.env.now - since if since is not None else 0.0)

    def summary(self) -> dict[str, Any]:
        """summary.json (docs/contract.md §8): deterministic, no wall-clock figures."""
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
                "errors": self.protocol.errors(r.index),
            }
            if self.battery is not None and r.battery is not None:
                robots[r.id]["battery"] = self._battery_summary(r, t)
            if self.contacts is not None and self.contacts.count[r.index]:
                robots[r.id]["collisions"] = self.contacts.count[r.index]
        summary = {
            "scenario": self.scenario.settings.name,
            "seed": self.scenario.settings.seed,
            "sim_time": t,
            "robots": robots,
            "stations": {s.name: {"parts": s.parts, "produced": s.produced} for s in self.stations},
            "errors": sum(self.protocol.errors(r.index) for r in self.robots) + self.fleet_errors,
        }
        if self.fields is not None:
            self.fields.summarise(summary)
        return summary


