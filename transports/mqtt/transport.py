"""The vehicles' side of VDA 5050 over MQTT (docs/contract.md §11): a fleet of simulated vehicles that a master drives
through a real broker. The edge of ``vcran live SCENARIO --mqtt URL`` (docs/vda5050.md, "Live over MQTT").

One MQTT connection per vehicle: VDA 5050 gives each vehicle its own last will (§6.14), and MQTT allows
one will per connection. Each vehicle's client subscribes to its own ``order`` and ``instantActions``
topics only, so a broker's access rules can confine each vehicle and no other fleet's traffic reaches
vcran.

Threads and what they own:

* the **simulation thread** (SimPy, :class:`~vcran.sim.live.LiveEnvironment`) calls :meth:`MqttTransport.send`,
  which encodes the message for the vehicle's version and queues it on the vehicle's connection (paho
  writes it on its network thread): it never waits on the network;
* one **network thread per vehicle** (paho's) connects, reconnects with back-off, and hands each message
  on the vehicle's two topics to the simulation with :meth:`LiveEnvironment.call_soon`, which stamps it
  with the simulated time at which it entered (what the trace records and a replay reproduces).

Inbound: ``Inbound(entity=<robot id>, attribute="order" | "instantActions", raw=<the payload as text>)``,
the payload decoded as UTF-8 (bytes that are not UTF-8 kept as lone surrogates, which no JSON parser
accepts, so the vehicle refuses them as not JSON). The VDA 5050 glue decodes and validates it with
:func:`vcran.core.vda5050.codec.decode`; a payload that is not JSON is still delivered (the vehicle reports
its ``validationError`` to the master, §6.6.4.1) and reported here once per vehicle and topic.

Outbound: ``Publish(t, robot, attribute="state" | "visualization" | "factsheet", message=<the model>)``,
headers stamped by the vehicle's logic. While a vehicle's broker connection is down, its visualization
is dropped and only its latest state and latest factsheet are kept; they go out once, after ONLINE, when
it reconnects: nothing stale or duplicated reaches the master, and the run itself never notices.
"""

from __future__ import annotations

import logging
import threading
from collections import Counter, deque
from collections.abc import Iterable
from functools import partial
from time import monotonic

import simpy

from transports.base import Deliver, Transport, wall_stats
from transports.mqtt.client import CONNECT_TIMEOUT, BrokerClient, MqttOptions, Tally, screened, start_all, stop_all
from transports.mqtt.connection import ConnectionTopic
from transports.mqtt.topics import DELIVERY, FROM_VEHICLE, TO_VEHICLE, BrokerUrl, FleetVehicle, check_fleet
from vcran.core.vda5050.codec import encode
from vcran.core.vda5050.enums import Topic
from vcran.core.wire import Frame, Inbound, Outbound, Publish
from vcran.sim.live import LiveEnvironment

log = logging.getLogger("vcran.mqtt")

#: What a vehicle keeps, latest only, while its connection is down, in the order it sends them on return.
HELD = (Topic.FACTSHEET, Topic.STATE)


class _Side:
    """One vehicle's connection and what it holds while the connection is down."""

    def __init__(self, transport: MqttTransport, vehicle: FleetVehicle) -> None:
        self.vehicle = vehicle
        self.transport = transport
        self.connection = ConnectionTopic(vehicle, transport.now)
        self.topics = {vehicle.address.topic(t): t for t in TO_VEHICLE}
        self.lock = threading.Lock()  # up and held, between the simulation thread and the network thread
        self.up = False
        self.held: dict[Topic, bytes] = {}
        self.counts: Counter[str] = Counter()  # under lock: sent, dropped, superseded
        options = transport.options
        self.client = BrokerClient(
            transport.url, f"{options.client_prefix}/{vehicle.address}", options,
            subscriptions=tuple(self.topics), on_message=self.received, on_up=self.came_up,
            on_down=self.went_down, will=self.connection.will)

    def came_up(self) -> None:
        """Connected and subscribed: ONLINE (§6.14), then what was held, oldest kind first."""
        self.connection.send(self.client, self.connection.online())
        with self.lock:
            for topic in HELD:
                payload = self.held.get(topic)
                if payload is not None and self._publish(topic, payload):  # else: gone again, still held
                    del self.held[topic]
            self.up = True

    def went_down(self) -> None:
        with self.lock:
            self.up = False

    def send(self, topic: Topic, payload: bytes) -> None:
        with self.lock:
            if self.up and self._publish(topic, payload):
                return
            if topic in HELD:
                if topic in self.held:
                    self.counts["superseded"] += 1
                self.held[topic] = payload
            else:
                self.counts["dropped"] += 1

    def _publish(self, topic: Topic, payload: bytes) -> bool:
        delivery = DELIVERY[topic]
        if self.client.publish(self.vehicle.address.topic(topic), payload, delivery.qos, delivery.retain) is None:
            return False
        self.counts["sent"] += 1
        return True

    def received(self, topic: str, payload: bytes) -> None:
        kind = self.topics.get(topic)
        tally = self.transport.tally
        if kind is None:  # only a broker that ignores our subscriptions sends this
            tally.report("foreign topics", topic, f"{self.vehicle.robot}: a message on {topic!r}, which is "
                         "not one of its topics, ignored")
            return
        inbound = screened(tally, self.transport.options, self.vehicle.robot, kind, topic, payload)
        if inbound is not None:
            self.transport.enter(inbound)


class MqttTransport(Transport):
    """The fleet ``vehicles`` on the broker at ``url``; :meth:`open` connects them, :meth:`attach` starts
    handing their messages to the simulation, :meth:`close` says OFFLINE and disconnects."""

    wants_frames = False  # VDA 5050 has no fleet telemetry frame; the glue publishes visualization itself
    wants_visualization = True  # onto the broker, every telemetry period, for whoever subscribes (§6.13)

    def __init__(self, url: BrokerUrl, vehicles: Iterable[FleetVehicle], options: MqttOptions | None = None) -> None:
        self.url = url
        self.options = options or MqttOptions()
        self.vehicles = check_fleet(vehicles)
        self.tally = Tally()
        self.latencies: deque[float] = deque(maxlen=100_000)  # wall seconds from arrival to the simulation
        #: Wall seconds from an order's or instantActions' arrival to the first state the vehicle sent after it
        #: entered the simulation (the state it caused: a vehicle answers each with one, §6.10), and how many
        #: messages entered; the simulation thread's alone.
        self.answers: deque[float] = deque(maxlen=100_000)
        self.delivered = 0
        self._unanswered: dict[str, float] = {}  # robot -> arrival of its oldest message no state followed yet
        self._env: LiveEnvironment | None = None
        self._deliver: Deliver | None = None
        self._early: list[tuple[Inbound, float]] = []  # arrived before attach
        self._lock = threading.Lock()  # _env and _early
        self._sides = {robot: _Side(self, vehicle) for robot, vehicle in self.vehicles.items()}
        self._opened = False

    def now(self) -> float:
        """The simulated time of this wall-clock instant (0 before the run starts)."""
        env = self._env
        return env.wall_now() if env is not None else 0.0

    # --- Transport --------------------------------------------------------------------------------------

    def open(self, timeout: float | None = CONNECT_TIMEOUT) -> None:
        """Connect every vehicle; with a ``timeout``, wait up to that many seconds for all of them and raise
        :class:`~transports.mqtt.client.MqttUnavailable` (every connection closed again) if one is still down. None: return at once,
        the connections come up in the background."""
        if not self._opened:
            self._opened = True
            start_all([side.client for side in self._sides.values()], self.url, timeout)

    def attach(self, env: simpy.Environment, deliver: Deliver) -> None:
        if not isinstance(env, LiveEnvironment):
            raise TypeError("the MQTT transport runs on a LiveEnvironment (real time)")
        with self._lock:
            self._env, self._deliver = env, deliver
            for inbound, arrived in self._early:
                env.call_soon(partial(self._enter, inbound, arrived))
            self._early.clear()
        self.open(timeout=None)

    def send(self, out: Outbound) -> None:
        if isinstance(out, Frame):
            return
        assert isinstance(out, Publish)
        side = self._sides.get(out.robot)
        if side is None:
            raise ValueError(f"no vehicle {out.robot!r} on this transport")
        try:
            topic = Topic(out.attribute)
        except ValueError:
            topic = None
        if topic not in FROM_VEHICLE or topic is Topic.CONNECTION:
            raise ValueError(f"{out.robot}: a vehicle publishes state, visualization and factsheet here, not "
                             f"{out.attribute!r} (the transport itself owns connection, §6.14)")
        side.send(topic, encode(out.message, side.vehicle.version))
        if topic is Topic.STATE and self._unanswered:
            arrived = self._unanswered.pop(out.robot, None)
            if arrived is not None:
                self.answers.append(monotonic() - arrived)

    def close(self) -> None:
        """OFFLINE for every connected vehicle (retained, QoS 1, acknowledged), then a graceful disconnect,
        which makes the broker drop the last wills (§6.14)."""
        pending = []
        for side in self._sides.values():
            with side.lock:
                up, side.up = side.up, False
            if up:
                info = side.connection.send(side.client, side.connection.offline())
                if info is not None:
                    pending.append(info)
        deadline = monotonic() + 5.0
        for info in pending:
            try:
                info.wait_for_publish(max(0.0, deadline - monotonic()))
            except (RuntimeError, ValueError):  # the connection went meanwhile: its will says so
                pass
        stop_all([side.client for side in self._sides.values()])

    # --- status -----------------------------------------------------------------------------------------

    @property
    def counts(self) -> Counter[str]:
        """Messages ``sent``, visualization ``dropped`` and held messages ``superseded`` while a connection
        was down, over the fleet."""
        total: Counter[str] = Counter()
        for side in self._sides.values():
            with side.lock:
                total.update(side.counts)
        return total

    @property
    def waiting(self) -> int:
        """Messages that arrived before :meth:`attach`, to enter the simulation at its start."""
        with self._lock:
            return len(self._early)

    def client(self, robot: str) -> BrokerClient:
        """``robot``'s connection (its health; tests cut its socket to see the last will)."""
        return self._sides[robot].client

    @property
    def connected(self) -> int:
        return sum(side.client.up for side in self._sides.values())

    def status(self) -> str:
        """One line for the live status display."""
        reconnects = sum(max(0, side.client.connects - 1) for side in self._sides.values())
        c = self.counts
        return (f"MQTT {self.url}: {self.connected}/{len(self._sides)} vehicles connected, {reconnects} reconnects; "
                f"out {c['sent']} sent, {c['dropped']} visualization dropped and {c['superseded']} held messages "
                f"superseded while down; in {self.delivered} delivered, {self.tally.describe()}")

    def latency_stats(self) -> dict[str, float]:
        """Count, median and 99th percentile of the wall seconds from arrival to entering the simulation."""
        return wall_stats(self.latencies)

    def answer_stats(self) -> dict[str, float]:
        """The same of the wall seconds from an order's (or instantActions') arrival to the state it caused."""
        return wall_stats(self.answers)

    # --- inbound ----------------------------------------------------------------------------------------

    def enter(self, inbound: Inbound) -> None:
        """From a network thread: hand ``inbound`` to the simulation at this instant (or at its start)."""
        arrived = monotonic()
        with self._lock:
            env = self._env
            if env is None:
                self._early.append((inbound, arrived))
                return
        env.call_soon(partial(self._enter, inbound, arrived))

    def _enter(self, inbound: Inbound, arrived: float) -> None:
        assert self._deliver is not None
        self.latencies.append(monotonic() - arrived)
        self.delivered += 1
        self._unanswered.setdefault(inbound.entity, arrived)
        self._deliver(inbound)

