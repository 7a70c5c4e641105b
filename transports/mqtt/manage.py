"""A VDA 5050 master against vehicles on a real MQTT broker, in real time (docs/contract.md §9, §11; docs/vda5050.md,
"Live over MQTT").

``vcran manage --mqtt`` runs the very :class:`~vcran.core.vda5050.master.Master` object that
:func:`vcran.simulate` runs, with the same handle: :class:`MqttLoop` is
:class:`vcran.sim.vda5050.loop.MasterLoop` on a :class:`~vcran.sim.live.LiveEnvironment` (so ``now``, jobs
and ``call_at`` timers follow the wall clock, scaled by the speed factor), with :class:`MqttMasterLink` in
place of the simulated link, as :class:`transports.orion.manage.OrionLoop` puts Orion there for OPIL:

* **master -> vehicle.** What the master sends goes out at once through
  :meth:`transports.mqtt.master.MqttMaster.send` (QoS 0, not retained, §6.2), encoded in the vehicle's
  version; one the version cannot carry raises in the master's hook, as in simulated time. While the broker
  is unreachable nothing is queued (a stale order sent on reconnect could do harm): the send is counted as
  not sent and reported once per vehicle, and the master, which retries what a vehicle's state does not
  show taken, decides what to send again.
* **vehicle -> master.** Every ``state``, ``connection`` and ``factsheet`` of a fleet vehicle, and its
  ``visualization`` if the master hears it (subscribed to only then, as :class:`MasterLoop` hands it on only
  then: the same master hears the same topics live and in simulated time), is parsed once, by the edge's
  screen (:func:`transports.mqtt.client.screened`), then validated against the official schema and decoded
  (:func:`vcran.core.vda5050.codec.decode_parsed`) on the network thread, and handed to the simulation with
  :meth:`LiveEnvironment.call_soon`: every hook runs in the simulation's one thread, ``handle._heard`` first,
  then the topic's hook, as in :meth:`MasterLoop.notified`. A payload that is not JSON is counted once, as a
  bad payload (the screen's); a message that does not validate is reported once per vehicle and topic and
  counted as an invalid message; never a crash. One of a vehicle outside the fleet is :class:`MqttMaster`'s
  to report.
* **what the master heard** (``log``, beside the ``job_*`` events): the vehicles' orders as their states
  show them, ``order_accepted`` and ``order_ended`` (:class:`vcran.core.vda5050.heard.HeardOrders`), logged
  when each state reaches the simulation thread, before the master's hooks see it, as
  :class:`transports.orion.manage.OrionLoop` logs the robots' states for OPIL: ``vcran report`` of the run
  folder draws the vehicles' busy time from them.
* **until_idle**: what the master sent is on its way until paho has written it to the broker connection
  (:attr:`MqttMasterLink.inbound_idle`); what a vehicle published is on its way while it waits for the
  simulation thread (:attr:`MqttMasterLink.outbound_idle`; ``visualization``, periodic telemetry, never
  holds a run back, as in :class:`MasterLoop`).
"""

from __future__ import annotations

import logging
import random
import threading
from collections.abc import Callable, Iterable
from functools import partial

import simpy

from transports.mqtt.client import CONNECT_TIMEOUT, MqttOptions
from transports.mqtt.master import INVALID, MqttMaster
from transports.mqtt.topics import BrokerUrl, FleetVehicle, fleet_of
from vcran.core.jobs import Log
from vcran.core.scenario import Scenario
from vcran.core.vda5050 import codec
from vcran.core.vda5050.enums import Topic
from vcran.core.vda5050.heard import HeardOrders
from vcran.core.vda5050.master import Master
from vcran.core.vda5050.order import InstantActions, Order
from vcran.core.vda5050.state import State
from vcran.core.wire import Deliver, Inbound, Outbound, Publish
from vcran.sim.live import LiveEnvironment
from vcran.sim.vda5050.loop import PERIODIC, MasterLoop, SimMasterHandle

log = logging.getLogger("vcran.mqtt")



class MqttMasterLink:
    """The master's side of the broker for :class:`MqttLoop` (module docstring): ``notify`` gets each valid
    message of a fleet vehicle, in the simulation thread, as a one-message batch of
    :class:`~vcran.core.wire.Publish` (robot id, topic, the decoded model)."""

    def __init__(self, env: LiveEnvironment, url: BrokerUrl, vehicles: Iterable[FleetVehicle],
                 notify: Callable[[list[Outbound]], None], options: MqttOptions | None = None, *,
                 visualization: bool = False) -> None:
        """``visualization``: subscribe to the vehicles' visualization too (a master that hears it)."""
        self.env, self.notify = env, notify
        self.master = MqttMaster(url, vehicles, self._received, options=options, visualization=visualization,
                                 parsed=True)  # each payload parsed once, by the screen; one not JSON counted there
        self._lock = threading.Lock()
        # Non-periodic messages handed to the simulation, not heard yet (under _lock: the network thread adds,
        # the simulation thread takes away), for until_idle: only the link sees both ends, the master neither.
        self._waiting = 0

    def open(self, timeout: float | None = CONNECT_TIMEOUT) -> None:
        """Connect; :class:`~transports.mqtt.client.MqttUnavailable` if the broker is not reached in ``timeout``."""
        self.master.open(timeout)

    def close(self) -> None:
        self.master.close()

    # --- ManagerLink ---------------------------------------------------------------------------------------

    def write(self, robot: str, attribute: str, message: Order | InstantActions, raw: object = None) -> None:
        """Send ``message`` (the model: ``attribute`` is its topic) to ``robot`` now."""
        if self.master.send(robot, message):
            return
        if self.master.tally.first("not sent", robot):  # counted in master.counts["unsent"] each time
            log.warning("%s to %s not sent: the broker connection is down (the master decides what to send again; "
                        "reported once per vehicle, later ones are counted)", attribute, robot)

    @property
    def inbound_idle(self) -> bool:
        """Everything the master sent has been written to the broker connection (or was lost with it)."""
        return self.master.idle

    @property
    def outbound_idle(self) -> bool:
        """No vehicle's message (other than periodic telemetry) waits for the simulation thread."""
        with self._lock:
            return self._waiting == 0

    # --- status --------------------------------------------------------------------------------------------

    @property
    def sent(self) -> int:
        return self.master.counts["sent"]

    @property
    def unsent(self) -> int:
        return self.master.counts["unsent"]

    def describe(self) -> str:
        """The end-of-run figure of the broker traffic (:meth:`MqttMaster.traffic`; after :meth:`close`)."""
        return self.master.traffic()

    # --- inbound, on the network thread --------------------------------------------------------------------

    def _received(self, inbound: Inbound) -> None:
        topic = Topic(inbound.attribute)
        vehicle = self.master.vehicles[inbound.entity]
        message = codec.decode_parsed(topic, inbound.raw, vehicle.version)  # the screen parsed it (module docstring)
        if isinstance(message, codec.Invalid):  # counted by the tally, as foreign topics and bad payloads are
            self.master.tally.report(INVALID, (inbound.entity, topic),
                                     f"{vehicle.address.topic(topic)}: an invalid {topic.value} ignored, "
                                     f"{message.path}: {message.problem}")
            return
        periodic = topic.value in PERIODIC
        if not periodic:
            with self._lock:
                self._waiting += 1
        self.env.call_soon(partial(self._hand_on, Publish(0.0, inbound.entity, topic.value, message), periodic))

    def _hand_on(self, publish: Publish, periodic: bool) -> None:
        try:
            self.notify([publish])
        finally:
            if not periodic:
                with self._lock:
                    self._waiting -= 1


class MqttLoop(MasterLoop):
    """:class:`MasterLoop` whose link is a real MQTT broker: the master's side of ``vcran manage --mqtt``.
    :meth:`attach` connects (an unreachable broker raises :class:`~transports.mqtt.client.MqttUnavailable`
    before any hook runs); :attr:`link` says what crossed it."""

    link: MqttMasterLink | None

    def __init__(self, scenario: Scenario, master: Master, log: Log, url: BrokerUrl, *,
                 options: MqttOptions | None = None, connect_timeout: float | None = CONNECT_TIMEOUT) -> None:
        super().__init__(scenario, master, log)
        self.url, self.options, self.connect_timeout = url, options, connect_timeout
        self._log = log
        #: The vehicles' orders as the master hears them (module docstring, "what the master heard").
        self.orders = HeardOrders()

    def notified(self, batch: list[Outbound]) -> None:
        assert self.handle is not None
        for out in batch:
            if isinstance(out, Publish) and isinstance(out.message, State):
                for event, fields in self.orders.heard(out.robot, out.message):
                    self._log(self.handle.now, out.robot, event, fields)
        super().notified(batch)

    def make_link(self, env: simpy.Environment, deliver: Deliver) -> MqttMasterLink:
        if not isinstance(env, LiveEnvironment):
            raise TypeError("a master on an MQTT broker runs on a LiveEnvironment (real time)")
        link = MqttMasterLink(env, self.url, fleet_of(self.scenario), self.notified, self.options,
                              visualization=self.wants_visualization)
        link.open(self.connect_timeout)
        return link

    def make_handle(self, env: simpy.Environment, rng: random.Random) -> LiveMasterHandle:
        return LiveMasterHandle(env, self, rng)


class LiveMasterHandle(SimMasterHandle):
    """The master's handle live: timers as in simulated time (on the LiveEnvironment's clock), what it
    sends straight to the broker."""

    def _publish(self, serial: str, topic: Topic, message: Order | InstantActions) -> None:
        loop = self._loop
        assert isinstance(loop, MqttLoop) and isinstance(loop.link, MqttMasterLink)
        robot = self.fleet.vehicle(serial).robot.id
        loop.orders.sent(robot, message)
        loop.link.write(robot, topic.value, message)
