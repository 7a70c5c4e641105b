"""The live Orion transport (SPEC §7): a virtual fleet that a real fleet manager drives through Orion.

Threads and what they own:

* the **simulation thread** (SimPy, :class:`~vcran.sim.live.LiveEnvironment`) calls :meth:`send`, which
  only writes into the :class:`Outbox` and wakes the sender: it never waits on the network;
* the **sender** (:mod:`transports.orion.sender`) takes the outbox at every telemetry tick and writes
  the fleet's changes with ``POST /v2/op/update`` (one request per tick, every ``ran_error`` included;
  more only when a body would pass Orion's 1 MB limit); when Orion is down or refuses, it keeps the
  latest value per robot and attribute and every error, and retries with capped backoff;
* the **inbound** thread polls ``GET /v2/entities`` for the whole fleet, or, with a notification URL,
  keeps one subscription alive (re-created only when Orion says it is gone) and reads the entities
  after each (re)subscription so nothing Orion holds is missed; notifications arrive on the
  :class:`Listener`.

Inbound attribute values go into the simulation through :meth:`LiveEnvironment.call_soon`, which stamps
them with the simulated time at which they entered. A value identical to the last one forwarded for the
same entity and attribute is not forwarded again: that is a re-read, which R10 ignores anyway, and
dropping it here keeps traces small. A read that overlaps a notification never forwards a value older
than the notified one.
"""

from __future__ import annotations

import logging
import math
import statistics
import threading
from dataclasses import dataclass
from functools import partial
from time import monotonic
from typing import Any
from urllib.parse import urlsplit

import simpy

from transports.base import Deliver, Transport
from transports.orion.client import OrionClient, OrionError
from transports.orion.health import Backoff, Health
from transports.orion.listener import Listener
from transports.orion.outbox import Outbox
from transports.orion.sender import Sender
from transports.orion.workers import poll, resilient
from vcran.core.messages import INBOUND
from vcran.core.wire import Frame, Inbound, Outbound, Publish
from vcran.io.http_server import one_line
from vcran.sim.live import LiveEnvironment

log = logging.getLogger("vcran.orion")


@dataclass(frozen=True)
class LiveOptions:
    entity_type: str
    robots: tuple[str, ...]
    #: Where Orion should POST notifications; None means polling.
    notify_url: str | None = None
    #: Address the listener binds to; default 127.0.0.1 and the notify URL's port.
    listen_host: str = "127.0.0.1"
    #: Polling period in simulated seconds (scaled by the speed factor like everything else).
    poll_interval: float = 0.25
    #: How often (wall seconds) the subscription is checked and re-created if Orion lost it.
    keepalive: float = 2.0
    max_notification: int = 1_048_576
    backoff_start: float = 0.25
    backoff_cap: float = 5.0


class OrionTransport(Transport):
    def __init__(self, client: OrionClient, options: LiveOptions) -> None:
        self.client, self.options = client, options
        self.outbox = Outbox()
        self.sender = Sender(client, self.outbox, options.entity_type, options.robots,
                             Backoff(options.backoff_start, options.backoff_cap))
        self.outbound = self.sender.health
        self.inbound = Health("inbound")
        self.latencies: list[float] = []  # wall seconds from arrival to entering the simulation
        self._robots = frozenset(options.robots)
        self._reads = 0
        self._lock = threading.Lock()  # last forwarded values, forward order
        self._last: dict[tuple[str, str], Any] = {}
        #: How many times a value of (robot, attribute) was forwarded: lets a read skip what a
        #: notification delivered while the read was in flight.
        self._forwarded: dict[tuple[str, str], int] = {}
        self._stop = threading.Event()
        self._env: LiveEnvironment | None = None
        self._deliver: Deliver | None = None
        self._threads: list[threading.Thread] = []
        self._listener: Listener | None = None
        self._subscription: str | None = None
        self._subscriptions: set[str] = set()
        self._resent = 0.0

    @property
    def requests(self) -> int:
        """Requests Orion answered with success: reads and accepted updates."""
        return self._reads + self.sender.counts.accepted

    @property
    def updates(self) -> int:
        """Batch updates Orion accepted."""
        return self.sender.counts.accepted

    # --- Transport --------------------------------------------------------------------------------------

    def open(self) -> None:
        """Bind the notification listener (if any) now, so that a busy port fails before the run starts."""
        if self.options.notify_url and self._listener is None:
            parts = urlsplit(self.options.notify_url)
            self._listener = Listener(self.options.listen_host, parts.port or 80, parts.path or "/",
                                      self._on_notification, self.options.max_notification)

    def attach(self, env: simpy.Environment, deliver: Deliver) -> None:
        if not isinstance(env, LiveEnvironment):
            raise TypeError("the Orion transport runs on a LiveEnvironment (real time)")
        self._env, self._deliver = env, deliver
        self.open()
        inbound = self._subscription_loop if self.options.notify_url else self._poll_loop
        for name, target in (("vcran-sender", partial(self.sender.loop, self._stop)), ("vcran-inbound", inbound)):
            thread = threading.Thread(target=resilient(name, target, self._stop), name=name, daemon=True)
            thread.start()
            self._threads.append(thread)

    def send(self, out: Outbound) -> None:
        if isinstance(out, Frame):
            self.outbox.put_frame(out)
            self.sender.tick()  # one batch per telemetry tick
        else:
            assert isinstance(out, Publish)
            self.outbox.put(out.robot, out.attribute, out.message)

    def close(self) -> None:
        self._stop.set()
        self.sender.release()
        for thread in self._threads:
            thread.join(timeout=10)
        try:
            self.sender.finish()  # a last attempt with what the run produced at its end
        except Exception:  # noqa: BLE001 - closing must finish
            log.exception("final delivery failed")
        if self._listener is not None:
            self._listener.stop()
        for sid in sorted(self._subscriptions):
            try:
                self.client.unsubscribe(sid)
            except OrionError as exc:
                log.warning("could not delete subscription %s: %s", sid, exc)
        self.client.close()

    def status(self) -> str:
        """One-line health for the live status display."""
        mode = "subscription" if self.options.notify_url else "polling"
        c = self.sender.counts
        errors = f", ran_errors {c.errors_delivered} delivered" if c.errors_delivered or c.errors_undeliverable else ""
        if c.errors_undeliverable:
            errors += f", {c.errors_undeliverable} undeliverable"
        return (f"Orion out {self.outbound.describe()}, in ({mode}) {self.inbound.describe()}, "
                f"{c.accepted}/{c.attempts} updates accepted, {self._reads} reads{errors}")

    def latency_stats(self) -> dict[str, float]:
        if not self.latencies:
            return {}
        ordered = sorted(self.latencies)
        p99 = ordered[min(len(ordered) - 1, math.ceil(0.99 * len(ordered)) - 1)]
        return {"count": len(ordered), "median": statistics.median(ordered), "p99": p99}

    # --- inbound ----------------------------------------------------------------------------------------

    def _poll_loop(self) -> None:
        assert self._env is not None
        poll(self._read_all, self.options.poll_interval / self._env.speed, self.inbound, self._stop,
             self.options.backoff_start, self.options.backoff_cap,
             on_back=self.sender.wake)  # the sender may be deep in its backoff: Orion is back now

    def _subscription_loop(self) -> None:
        unread = True  # the entities must be read after each (re)subscription
        failures: tuple[Any, Any, Any] = (None, None, None)  # lastFailure, failsCounter, timesSent (_failures)
        backoff = Backoff(self.options.backoff_start, self.options.backoff_cap)
        while not self._stop.is_set():
            try:
                if self._subscription is not None:
                    shown = self.client.subscription(self._subscription)
                    if shown is None:
                        # Orion lost it (restart, or someone deleted it), and maybe our entities with it.
                        log.warning("subscription %s is gone from Orion; re-creating it", self._subscription)
                        self._subscriptions.discard(self._subscription)
                        self._subscription = None
                        self.sender.wake()
                    elif (seen := _failures(shown)) != failures:
                        # Orion could not deliver some notification (a burst, a slow moment): what it
                        # carried is only in Orion now, so read it (SPEC §7: no loss window).
                        if seen[0] is not None:
                            log.warning("Orion reports a failed notification (%s, %s failing): reading "
                                        "the entities again", one_line(seen[0], 40), one_line(seen[1], 20))
                            unread = True
                        failures = seen
                if self._subscription is None:
                    self._subscription = self.client.subscribe(self._subscription_body())
                    self._subscriptions.add(self._subscription)
                    log.info("subscribed to Orion: %s", self._subscription)
                    unread, failures = True, (None, None, None)
                if unread:
                    self._read_all()
                    unread = False
                backoff.reset()
                if self.inbound.ok("subscription in place"):
                    self.sender.wake()  # the sender may be deep in its backoff: Orion is back now
            except OrionError as exc:  # keep the subscription id: only Orion saying 404 makes it stale
                self.inbound.failed(f"{exc}; retrying with backoff")
                self._stop.wait(backoff.next(exc.retry_after))
                continue
            self._stop.wait(self.options.keepalive)

    def _subscription_body(self) -> dict[str, Any]:
        attrs = list(INBOUND)
        return {
            "description": "vcran live: fleet commands",
            "subject": {
                "entities": [{"id": robot, "type": self.options.entity_type} for robot in self.options.robots],
                "condition": {"attrs": attrs},
            },
            "notification": {"http": {"url": self.options.notify_url}, "attrs": attrs, "attrsFormat": "normalized"},
        }

    def _read_all(self) -> None:
        """Read every robot's command attributes once; raises OrionError."""
        with self._lock:
            before = dict(self._forwarded)
        entities = self.client.entities(self.options.entity_type, list(self.options.robots), INBOUND)
        self._reads += 1
        if len(entities) < len(self.options.robots) and monotonic() - self._resent > 1.0:
            self._resent = monotonic()  # some robot entity is gone (Orion restarted or someone deleted it)
            self.sender.wake()
        self._forward(entities, monotonic(), unchanged_since=before)

    def _on_notification(self, subscription: str, data: list[dict[str, Any]]) -> None:
        if subscription not in self._subscriptions:
            log.info("notification for unknown subscription %s ignored", one_line(subscription, 60))
            return
        self._forward(data, monotonic())

    def _forward(self, entities: list[dict[str, Any]], arrived: float,
                 unchanged_since: dict[tuple[str, str], int] | None = None) -> None:
        """Hand new values to the simulation, in order. ``unchanged_since`` (a read's snapshot of the
        forward counters): skip values that a notification replaced while the read was in flight."""
        env = self._env
        assert env is not None
        with self._lock:  # one order for reads and notifications: the order of call_soon
            for entity in entities:
                robot = entity.get("id")
                if not isinstance(robot, str) or robot not in self._robots:  # a list id is unhashable
                    continue
                for attribute in INBOUND:
                    if attribute not in entity:
                        continue
                    key = (robot, attribute)
                    if unchanged_since is not None and self._forwarded.get(key, 0) != unchanged_since.get(key, 0):
                        continue
                    value = entity[attribute]
                    if self._last.get(key) == value:
                        continue
                    self._last[key] = value
                    self._forwarded[key] = self._forwarded.get(key, 0) + 1
                    inbound = Inbound(robot, attribute, raw=value)
                    env.call_soon(partial(self._enter, inbound, arrived))

    def _enter(self, inbound: Inbound, arrived: float) -> None:
        assert self._deliver is not None
        self.latencies.append(monotonic() - arrived)
        if len(self.latencies) > 100_000:
            del self.latencies[:50_000]
        self._deliver(inbound)


def _failures(subscription: dict[str, Any]) -> tuple[Any, Any, Any]:
    """What changes when Orion fails to deliver a notification: ``lastFailure`` and ``failsCounter``, and
    ``timesSent`` while failures are counted. Orion gives delivery times in whole seconds and resets
    ``failsCounter`` at a success, so a failure, a success and a failure within one second between two
    looks leave the first two as they were; the notifications sent meanwhile do not."""
    notification = subscription.get("notification")
    if not isinstance(notification, dict):
        return None, None, None
    failing = notification.get("failsCounter")
    return notification.get("lastFailure"), failing, notification.get("timesSent") if failing else None
