"""vcran's VDA 5050 vehicle on a real broker, in real time, for masters written outside vcran (issue 31,
"Must show": a third-party master drives a 2.0.0 vehicle; the test's own paho master does the same).

The vehicle's logic is vcran's pure :class:`~vcran.core.vda5050.vehicle.Vehicle` on the bench body of
:mod:`vcran.testing.vda5050.harness` (which applies every effect), behind vcran's :class:`MqttTransport`;
what this module adds is time: a :class:`LiveEnvironment` process that moves the body along its route at
``speed`` m/s in ticks of ``tick`` simulated seconds while nothing holds it, reports each waypoint reached,
ends each body action ``act_time`` seconds after it started, fires the vehicle's timers when due, and
publishes every state the vehicle asks for.

It stands in for vcran's VDA 5050 SimPy glue (vcran/sim/vda5050/, issue 31 item 4) until that lands: the
tests that use it then run against the glue's live fleet instead (``vcran live SCENARIO --mqtt``), and this
module goes. It is a test double of the *simulation*, not of the vehicle: every protocol decision is the
real Vehicle's.
"""

from __future__ import annotations

import math
import threading
from typing import Any

from transports.mqtt import FleetVehicle, MqttTransport, parse_url
from vcran.core.vda5050.config import VehicleConfig
from vcran.core.vda5050.effects import Effect
from vcran.core.wire import Inbound, Publish
from vcran.sim.live import LiveEnvironment
from vcran.testing.vda5050.harness import Bench

ROBOT = "agv1"


class LiveVehicle:
    """One vehicle standing at ``(x, y)``, on the broker at ``url`` once :meth:`start` returns."""

    def __init__(self, url: str, config: VehicleConfig, *, x: float = 0.0, y: float = 0.0, speed: float = 1.0,
                 tick: float = 0.05, act_time: float = 1.0, factor: float = 1.0) -> None:
        self.config, self.speed, self.tick, self.act_time = config, speed, tick, act_time
        self.transport = MqttTransport(parse_url(url), [FleetVehicle.of(ROBOT, config)])
        self.env = LiveEnvironment(factor)
        self.bench = Bench(config, x=x, y=y)  # the vehicle starts: factsheet and state, published by start()
        self.acting: dict[str, float] = {}  # body actions under way: seconds of work left
        self.effects: list[Effect] = list(self.bench.effects)
        self._published = 0
        self._factsheets = 0
        self._done = self.env.event()
        self._thread = threading.Thread(target=self._run, name="live-vehicle", daemon=True)
        self.error: BaseException | None = None

    def start(self) -> LiveVehicle:
        self.transport.open()
        self.transport.attach(self.env, lambda inbound: self._inbound(inbound))
        self.env.process(self._body())
        self._flush()
        self._thread.start()
        return self

    def stop(self) -> None:
        self.env.call_soon(lambda: self._done.succeed() if not self._done.triggered else None)
        self._thread.join(30)
        self.transport.close()
        assert not self._thread.is_alive(), "the vehicle's simulation did not stop"
        if self.error is not None:
            raise self.error

    # --- the simulation thread -----------------------------------------------------------------------------

    def _run(self) -> None:
        try:
            self.env.run(until=self._done)
        except BaseException as exc:  # noqa: BLE001 - re-raised in the test's thread by stop()
            self.error = exc

    def _inbound(self, inbound: Inbound) -> None:
        self._catch_up()
        raw = str(inbound.raw).encode("utf-8", "surrogatepass")
        if inbound.attribute == "order":
            self._apply(self.bench.order(raw))
        else:
            self._apply(self.bench.instant(raw))

    def _body(self):
        """Each tick: timers due, then the body drives and acts unless something holds it."""
        while True:
            yield self.env.timeout(self.tick)
            self._catch_up()
            if self.bench.holds:
                continue
            self._drive(self.speed * self.tick)
            for action_id in list(self.acting):
                self.acting[action_id] -= self.tick
                if self.acting[action_id] <= 1e-9 and action_id in self.bench.acting:
                    del self.acting[action_id]
                    self._apply(self.bench.finish(action_id))

    def _drive(self, step: float) -> None:
        bench = self.bench
        if not bench.route:
            return
        goal = bench.route[0]
        left = math.hypot(goal.x - bench.x, goal.y - bench.y)
        if left > step:
            bench.x += (goal.x - bench.x) * step / left
            bench.y += (goal.y - bench.y) * step / left
            bench.odometer += step
            return
        self._apply(bench.reach())  # the bench counts the rest of the leg on its odometer

    def _catch_up(self) -> None:
        self._apply(self.bench.at(self.env.now))

    def _apply(self, effects: list[Effect]) -> None:
        """The bench applied the effects already; start the clocks of new body actions and publish."""
        self.effects += effects
        for action_id in self.bench.acting:
            self.acting.setdefault(action_id, self.act_time)
        for action_id in list(self.acting):
            if action_id not in self.bench.acting:  # interrupted
                del self.acting[action_id]
        self._flush()

    def _flush(self) -> None:
        bench, now = self.bench, self.env.now
        if bench.factsheets > self._factsheets:
            self._factsheets = bench.factsheets
            self._send("factsheet", bench.vehicle.factsheet(now))
        for state in bench.states[self._published:]:
            self._send("state", state)
        self._published = len(bench.states)

    def _send(self, topic: str, message: Any) -> None:
        self.transport.send(Publish(self.env.now, ROBOT, topic, message))
