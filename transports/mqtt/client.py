"""One MQTT connection with reconnect and back-off, shared by the vehicles' transport and the master's client.

Threads: paho's network thread (``loop_start``) runs the connection, reconnects with exponential back-off
after a drop (``backoff_start`` doubling up to ``backoff_cap`` wall seconds, reset by a successful
CONNACK) and calls the callbacks given here; any thread may :meth:`BrokerClient.publish`, which queues
the packet and wakes the network thread without waiting on the network. A callback that raises is
logged and the connection goes on: nothing a peer sends stops the edge.
"""

from __future__ import annotations

import logging
import threading
from collections import Counter
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from time import monotonic
from typing import Any

import orjson
import paho.mqtt.client as mqtt
from paho.mqtt.enums import CallbackAPIVersion

from transports.mqtt.topics import DELIVERY, BrokerUrl
from vcran.core.vda5050.enums import Topic
from vcran.core.wire import Inbound

log = logging.getLogger("vcran.mqtt")

#: Wall seconds a fleet's or a master's connections may take to come up before ``open`` gives up (and closes
#: them again: nothing half-connected stays): the default of both, and what ``vcran live`` and ``vcran manage`` wait.
CONNECT_TIMEOUT = 10.0


@dataclass(frozen=True)
class MqttOptions:
    """How the edge's connections behave; the defaults follow VDA 5050 (§6.14: a heartbeat "around 15
    seconds") and what a fleet on one broker needs."""

    #: MQTT keepalive, seconds: the broker sends a vehicle's last will when it hears nothing for 1.5 times this.
    keepalive: int = 15
    #: Reconnect back-off, wall seconds: the first wait, doubled after each failed attempt up to the cap.
    backoff_start: float = 0.25
    backoff_cap: float = 5.0
    #: Seconds a TCP connect may take before the attempt counts as failed.
    connect_timeout: float = 5.0
    #: Largest inbound payload handed on, bytes; a larger one is reported and dropped.
    max_payload: int = 1_048_576
    #: Client ids are ``<prefix>/<topic levels>`` (vehicles) and ``<prefix>-master-<n>`` (masters).
    client_prefix: str = "vcran"

    def __post_init__(self) -> None:
        if self.keepalive < 1 or not 0 < self.backoff_start <= self.backoff_cap or self.connect_timeout <= 0:
            raise ValueError("keepalive >= 1, 0 < backoff_start <= backoff_cap and connect_timeout > 0 are needed")
        if self.max_payload < 1:
            raise ValueError("max_payload must be positive")


class Tally:
    """Problems a peer caused, counted by kind, each distinct (kind, key) logged once: a master that sends
    garbage ten times a second gets one log line and a count, never a flood or a crash (docs/contract.md §11).
    :meth:`first` is the log-once alone, for a problem counted elsewhere."""

    #: How many distinct keys are remembered; past it, problems are counted without a log line.
    LIMIT = 1000

    def __init__(self) -> None:
        self.counts: Counter[str] = Counter()
        self._seen: set[tuple[str, object]] = set()
        self._lock = threading.Lock()

    def report(self, kind: str, key: object, message: str) -> None:
        with self._lock:
            self.counts[kind] += 1
            first = self._first(kind, key)
        if first:
            log.warning("%s (reported once; later ones are counted)", message)

    def first(self, kind: str, key: object) -> bool:
        """Whether ``(kind, key)`` comes for the first time (then the caller logs it), counting nothing: for a
        problem with a count of its own, such as a send the broker did not take (``MqttMaster.counts``)."""
        with self._lock:
            return self._first(kind, key)

    def _first(self, kind: str, key: object) -> bool:  # under _lock
        first = (kind, key) not in self._seen and len(self._seen) < self.LIMIT
        if first:
            self._seen.add((kind, key))
        return first

    def describe(self) -> str:
        with self._lock:
            return ", ".join(f"{n} {kind}" for kind, n in sorted(self.counts.items())) or "no problems"


class MqttUnavailable(ConnectionError):
    """The broker could not be reached, or refused, when the edge connected."""


def screened(tally: Tally, options: MqttOptions, robot: str, kind: Topic, topic: str, payload: bytes, *,
             parsed: bool = False) -> Inbound | None:
    """A received message as the edge hands it on: ``raw`` is the payload as text (bytes that are not UTF-8
    become lone surrogates, which no JSON parser accepts); None for a payload over ``max_payload``. A
    payload that is not JSON is handed on (its receiver refuses it, and a vehicle tells the master so) and
    reported once per vehicle and topic.

    ``parsed``: ``raw`` is the JSON value the payload parses to, parsed here once for a receiver that
    decodes it (:func:`vcran.core.vda5050.codec.decode_parsed`), and a payload that is not JSON, reported
    here, is not handed on: it is counted once, as a bad payload, not again as whatever its receiver
    would make of it."""
    if len(payload) > options.max_payload:
        tally.report("oversized payloads", (robot, kind), f"{topic}: a payload of {len(payload)} bytes, over "
                     f"the limit of {options.max_payload}, dropped")
        return None
    try:
        doc = orjson.loads(payload)
    except orjson.JSONDecodeError:
        tally.report("bad payloads", (robot, kind), f"{topic}: a payload that is not JSON")
        if parsed:
            return None
    return Inbound(robot, kind.value, raw=doc if parsed else payload.decode("utf-8", "surrogateescape"))


Will = Callable[[], tuple[str, bytes]]


class BrokerClient:
    """One paho client: connects in the background, keeps ``subscriptions`` after every (re)connect, and
    calls ``on_up`` (connected, subscriptions acknowledged), ``on_down`` and ``on_message(topic, payload)`` on
    its network thread. ``will()``, called before each connection attempt, gives the last will's topic and
    payload (delivered as ``connection`` is: §6.14's is the only will VDA 5050 defines)."""

    def __init__(self, url: BrokerUrl, client_id: str, options: MqttOptions, *,
                 subscriptions: Sequence[str] = (),
                 on_message: Callable[[str, bytes], None] | None = None,
                 on_up: Callable[[], None] | None = None,
                 on_down: Callable[[], None] | None = None,
                 will: Will | None = None) -> None:
        self.url, self.client_id, self.options = url, client_id, options
        self.connects = 0  # successful CONNACKs so far
        self.failures = 0  # attempts that did not connect
        self.last_error = "not connected yet"
        self._subscriptions = tuple(subscriptions)
        self._on_message, self._on_up, self._on_down, self._will = on_message, on_up, on_down, will
        self._up = threading.Event()
        self._subscribing: int | None = None  # the mid of the SUBSCRIBE whose SUBACK makes the client up
        self._started = False
        client = mqtt.Client(CallbackAPIVersion.VERSION2, client_id=client_id, clean_session=True,
                             protocol=mqtt.MQTTv311)
        client.reconnect_delay_set(options.backoff_start, options.backoff_cap)  # type: ignore[arg-type]
        client.connect_timeout = options.connect_timeout
        client.suppress_exceptions = True  # the callbacks below catch everything; this is the belt
        client.on_pre_connect = self._pre_connect
        client.on_connect = self._connected
        client.on_connect_fail = self._connect_failed
        client.on_disconnect = self._disconnected
        client.on_message = self._message
        client.on_subscribe = self._subscribed
        self._client = client

    @property
    def up(self) -> bool:
        return self._up.is_set()

    def start(self) -> None:
        """Connect in the background (retrying until :meth:`stop`); returns at once."""
        if self._started:
            return
        self._started = True
        self._client.connect_async(self.url.host, self.url.port, keepalive=self.options.keepalive)
        self._client.loop_start()

    def wait_up(self, timeout: float) -> bool:
        return self._up.wait(timeout)

    def publish(self, topic: str, payload: bytes, qos: int, retain: bool) -> mqtt.MQTTMessageInfo | None:
        """Queue one message; None if paho refused it (not connected), which the caller decides about."""
        info = self._client.publish(topic, payload, qos=qos, retain=retain)
        return info if info.rc == mqtt.MQTT_ERR_SUCCESS else None

    def disconnect(self) -> None:
        """A graceful MQTT DISCONNECT (the broker drops the last will); the network thread then ends."""
        self._client.disconnect()

    def join(self) -> None:
        """Wait for the network thread to end (after :meth:`disconnect`, or give up reconnecting)."""
        if self._started:
            self._client.loop_stop()
            self._started = False

    def stop(self) -> None:
        self.disconnect()
        self.join()

    def socket(self) -> Any:
        """The connection's socket (tests cut it to see the last will)."""
        return self._client.socket()

    # --- paho's callbacks, on the network thread ---------------------------------------------------------

    def _pre_connect(self, client: mqtt.Client, _userdata: Any) -> None:
        if self._will is not None:
            try:
                topic, payload = self._will()
            except Exception:  # noqa: BLE001 - a connection without a will beats none at all
                log.exception("%s: building the last will failed", self.client_id)
                return
            delivery = DELIVERY[Topic.CONNECTION]
            client.will_set(topic, payload, qos=delivery.qos, retain=delivery.retain)

    def _connected(self, client: mqtt.Client, _userdata: Any, _flags: Any, reason: Any, _props: Any) -> None:
        if reason.is_failure:
            self.failures += 1
            self.last_error = f"the broker refused the connection: {reason}"
            log.warning("%s: %s", self.client_id, self.last_error)
            return
        self.connects += 1
        if self.connects > 1:
            log.info("%s: connected again to %s", self.client_id, self.url)
        if self._subscriptions:  # up once the broker acknowledged them: nothing sent to us is missed after
            self._subscribing = client.subscribe([(topic, 0) for topic in self._subscriptions])[1]
        else:
            self._came_up()

    def _subscribed(self, _client: mqtt.Client, _userdata: Any, mid: int, reasons: Any, _props: Any) -> None:
        if mid != self._subscribing:
            return
        refused = [str(r) for r in reasons if r.is_failure]
        if refused:  # a broker's access rules: the connection stays, and the status says why nothing arrives
            self.last_error = f"the broker refused a subscription: {', '.join(refused)}"
            log.warning("%s: %s", self.client_id, self.last_error)
        self._came_up()

    def _came_up(self) -> None:
        self._up.set()
        self._call(self._on_up)

    def _connect_failed(self, _client: mqtt.Client, _userdata: Any) -> None:
        self.failures += 1
        self.last_error = f"cannot reach the broker at {self.url}"

    def _disconnected(self, _client: mqtt.Client, _userdata: Any, _flags: Any, reason: Any, _props: Any) -> None:
        was_up = self._up.is_set()
        self._up.clear()
        if was_up:
            self.last_error = f"connection lost ({reason}); reconnecting"
            if reason.is_failure:
                log.warning("%s: %s", self.client_id, self.last_error)
            self._call(self._on_down)

    def _message(self, _client: mqtt.Client, _userdata: Any, message: mqtt.MQTTMessage) -> None:
        if self._on_message is not None:
            try:
                topic = message.topic
            except UnicodeDecodeError:  # MQTT requires UTF-8 topics; a broker that lets one through
                topic = "\ufffd(a topic that is not UTF-8)"
            self._call(self._on_message, topic, message.payload)

    def _call(self, fn: Callable[..., None] | None, *args: Any) -> None:
        if fn is None:
            return
        try:
            fn(*args)
        except Exception:  # noqa: BLE001 - the connection must go on; the log says what went wrong
            log.exception("%s: handling a broker event failed", self.client_id)


def start_all(clients: Sequence[BrokerClient], url: BrokerUrl, timeout: float | None) -> None:
    """Start ``clients``; with a ``timeout``, wait that many seconds for all of them, and if one is still
    down, stop them all and raise :class:`MqttUnavailable` (nothing is left half-connected)."""
    for client in clients:
        client.start()
    if timeout is None:
        return
    deadline = monotonic() + timeout
    down = [c for c in clients if not c.wait_up(max(0.0, deadline - monotonic()))]
    if down:
        stop_all(clients)
        what = f"{len(down)} of {len(clients)} connections" if len(clients) > 1 else "not connected"
        raise MqttUnavailable(f"{url}: {what} after {timeout:g} s ({down[0].last_error})")


def stop_all(clients: Sequence[BrokerClient]) -> None:
    """Disconnect ``clients`` gracefully, all at once, then wait for their network threads."""
    for client in clients:
        client.disconnect()
    for client in clients:
        client.join()
