"""The one Orion link (docs/contract.md §7; docs/live.md): what either side of live mode keeps with Orion.

``vcran live`` (the fleet's side, :class:`transports.orion.transport.OrionTransport`) and ``vcran manage``
(the fleet manager's side, :class:`transports.orion.manage.OrionManagerLink`) are each an
:class:`OrionLink`, and differ only in what they read, what they subscribe to, and where what they read
goes. So both have every guarantee of docs/contract.md §7:

* **outbound**: writes go into an :class:`~transports.orion.outbox.Outbox`, which the
  :class:`~transports.orion.sender.Sender` (a thread of its own) sends as batch updates: coalesced, every
  queued value in order, backing off on 4xx and 5xx, never flooding Orion;
* **inbound by subscription** (a notification URL): the keeper thread holds the link's
  :class:`Subscription`\\ s, looks at each every ``keepalive`` seconds and re-creates one Orion lost (a
  restart, someone deleted it), and reads the entities after each (re)subscription and after each
  notification Orion reports it failed to deliver (the subscription's ``lastFailure``/``failsCounter``),
  so nothing Orion still holds is lost; notifications arrive on the
  :class:`~transports.orion.listener.Listener`. **By polling** otherwise: one read of the fleet every
  ``poll_interval`` simulated seconds (:func:`transports.orion.workers.poll`);
* **what comes in** (a notification or a read) is handed on (:meth:`OrionLink._hand_on`) as changes: a
  value identical to the last one handed on for that entity and attribute is not handed on again, unless
  it comes from a subscription whose notifications are writes (``robot_description``, written with
  forcedUpdate). A read hands on an entity only where a subscription on the link's condition would have
  notified it (an entity new to the link, or one of its condition values changed), and never a value
  older than one a notification handed on while the read was in flight;
* **health**: each direction logs a fault once per distinct cause and once when Orion is back
  (:class:`~transports.orion.health.Health`); :meth:`OrionLink.status` is the one-line summary.
"""

from __future__ import annotations

import logging
import threading
from dataclasses import dataclass
from functools import partial
from time import monotonic
from typing import Any
from urllib.parse import urlsplit

from transports.orion.client import OrionClient, OrionError
from transports.orion.health import Backoff, Health
from transports.orion.listener import Listener
from transports.orion.outbox import Outbox
from transports.orion.sender import Sender
from transports.orion.workers import poll, resilient
from vcran.io.http_server import one_line

log = logging.getLogger("vcran.orion")

#: What a link hands on: (entity id, attribute, the NGSI value as Orion gave it).
Change = tuple[str, str, Any]
_NONE = object()  # no value
_NO_FAILURE = (None, None, None)


@dataclass(frozen=True)
class LinkOptions:
    entity_type: str
    robots: tuple[str, ...] = ()
    #: Where Orion should POST notifications; None means polling.
    notify_url: str | None = None
    #: Address the listener binds to; default 127.0.0.1 and the notify URL's port.
    listen_host: str = "127.0.0.1"
    #: Polling period in simulated seconds (scaled by the speed factor like everything else).
    poll_interval: float = 0.25
    #: How often (wall seconds) the subscriptions are checked and re-created if Orion lost them.
    keepalive: float = 2.0
    max_notification: int = 1_048_576
    backoff_start: float = 0.25
    backoff_cap: float = 5.0


@dataclass(frozen=True)
class Subscription:
    """A subscription the link keeps: notify ``attrs`` when one of ``condition`` changes (empty: any, as
    Orion reads it). ``writes``: each notification is a write to hand on, unchanged values too (what
    Orion's forcedUpdate wrote)."""

    description: str
    condition: tuple[str, ...]
    attrs: tuple[str, ...]
    writes: bool = False


class OrionLink:
    """One side's link to Orion. ``attributes``: what it reads; ``subscriptions``: the first one's
    condition is also what a read compares (what that subscription would have notified)."""

    def __init__(self, client: OrionClient, options: LinkOptions, attributes: tuple[str, ...],
                 subscriptions: tuple[Subscription, ...], *, outbound: str = "outbound", inbound: str = "inbound",
                 queued: str = "ran_error") -> None:
        self.client, self.options = client, options
        self.attributes, self.subscriptions = attributes, subscriptions
        self.outbox = Outbox()
        self.sender = Sender(client, self.outbox, options.entity_type, options.robots,
                             Backoff(options.backoff_start, options.backoff_cap), Health(outbound), queued)
        self.outbound = self.sender.health
        self.inbound = Health(inbound)
        self.listener: Listener | None = None
        #: Reads of the entities Orion answered; notifications taken.
        self.reads = self.notifications = 0
        self._robots = frozenset(options.robots)
        self._condition = subscriptions[0].condition or attributes
        self._lock = threading.Lock()  # what was handed on, and its order
        self._last: dict[tuple[str, str], Any] = {}
        #: How many values of (robot, attribute) were handed on: lets a read skip what a notification
        #: delivered while the read was in flight.
        self._handed: dict[tuple[str, str], int] = {}
        self._known: set[str] = set()  # the robots whose entity the last read found
        self._sids: list[str | None] = [None] * len(subscriptions)  # each subscription's id in Orion
        self._ours: dict[str, Subscription] = {}  # every subscription in place, by id
        self._failures: dict[str, tuple[Any, Any, Any]] = {}
        self._unread = True  # the entities must be read after each (re)subscription
        self._resent = 0.0
        self._stop = threading.Event()
        self._threads: list[threading.Thread] = []

    @property
    def updates(self) -> int:
        """Batch updates Orion accepted."""
        return self.sender.counts.accepted

    @property
    def requests(self) -> int:
        """Requests Orion answered with success: reads and accepted updates."""
        return self.reads + self.updates

    # --- lifecycle ------------------------------------------------------------------------------------------

    def open(self) -> None:
        """Bind the notification listener (if any) now, so that a busy port fails before the run starts."""
        if self.options.notify_url and self.listener is None:
            parts = urlsplit(self.options.notify_url)
            self.listener = Listener(self.options.listen_host, parts.port or 80, parts.path or "/",
                                     self._on_notification, self.options.max_notification)

    def start(self, speed: float, *, strict: bool = False) -> None:
        """Listen, and start the sender and the inbound thread (``speed``: simulated seconds per wall
        second). ``strict``: subscribe and read (or read, polling) here first, and raise OSError (the
        listener's port) or OrionError (Orion unreachable or refusing) with nothing left running."""
        self.open()
        first = 0.0
        if strict:
            try:
                self._look() if self.options.notify_url else self._read()
            except BaseException:
                self.close()
                raise
            first = self.options.keepalive
        if self.options.notify_url:
            inbound = partial(self._keep, first)
        else:
            period = self.options.poll_interval / speed
            inbound = partial(poll, self._read, period, self.inbound, self._stop, self.options.backoff_start,
                              self.options.backoff_cap, on_back=self.sender.wake, first=period if strict else 0.0)
        for name, target in (("vcran-sender", partial(self.sender.loop, self._stop)), ("vcran-inbound", inbound)):
            thread = threading.Thread(target=resilient(name, target, self._stop), name=name, daemon=True)
            thread.start()
            self._threads.append(thread)

    def close(self) -> None:
        """Stop the threads, make a last delivery attempt, stop listening, delete the subscriptions."""
        self._stop.set()
        self.sender.release()
        for thread in self._threads:
            thread.join(timeout=10)
        self._threads = []
        try:
            self.sender.finish()
        except Exception:  # noqa: BLE001 - closing must finish
            log.exception("final delivery failed")
        if self.listener is not None:
            self.listener.stop()
            self.listener = None
        for sid in sorted(self._ours):
            try:
                self.client.unsubscribe(sid)
            except OrionError as exc:
                log.warning("could not delete subscription %s: %s", sid, exc)
        self._ours.clear()
        self.client.close()

    def status(self) -> str:
        """One-line health for the live status display."""
        mode = "subscription" if self.options.notify_url else "polling"
        c = self.sender.counts
        queued = f", {self.sender.noun}s {c.delivered} delivered" if c.delivered or c.undeliverable else ""
        if c.undeliverable:
            queued += f", {c.undeliverable} undeliverable"
        return (f"Orion out {self.outbound.describe()}, in ({mode}) {self.inbound.describe()}, "
                f"{c.accepted}/{c.attempts} updates accepted, {self.reads} reads{queued}")

    def _hand_on(self, changes: list[Change], arrived: float) -> None:
        """Where what comes in goes (called in arrival order, under the link's lock); ``arrived``: monotonic."""
        raise NotImplementedError

    # --- inbound ----------------------------------------------------------------------------------------------

    def _keep(self, first: float) -> None:
        """The keeper: a look every ``keepalive`` seconds; a failed one is retried with backoff."""
        backoff = Backoff(self.options.backoff_start, self.options.backoff_cap)
        delay = first
        while not self._stop.wait(delay):
            try:
                self._look()
            except OrionError as exc:  # keep the ids: only Orion saying 404 makes one stale
                self.inbound.failed(f"{exc}; retrying with backoff")
                delay = backoff.next(exc.retry_after)
                continue
            backoff.reset()
            delay = self.options.keepalive
            if self.inbound.ok("subscription in place"):
                self.sender.wake()  # the sender may be deep in its backoff: Orion is back now

    def _look(self) -> None:
        """Every subscription in place (re-created if Orion lost it), the entities read if something may
        have been missed; raises OrionError."""
        for k, spec in enumerate(self.subscriptions):
            sid = self._sids[k]
            if sid is not None:
                shown = self.client.subscription(sid)
                if shown is None:
                    # Orion lost it (restart, or someone deleted it), and maybe our entities with it.
                    log.warning("subscription %s is gone from Orion; re-creating it", one_line(sid, 60))
                    del self._ours[sid], self._failures[sid]
                    sid = self._sids[k] = None
                    self.sender.wake()
                elif (seen := _failures(shown)) != self._failures[sid]:
                    # Orion could not deliver some notification (a burst, a slow moment): what it
                    # carried is only in Orion now, so read it (docs/contract.md §7: no loss window).
                    if seen[0] is not None:
                        log.warning("Orion reports a failed notification (%s, %s failing): reading "
                                    "the entities again", one_line(seen[0], 40), one_line(seen[1], 20))
                        self._unread = True
                    self._failures[sid] = seen
            if sid is None:
                sid = self._sids[k] = self.client.subscribe(self._body(spec))
                self._ours[sid], self._failures[sid] = spec, _NO_FAILURE
                self._unread = True
                log.info("subscribed to Orion: %s", sid)
        if self._unread:
            self._read()
            self._unread = False

    def _body(self, spec: Subscription) -> dict[str, Any]:
        return {
            "description": spec.description,
            "subject": {
                "entities": [{"id": robot, "type": self.options.entity_type} for robot in self.options.robots],
                "condition": {"attrs": list(spec.condition)},
            },
            "notification": {"http": {"url": self.options.notify_url}, "attrs": list(spec.attrs),
                             "attrsFormat": "normalized"},
        }

    def _read(self) -> None:
        """Read the fleet's entities once; raises OrionError."""
        with self._lock:
            since = dict(self._handed)
        entities = self.client.entities(self.options.entity_type, list(self.options.robots), self.attributes)
        self.reads += 1
        if len(entities) < len(self.options.robots) and self.outbox.restorable and monotonic() - self._resent > 1.0:
            self._resent = monotonic()  # some robot entity we published is gone (Orion restarted, or a delete)
            self.sender.wake()
        self._take(entities, monotonic(), since=since)

    def _on_notification(self, sid: str, data: list[dict[str, Any]]) -> None:
        spec = self._ours.get(sid)
        if spec is None:
            log.info("notification for unknown subscription %s ignored", one_line(sid, 60))
            return
        self.notifications += 1
        self._take(data, monotonic(), writes=spec.writes)

    def _take(self, entities: list[dict[str, Any]], arrived: float, *,
              since: dict[tuple[str, str], int] | None = None, writes: bool = False) -> None:
        """Hand on what changed, in order. ``since``: this is a read, and this the snapshot of the counts
        handed on when it began."""
        with self._lock:  # one order for reads and notifications
            changes: list[Change] = []
            found: set[str] = set()
            for entity in entities:
                robot = entity.get("id")
                if not isinstance(robot, str) or robot not in self._robots:  # a list id is unhashable
                    continue
                if since is not None:  # what a subscription would have notified: new, or a condition changed
                    found.add(robot)
                    if robot in self._known and all(entity.get(a, _NONE) == self._last.get((robot, a), _NONE)
                                                    for a in self._condition):
                        continue
                for attribute in self.attributes:
                    key, value = (robot, attribute), entity.get(attribute, _NONE)
                    if value is _NONE or (since is not None and self._handed.get(key, 0) != since.get(key, 0)):
                        continue  # a notification handed on a newer value while the read was in flight
                    if not writes and self._last.get(key, _NONE) == value:
                        continue  # a re-read, which R10 ignores anyway
                    self._last[key] = value
                    self._handed[key] = self._handed.get(key, 0) + 1
                    changes.append((robot, attribute, value))
            if since is not None:
                self._known = found  # an entity Orion no longer holds is new when it is back
            if changes:
                self._hand_on(changes, arrived)


def _failures(subscription: dict[str, Any]) -> tuple[Any, Any, Any]:
    """What changes when Orion fails to deliver a notification: ``lastFailure`` and ``failsCounter``, and
    ``timesSent`` while failures are counted. Orion gives delivery times in whole seconds and resets
    ``failsCounter`` at a success, so a failure, a success and a failure within one second between two
    looks leave the first two as they were; the notifications sent meanwhile do not."""
    notification = subscription.get("notification")
    if not isinstance(notification, dict):
        return _NO_FAILURE
    failing = notification.get("failsCounter")
    return notification.get("lastFailure"), failing, notification.get("timesSent") if failing else None
