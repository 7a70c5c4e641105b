"""§6.14, the ``connection`` topic of one vehicle: ONLINE after connecting, OFFLINE before a graceful
disconnect, and CONNECTIONBROKEN, the last will the broker sends when the connection ends otherwise.

The edge, not the vehicle's logic, owns this topic: connecting is a network event, which no simulated
run has and no replay reproduces, so these messages never enter a trace. Their ``headerId`` counts on
this topic alone (§6.4: "defined per topic"), without gaps and in the order a subscriber sees them: the
last will must be set before the connection is made, so each attempt reserves two ids, ONLINE's and the
will's (n, n+1). The will's id is the one a graceful OFFLINE takes, since the broker then drops the will;
an attempt that fails reserves the same two again. Timestamps are the vehicle's calendar (its ``epoch``
plus simulated time, like its other messages); the will's is when it was set ("the timestamp and headerId
fields will always be outdated", §6.14).
"""

from __future__ import annotations

import threading
from collections.abc import Callable

from paho.mqtt.client import MQTTMessageInfo

from transports.mqtt.client import BrokerClient
from transports.mqtt.topics import DELIVERY, FleetVehicle
from vcran.core.vda5050.codec import encode
from vcran.core.vda5050.enums import ConnectionState, Topic
from vcran.core.vda5050.header import Header, timestamp
from vcran.core.vda5050.state import Connection


class ConnectionTopic:
    """The connection messages of one vehicle; ``now()`` is the simulated time (0 before the run starts)."""

    def __init__(self, vehicle: FleetVehicle, now: Callable[[], float]) -> None:
        self.vehicle = vehicle
        self.topic = vehicle.address.topic(Topic.CONNECTION)
        self.delivery = DELIVERY[Topic.CONNECTION]
        self._now = now
        self._next = 0  # the headerId of the next ONLINE
        self._lock = threading.Lock()

    def will(self) -> tuple[str, bytes]:
        """The last will for the attempt about to be made: CONNECTIONBROKEN, headerId n+1."""
        with self._lock:
            return self.topic, self._message(self._next + 1, ConnectionState.CONNECTIONBROKEN)

    def online(self) -> bytes:
        """ONLINE for the connection just made: headerId n; the next connection starts at n+2."""
        with self._lock:
            payload = self._message(self._next, ConnectionState.ONLINE)
            self._next += 2
            return payload

    def offline(self) -> bytes:
        """OFFLINE before a graceful disconnect: the will's headerId (n+1), which the broker now drops."""
        with self._lock:
            return self._message(self._next - 1, ConnectionState.OFFLINE)

    def send(self, client: BrokerClient, payload: bytes) -> MQTTMessageInfo | None:
        """Publish ONLINE or OFFLINE as §6.14 says: QoS 1, retained."""
        return client.publish(self.topic, payload, self.delivery.qos, self.delivery.retain)

    def _message(self, header_id: int, state: ConnectionState) -> bytes:
        v = self.vehicle
        header = Header(header_id, timestamp(self._now(), v.epoch), v.version.value,
                        v.address.manufacturer, v.address.serial_number)
        return encode(Connection(header=header, connection_state=state), v.version)
