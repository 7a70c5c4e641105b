"""VDA 5050's closed loop in simulated time (docs/contract.md §9, §11): what a master hears of its vehicles, and its handle.

:class:`MasterLoop` is the shared :class:`vcran.sim.loop.Loop` (jobs, timers, hooks, the link) for a
:class:`~vcran.core.vda5050.master.Master`, the loop :class:`vcran.testing.vda5050.yard.Yard` stands in for
without SimPy, here around the simulation's vehicles (bodies, stations, batteries, faults, collisions):

- **master -> vehicle.** What the master sends (:class:`SimMasterHandle`) crosses as on an MQTT broker: encoded
  in the vehicle's version, read back as the JSON object a broker's payload parses to, and handed to the
  vehicle's glue, which validates it against the official schema and decodes it (a master's invalid order
  is refused with a ``validationError`` in the vehicle's state, never a crash; one the vehicle's version
  cannot carry at all raises in the master's hook, as a client library refuses to encode it). Every message
  takes the link's latency (+ seeded jitter), in order per vehicle, and arrives once: a broker holds no value
  and merges nothing, so the link does not either (``holds=False``, :class:`vcran.sim.link.Link`).
- **vehicle -> master.** Each ``state`` and ``factsheet`` a vehicle publishes reaches the master with its
  instant's batch, the link's latency later: ``handle._heard`` first (what the handle reads), then the
  topic's hook if the master :meth:`~vcran.core.vda5050.master.Master.hears` it. ``visualization`` reaches
  it the same way only if it hears it (``"visualization"`` in its ``topics``): a master hears what it
  subscribes to, as live (``vcran manage --mqtt`` subscribes to it only then), and otherwise the vehicles
  build none for the loop (:attr:`MasterLoop.wants_visualization`); ``handle.position`` then follows the
  states. Vehicles
  are robot ids in the simulation, serial numbers to the master (:class:`~vcran.core.vda5050.fleet.MasterFleet`).
  A simulated run has no broker connection, so no ``connection`` message (docs/vda5050.md).
- **link_down** (docs/contract.md §4) is the vehicle's, as in a scripted run (:meth:`vcran.sim.vda5050.glue.Vda5050.link_down`):
  the vehicle goes on with its base, what reaches it meanwhile is lost (QoS 0, §6.2, a ``message_lost``
  event), and it publishes the latest of each topic it held once its link is back. The loop's link is never
  cut (:meth:`MasterLoop.outage`), so a replay of the run cuts the vehicle's link just the same.
- **When the run is over** (``until_idle``): ``visualization`` is periodic telemetry and never keeps a run
  from ending. ``state`` is not: a state on its way may make the master act (the drop it reports FINISHED
  ends a job). The state a vehicle publishes every 30 s whatever happens holds the end back by the link's
  latency at most, once in 30 s: it never keeps a run alive.
"""

from __future__ import annotations

import random
from typing import Any, cast

import orjson
import simpy

from vcran.core.jobs import Log
from vcran.core.scenario import Scenario
from vcran.core.vda5050 import codec
from vcran.core.vda5050.enums import Topic
from vcran.core.vda5050.fleet import MasterFleet
from vcran.core.vda5050.master import HOOKS, Heard, Master, MasterHandle, topic_of
from vcran.core.vda5050.order import InstantActions, Order
from vcran.core.wire import Outbound, Publish
from vcran.sim.loop import InSimTime, Loop

#: What vehicles publish periodically whatever happens: it never keeps a run from ending idle.
PERIODIC = frozenset({"visualization"})


class MasterLoop(Loop):
    """The vehicles' transport in a closed loop with a VDA 5050 master. ``log`` receives the ``job_*`` events."""

    periodic = PERIODIC
    holds = False  # MQTT: every message reaches the vehicle once, none held (module docstring)
    fleet: MasterFleet

    def __init__(self, scenario: Scenario, master: Master, log: Log) -> None:
        super().__init__(scenario, master, log)
        self.manager: Master = master
        self.serials = {agv.robot.id: agv.serial_number for agv in self.fleet.vehicles}

    def make_fleet(self, scenario: Scenario) -> MasterFleet:
        return MasterFleet.of(scenario)

    def make_handle(self, env: simpy.Environment, rng: random.Random) -> SimMasterHandle:
        return SimMasterHandle(env, self, rng)

    @property
    def wants_visualization(self) -> bool:  # type: ignore[override]
        """Only a master that hears ``visualization`` is sent any (module docstring)."""
        return self.manager.hears(Topic.VISUALIZATION)

    def notified(self, batch: list[Outbound]) -> None:
        """One batch of the vehicles' publications reaches the master, in the order they were published."""
        assert self.handle is not None
        handle, master = self.handle, self.manager
        assert isinstance(handle, SimMasterHandle)
        for out in batch:
            if not isinstance(out, Publish):
                continue  # a fleet's frame is OPIL's telemetry: VDA 5050 vehicles publish visualization
            serial, message = self.serials[out.robot], cast(Heard, out.message)  # what a vehicle publishes
            handle._heard(serial, message)
            topic = topic_of(message)
            if master.hears(topic):
                self._call(HOOKS[topic], serial, message)

    def outage(self, robot: str, until: float) -> bool:
        """False: the vehicle's glue cuts its own link (module docstring), as MQTT's QoS 0 does."""
        return False


class SimMasterHandle(InSimTime, MasterHandle):
    """The handle of a VDA 5050 master in simulated time: messages go over the link, timers are SimPy events."""

    _loop: MasterLoop

    def __init__(self, env: simpy.Environment, loop: MasterLoop, rng: random.Random) -> None:
        super().__init__(loop.fleet, loop.jobs, rng)
        self.env, self._loop = env, loop

    def _publish(self, serial: str, topic: Topic, message: Order | InstantActions) -> None:
        agv = self.fleet.vehicle(serial)
        payload: Any = orjson.loads(codec.encode(message, agv.config.version))  # the JSON object a broker carries
        assert self._loop.link is not None
        self._loop.link.write(agv.robot.id, topic.value, None, payload)
