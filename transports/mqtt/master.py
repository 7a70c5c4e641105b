"""The master's side of VDA 5050 over MQTT: what ``vcran manage --mqtt`` uses to run a Python master
live (docs/contract.md §11), and what tests use to drive vcran's vehicles as any master would.

One connection (a master has no last will in VDA 5050), subscribed with wildcards to the ``state``,
``connection`` and ``factsheet`` topics of every interface name of its fleet; ``visualization`` too when
asked. Messages of vehicles outside the fleet (another fleet on the same broker) are reported once per
topic and ignored. Each message of a fleet vehicle is handed to ``on_message`` on the network thread as
``Inbound(entity=<robot id>, attribute=<topic>, raw=<the payload as text>)``, as the vehicles' transport
hands theirs; decoding (:func:`vcran.core.vda5050.codec.decode`) is the receiver's business. With
``parsed=True``, ``raw`` is the JSON value the payload parses to, and a payload that is not JSON is only
counted (:func:`transports.mqtt.client.screened`): ``vcran manage --mqtt``'s link decodes what it gets
without parsing it again. A receiver that finds a message invalid reports it to :attr:`MqttMaster.tally` as
:data:`INVALID`: what was handed on less those is what the master heard (:meth:`MqttMaster.traffic`).

:meth:`MqttMaster.send` publishes an ``order`` or ``instantActions`` message (QoS 0, not retained, §6.2),
encoded for the vehicle's version, and says whether the broker connection took it: while the broker is
unreachable nothing is queued, since a stale order sent on reconnect could do harm; the master decides
what to send again.
"""

from __future__ import annotations

import itertools
import os
from collections import Counter, deque
from collections.abc import Callable, Iterable

import paho.mqtt.client as mqtt

from transports.mqtt.client import CONNECT_TIMEOUT, BrokerClient, MqttOptions, Tally, screened, start_all
from transports.mqtt.topics import DELIVERY, TO_VEHICLE, BrokerUrl, FleetVehicle, check_fleet, fleet_filter, parse_topic
from vcran.core.vda5050.codec import encode
from vcran.core.vda5050.enums import Topic
from vcran.core.vda5050.order import InstantActions, Order
from vcran.core.wire import Inbound

_MASTERS = itertools.count(1)
_QUEUED = (mqtt.MQTT_ERR_SUCCESS, mqtt.MQTT_ERR_AGAIN)  # a publish paho holds to write
_TOPICS = {Order: Topic.ORDER, InstantActions: Topic.INSTANT_ACTIONS}
#: The tally's kind of a message handed on that its receiver found invalid (module docstring): not heard.
INVALID = "invalid messages"


class MqttMaster:
    """A master's connection to the fleet ``vehicles`` on the broker at ``url``."""

    def __init__(self, url: BrokerUrl, vehicles: Iterable[FleetVehicle], on_message: Callable[[Inbound], None], *,
                 options: MqttOptions | None = None, visualization: bool = False,
                 on_up: Callable[[], None] | None = None, parsed: bool = False) -> None:
        """``parsed``: hand on each payload parsed, not as text (module docstring)."""
        self.url = url
        self._parsed = parsed
        self.options = options or MqttOptions()
        self.vehicles = check_fleet(vehicles)
        self.tally = Tally()
        self.counts: Counter[str] = Counter()  # sent, unsent (broker unreachable), received
        self._on_message = on_message
        self._in_flight: deque[mqtt.MQTTMessageInfo] = deque()  # taken by paho, not yet written (:attr:`idle`)
        self._by_topic = {v.address.topic(t): (v.robot, t) for v in self.vehicles.values()
                          for t in (Topic.STATE, Topic.CONNECTION, Topic.FACTSHEET, Topic.VISUALIZATION)}
        topics = [Topic.STATE, Topic.CONNECTION, Topic.FACTSHEET] + ([Topic.VISUALIZATION] if visualization else [])
        interfaces = sorted({(v.address.interface_name, v.address.major) for v in self.vehicles.values()})
        subscriptions = [fleet_filter(name, major, t) for name, major in interfaces for t in topics]
        self._wanted = frozenset(topics)
        client_id = f"{self.options.client_prefix}-master-{os.getpid()}-{next(_MASTERS)}"
        self.client = BrokerClient(url, client_id, self.options, subscriptions=subscriptions,
                                   on_message=self._received, on_up=on_up)

    def open(self, timeout: float | None = CONNECT_TIMEOUT) -> None:
        """Connect; with a ``timeout``, wait that long and raise :class:`MqttUnavailable` if still down."""
        start_all([self.client], self.url, timeout)

    @property
    def up(self) -> bool:
        return self.client.up

    def send(self, robot: str, message: Order | InstantActions) -> bool:
        """Publish ``message`` to ``robot``; False if the broker connection did not take it."""
        vehicle = self.vehicles.get(robot)
        if vehicle is None:
            raise ValueError(f"no vehicle {robot!r} in this master's fleet")
        topic = _TOPICS.get(type(message))
        if topic is None:
            raise ValueError(f"a master sends orders and instant actions, not {type(message).__name__}")
        delivery = DELIVERY[topic]
        info = self.client.publish(vehicle.address.topic(topic), encode(message, vehicle.version),
                                   delivery.qos, delivery.retain)
        self.counts["sent" if info is not None else "unsent"] += 1
        if info is not None and not info.is_published():
            self._in_flight.append(info)
        return info is not None

    @property
    def idle(self) -> bool:
        """Every message :meth:`send` took has been written to the broker connection (QoS 0: nothing more
        is known of it), or the connection it was queued on is gone. Call it from the thread that sends."""
        while self._in_flight and (self._in_flight[0].rc not in _QUEUED or self._in_flight[0].is_published()):
            self._in_flight.popleft()  # written, or lost with its connection (paho sets rc: CONN_LOST)
        return not self._in_flight

    def close(self) -> None:
        self.client.stop()

    @property
    def heard(self) -> int:
        """Messages handed on to ``on_message`` that their receiver did not report as :data:`INVALID`."""
        return self.counts["received"] - self.tally.counts[INVALID]

    def traffic(self) -> str:
        """What crossed the connection, and the problems of the tally: ``vcran manage --mqtt``'s end-of-run
        figure. The counts are the network thread's: read it once :meth:`close` has returned for a final one."""
        c = self.counts
        problems = self.tally.describe()
        return (f"{c['sent']} message(s) sent, {c['unsent']} not sent (broker down); {self.heard} heard"
                + ("" if problems == "no problems" else f" ({problems})"))

    def status(self) -> str:
        state = "connected" if self.client.up else self.client.last_error
        return f"MQTT {self.url}: master {state}, {max(0, self.client.connects - 1)} reconnects; {self.traffic()}"

    def _received(self, topic: str, payload: bytes) -> None:
        found = self._by_topic.get(topic)
        if found is None or found[1] not in self._wanted:
            parsed = parse_topic(topic)
            what = "a vehicle outside the fleet" if parsed is not None else "not a VDA 5050 topic"
            self.tally.report("foreign topics", topic, f"a message on {topic!r} ({what}) ignored")
            return
        inbound = screened(self.tally, self.options, *found, topic, payload, parsed=self._parsed)
        if inbound is not None:
            self.counts["received"] += 1
            self._on_message(inbound)


assert set(_TOPICS.values()) == set(TO_VEHICLE)
