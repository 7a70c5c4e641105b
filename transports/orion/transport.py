"""The live Orion transport (SPEC §7): a virtual fleet that a real fleet manager drives through Orion.

Threads and what they own:

* the **simulation thread** (SimPy, :class:`~vcran.sim.live.LiveEnvironment`) calls :meth:`send`, which
  only writes into the :class:`Outbox` and wakes the sender: it never waits on the network;
* the **sender** takes the outbox at every telemetry tick and writes the whole fleet's changes with
  ``POST /v2/op/update`` (one request per tick, more only when a batch would pass Orion's 1 MB limit);
  when Orion is down it keeps the latest value per robot and attribute and retries with capped backoff;
* the **inbound** thread polls ``GET /v2/entities`` for the whole fleet, or, with a notification URL,
  keeps one subscription alive (re-created when Orion lost it) and reads the entities once after each
  (re)subscription so nothing Orion holds is missed; notifications arrive on the :class:`Listener`.

Inbound attribute values go into the simulation through :meth:`LiveEnvironment.call_soon`, which stamps
them with the simulated time at which they entered. A value identical to the last one forwarded for the
same entity and attribute is not forwarded again: that is a re-read, which R10 ignores anyway, and
dropping it here keeps traces small.
"""

from __future__ import annotations

import logging
import math
import statistics
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from time import monotonic
from typing import Any
from urllib.parse import urlsplit

import simpy

from transports.base import Deliver, Transport
from transports.orion.client import OrionClient, OrionError
from transports.orion.listener import Listener
from transports.orion.outbox import Outbox
from vcran.messages import (
    INBOUND,
    Header,
    Message,
    Motion,
    Point,
    Pose,
    PoseStamped,
    Quaternion,
    Time,
    Twist,
    Vector3,
)
from vcran.sim.live import LiveEnvironment
from vcran.wire import Frame, Inbound, Outbound, Publish

log = logging.getLogger("vcran.orion")

#: Order of attributes inside one entity of a batch update.
ATTRIBUTE_ORDER = ("current_motion", "assignment_status", "ran_status", "robot_description", "ran_error")


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


class Health:
    """One line per change of state, not one per failed tick (SPEC §7 "each fault is logged once")."""

    def __init__(self, what: str) -> None:
        self.what = what
        self.fault: str | None = None
        self.since = 0.0
        self.failures = 0

    def failed(self, message: str) -> None:
        self.failures += 1
        if self.fault is None:
            self.since = monotonic()
            log.warning("%s: %s; retrying in the background", self.what, message)
        elif message != self.fault:
            log.warning("%s: %s", self.what, message)
        self.fault = message

    def ok(self, detail: str = "") -> None:
        if self.fault is not None:
            log.warning("%s: Orion is back after %.1f s%s", self.what, monotonic() - self.since,
                        f", {detail}" if detail else "")
        self.fault = None

    def describe(self) -> str:
        return "ok" if self.fault is None else f"down {monotonic() - self.since:.0f}s"


class OrionTransport(Transport):
    def __init__(self, client: OrionClient, options: LiveOptions) -> None:
        self.client, self.options = client, options
        self.outbox = Outbox()
        self.outbound = Health("outbound")
        self.inbound = Health("inbound")
        self.requests = 0  # all requests that got an answer
        self.updates = 0  # of which outbound batch updates
        self.latencies: list[float] = []  # wall seconds from arrival to entering the simulation
        self._robots = set(options.robots)
        self._last: dict[tuple[str, str], Any] = {}
        self._last_lock = threading.Lock()
        self._stop = threading.Event()
        self._flush = threading.Event()
        self._env: LiveEnvironment | None = None
        self._deliver: Deliver | None = None
        self._threads: list[threading.Thread] = []
        self._listener: Listener | None = None
        self._subscriptions: set[str] = set()
        self._subscription: str | None = None
        self._resent = 0.0

    # --- Transport --------------------------------------------------------------------------------------

    def attach(self, env: simpy.Environment, deliver: Deliver) -> None:
        if not isinstance(env, LiveEnvironment):
            raise TypeError("the Orion transport runs on a LiveEnvironment (real time)")
        self._env, self._deliver = env, deliver
        if self.options.notify_url:
            parts = urlsplit(self.options.notify_url)
            self._listener = Listener(self.options.listen_host, parts.port or 80, parts.path or "/",
                                      self._on_notification, self.options.max_notification)
            inbound: Callable[[], None] = self._subscription_loop
        else:
            inbound = self._poll_loop
        for name, target in (("vcran-sender", self._send_loop), ("vcran-inbound", inbound)):
            thread = threading.Thread(target=target, name=name, daemon=True)
            thread.start()
            self._threads.append(thread)

    def send(self, out: Outbound) -> None:
        if isinstance(out, Frame):
            self.outbox.put_frame(out)
            self._flush.set()  # one batch per telemetry tick
        else:
            assert isinstance(out, Publish)
            self.outbox.put(out.robot, out.attribute, out.message)

    def close(self) -> None:
        self._stop.set()
        self._flush.set()
        for thread in self._threads:
            thread.join(timeout=10)
        self._deliver_pending()  # a last attempt with what the run produced at its end
        if self._listener is not None:
            self._listener.stop()
        if self._subscription is not None:
            try:
                self.client.unsubscribe(self._subscription)
            except OrionError as exc:
                log.warning("could not delete subscription %s: %s", self._subscription, exc)
        self.client.close()

    def status(self) -> str:
        """One-line health for the live status display."""
        mode = "subscription" if self.options.notify_url else "polling"
        return (f"Orion out {self.outbound.describe()}, in ({mode}) {self.inbound.describe()}, "
                f"{self.updates} updates, {self.requests - self.updates} reads")

    def latency_stats(self) -> dict[str, float]:
        if not self.latencies:
            return {}
        ordered = sorted(self.latencies)
        p99 = ordered[min(len(ordered) - 1, math.ceil(0.99 * len(ordered)) - 1)]
        return {"count": len(ordered), "median": statistics.median(ordered), "p99": p99}

    # --- outbound ---------------------------------------------------------------------------------------

    def _send_loop(self) -> None:
        backoff = self.options.backoff_start
        while not self._stop.is_set():
            self._flush.wait()
            self._flush.clear()
            if self._stop.is_set():
                return
            was_down = self.outbound.fault is not None
            if self._deliver_pending():
                backoff = self.options.backoff_start
                if was_down:  # Orion may have come back empty: restore everything, not only the changes
                    self.outbox.resend_all()
                    self._flush.set()
            else:
                self._stop.wait(backoff)
                backoff = min(backoff * 2, self.options.backoff_cap)
                self._flush.set()  # try again even without a new tick

    def _deliver_pending(self) -> bool:
        from vcran.codec import CodecError, encode_entity_json, split_batch

        pending, frame = self.outbox.take()
        if not pending and frame is None:
            return True
        try:
            entities = [encode_entity_json(robot, self.options.entity_type, attrs)
                        for robot, attrs in _entities(self.options.robots, pending, frame)]
            bodies = split_batch(entities)
        except CodecError as exc:  # a bug, not a fault of Orion: drop the batch, say so loudly
            log.error("cannot encode the outbound batch: %s", exc)
            return True
        try:
            for body in bodies:
                self.client.update(body)
                self.requests += 1
                self.updates += 1
        except OrionError as exc:
            # Bodies already taken stay taken; giving everything back resends them, which Orion
            # treats as a same-value write. Simpler than tracking which entities got through.
            self.outbox.give_back(pending, frame)
            self.outbound.failed(str(exc))
            return False
        self.outbound.ok(f"delivered {len(entities)} entities")
        return True

    # --- inbound ----------------------------------------------------------------------------------------

    def _poll_loop(self) -> None:
        assert self._env is not None
        period = self.options.poll_interval / self._env.speed
        next_poll = monotonic()
        while not self._stop.is_set():
            self._read_all()
            next_poll = max(next_poll + period, monotonic())
            self._stop.wait(max(0.0, next_poll - monotonic()))

    def _subscription_loop(self) -> None:
        while not self._stop.is_set():
            try:
                if self._subscription is None or not self.client.subscription_exists(self._subscription):
                    if self._subscriptions:  # it existed: Orion lost it, and maybe our entities with it
                        self.outbox.resend_all()
                        self._flush.set()
                    self._subscription = self.client.subscribe(self._subscription_body())
                    self._subscriptions.add(self._subscription)
                    log.info("subscribed to Orion: %s", self._subscription)
                    self._read_all(raise_errors=True)  # whatever was written before (or while) it existed
                self.inbound.ok("subscription in place")
            except OrionError as exc:
                self.inbound.failed(str(exc))
                self._subscription = None
                self._stop.wait(self.options.backoff_start)
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

    def _read_all(self, raise_errors: bool = False) -> None:
        try:
            entities = self.client.entities(self.options.entity_type, list(self.options.robots), INBOUND)
            self.requests += 1
        except OrionError as exc:
            if raise_errors:
                raise
            self.inbound.failed(str(exc))
            return
        if not self.options.notify_url:
            self.inbound.ok()
        if len(entities) < len(self.options.robots) and monotonic() - self._resent > 1.0:
            self._resent = monotonic()  # some robot entity is gone (Orion restarted or someone deleted it)
            self.outbox.resend_all()
            self._flush.set()
        self._forward(entities, monotonic())

    def _on_notification(self, subscription: str, data: list[dict[str, Any]]) -> None:
        if subscription not in self._subscriptions:
            log.info("notification for unknown subscription %s ignored", subscription)
            return
        self._forward(data, monotonic())

    def _forward(self, entities: list[dict[str, Any]], arrived: float) -> None:
        env, deliver = self._env, self._deliver
        assert env is not None and deliver is not None
        for entity in entities:
            robot = entity.get("id")
            for attribute in INBOUND:
                if attribute not in entity:
                    continue
                value = entity[attribute]
                with self._last_lock:
                    if self._last.get((robot, attribute)) == value:
                        continue
                    self._last[(robot, attribute)] = value
                inbound = Inbound(str(robot), attribute, raw=value)
                env.call_soon(lambda inbound=inbound: self._enter(inbound, arrived))

    def _enter(self, inbound: Inbound, arrived: float) -> None:
        assert self._deliver is not None
        self.latencies.append(monotonic() - arrived)
        if len(self.latencies) > 100_000:
            del self.latencies[:50_000]
        self._deliver(inbound)


def _entities(robots: tuple[str, ...], pending: dict[str, dict[str, Message]], frame: Frame | None):  # type: ignore[no-untyped-def]
    """``(robot, {attribute: message})`` in fleet order, attributes in a fixed order."""
    motions = {}
    if frame is not None:
        stamp = Time.from_seconds(frame.t)
        for robot, (x, y, theta, v, w) in zip(frame.robots, frame.columns.tolist()):
            motions[robot] = motion_message(stamp, x, y, theta, v, w)
    for robot in robots:
        attrs: dict[str, Message] = {}
        if robot in motions:
            attrs["current_motion"] = motions[robot]
        extra = pending.get(robot, {})
        for name in ATTRIBUTE_ORDER[1:]:
            if name in extra:
                attrs[name] = extra[name]
        if attrs:
            yield robot, attrs


def motion_message(stamp: Time, x: float, y: float, theta: float, v: float, w: float) -> Motion:
    """``current_motion`` of one robot: pose in the map frame and body velocities (SPEC §2)."""
    return Motion(
        PoseStamped(Header(0, stamp, "/map"), Pose(Point(x, y, 0.0), Quaternion.from_yaw(theta))),
        Twist(Vector3(v, 0.0, 0.0), Vector3(0.0, 0.0, w)),
    )


def wait_until(predicate: Callable[[], bool], timeout: float, step: float = 0.02) -> bool:
    """Poll ``predicate`` until true or ``timeout`` wall seconds passed (tests and the CLI use it)."""
    end = monotonic() + timeout
    while monotonic() < end:
        if predicate():
            return True
        time.sleep(step)
    return predicate()
