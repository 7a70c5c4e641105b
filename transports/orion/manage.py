"""A fleet manager against a real Orion, in real time (SPEC §9, "The same fleet manager, live").

``vcran manage`` runs the very :class:`~vcran.core.opil.manager.FleetManager` object that
:func:`vcran.simulate` runs, with the same handle API: :class:`OrionLoop` is
:class:`vcran.sim.opil.loop.ClosedLoop` on a :class:`~vcran.sim.live.LiveEnvironment` (so ``now``, jobs and
``call_at`` timers follow the wall clock, scaled by the speed factor), with :class:`OrionLink` in place of
the simulated link:

* **writes** (the manager's assignments and cancels) go to Orion as batch updates
  (``POST /v2/op/update``), from a sender thread, so a hook never waits on HTTP. Whatever the manager
  wrote while the previous request was in flight goes out together, in write order. One entity carries
  one value per attribute, and the RAN reads an entity's attributes in a fixed order (motion, action,
  cancel), so a write that could not keep its order inside the current round starts the next one;
* **updates** come from one Orion subscription to the robots' published attributes (with a notification
  URL), or from polling them. The subscription's condition is the manager's
  :attr:`~vcran.core.opil.manager.FleetManager.attributes`; every notification carries all of them, so
  ``handle.latest`` and ``handle.pose`` are as fresh as the robot's last notified change. The entities
  are read once after subscribing (what Orion already holds reaches the manager first). Notifications
  arrive on the :class:`~transports.orion.listener.Listener`. ``robot_description`` (the attributes of
  :data:`~vcran.core.messages.FORCED_UPDATES`) has a subscription of its own: ``vcran live`` writes it
  every period with Orion's forcedUpdate, unchanged, and a notification of the whole entity cannot tell
  such a write from a description that merely rides along; this subscription's notifications can, so the
  manager is told of each periodic write, as in simulated time (SPEC §2, §9). Elsewhere (the first read,
  the other notifications, polling) a description reaches it only when it differs from the last one.
  Polling (``GET /v2/entities`` every ``poll_interval`` simulated seconds, for a manager Orion cannot
  reach) tells the manager what that subscription would: everything at the first read, then a robot's
  attributes, all of them, when one of its condition attributes changed since the previous read (the
  NGSI values compared as Orion gave them). A value that changes and changes back between two reads is
  missed, as polling misses it in ``vcran live`` (docs/live.md).
  Either way a batch enters the manager's thread through :meth:`LiveEnvironment.call_soon`: every hook
  runs in one thread, as in simulated time.

Orion being down is handled like live mode does: a failed write is kept and retried with capped backoff
(logged once per fault); a refused one (4xx) is dropped and logged. A failed poll is logged once per
fault and retried with the backoff of ``vcran live``'s polling (:func:`transports.orion.workers.poll`).
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from typing import Any
from urllib.parse import urlsplit

import simpy

from transports.orion.client import OrionClient, OrionError, OrionRejected
from transports.orion.health import Health
from transports.orion.listener import Listener
from transports.orion.workers import poll, resilient
from vcran.core.codec import CodecError, decode_attribute, encode_attribute, split_batch
from vcran.core.jobs import Log
from vcran.core.messages import FORCED_UPDATES, INBOUND, OUTBOUND, Message, RanStatus
from vcran.core.opil.manager import FleetManager
from vcran.core.scenario import Scenario
from vcran.core.wire import Deliver, Outbound, Publish
from vcran.sim.live import LiveEnvironment
from vcran.sim.loop import ManagerLink
from vcran.sim.opil.loop import ClosedLoop

log = logging.getLogger("vcran.orion")

_ORDER = {name: k for k, name in enumerate(INBOUND)}  # the order in which the RAN reads an entity's attributes
_NONE = object()  # no value seen yet


@dataclass(frozen=True)
class ManageOptions:
    entity_type: str
    #: Where Orion POSTs the manager's notifications (vcran listens there); None means polling.
    notify_url: str | None = None
    listen_host: str = "127.0.0.1"
    #: Polling period in simulated seconds (scaled by the speed factor like everything else).
    poll_interval: float = 0.25
    max_notification: int = 1_048_576
    backoff_start: float = 0.25
    backoff_cap: float = 5.0


class OrionLink(ManagerLink):
    """The manager's side of Orion: batched writes out, subscription notifications or polled reads in."""

    def __init__(self, env: LiveEnvironment, client: OrionClient, robots: tuple[str, ...], options: ManageOptions,
                 attributes: frozenset[str] | None, notify: Callable[[list[Outbound]], None]) -> None:
        self.env, self.client, self.robots, self.options = env, client, robots, options
        self._condition = [a for a in OUTBOUND if attributes is None or a in attributes]
        self._notify = notify
        self._robots = frozenset(robots)
        self._lock = threading.Lock()
        self._pending: list[tuple[str, str, Any]] = []  # (robot, attribute, NGSI value) in write order
        self._sending = 0                                # writes taken by the sender, not yet delivered
        self._wake = threading.Event()
        self._stop = threading.Event()
        self.outbound = Health("manager writes")
        self.inbound = Health("manager subscription" if options.notify_url is not None else "manager polling")
        #: Notifications taken (subscription); reads of the entities Orion answered (either way).
        self.writes = self.requests = self.notifications = self.reads = 0
        #: Polling: each robot's condition values at the last read, to tell a change.
        self._seen: dict[str, tuple[Any, ...]] = {}
        #: The forced attributes wanted (robot_description), and their last NGSI values handed on.
        self._forced = [a for a in FORCED_UPDATES if attributes is None or a in attributes]
        self._forced_seen: dict[tuple[str, str], Any] = {}
        self._subscription: str | None = None
        self._forced_subscription: str | None = None
        self._listener: Listener | None = None
        self._sender: threading.Thread | None = None
        self._poller: threading.Thread | None = None

    # --- lifecycle -------------------------------------------------------------------------------------

    def open(self) -> None:
        """Listen for notifications and subscribe (or not, when polling), read what Orion holds; then
        start the sender (and the poller). Raises OSError (the listener's port) or OrionError (Orion
        unreachable or refusing) before any hook runs."""
        notify_url = self.options.notify_url
        if notify_url is not None:
            parts = urlsplit(notify_url)
            self._listener = Listener(self.options.listen_host, parts.port or 80, parts.path or "/",
                                      self._on_notification, self.options.max_notification)
        try:
            if notify_url is not None:
                self._subscription = self.client.subscribe(self._subscription_body())
                if self._forced:
                    self._forced_subscription = self.client.subscribe(self._subscription_body(forced=True))
            entities = self._read()
        except BaseException:
            self.close()
            raise
        self._forward(entities if notify_url is not None else self._changed(entities))
        self._sender = threading.Thread(target=self._send_loop, name="vcran-manager-sender", daemon=True)
        self._sender.start()
        if notify_url is None:
            period = self.options.poll_interval / self.env.speed
            loop = partial(poll, self._poll, period, self.inbound, self._stop, self.options.backoff_start,
                           self.options.backoff_cap, first=period)  # the first read is done
            self._poller = threading.Thread(target=resilient("vcran-manager-poller", loop, self._stop),
                                            name="vcran-manager-poller", daemon=True)
            self._poller.start()

    def close(self) -> None:
        """Stop polling, deliver what is still pending (one last try), stop listening, delete the
        subscription."""
        self._stop.set()
        self._wake.set()
        if self._poller is not None:
            self._poller.join(timeout=10)
            self._poller = None
        if self._sender is not None:
            self._sender.join(timeout=10)
            self._sender = None
        if self._pending:
            self._deliver()
        if self._listener is not None:
            self._listener.stop()
            self._listener = None
        for sid in (self._subscription, self._forced_subscription):
            if sid is None:
                continue
            try:
                self.client.unsubscribe(sid)
            except OrionError as exc:
                log.warning("could not delete subscription %s: %s", sid, exc)
        self._subscription = self._forced_subscription = None

    # --- ManagerLink --------------------------------------------------------------------------------------

    def write(self, robot: str, attribute: str, message: Message | None, raw: Any = None) -> None:
        value = encode_attribute(attribute, message) if message is not None else raw
        with self._lock:
            self._pending.append((robot, attribute, value))
        self._wake.set()

    @property
    def inbound_idle(self) -> bool:
        """Everything the manager wrote has reached Orion (or been refused by it)."""
        with self._lock:
            return not self._pending and self._sending == 0

    @property
    def outbound_idle(self) -> bool:
        return True  # what the robots publish is theirs to send; nothing of it is held here

    # --- writes -------------------------------------------------------------------------------------------

    def _send_loop(self) -> None:
        backoff = self.options.backoff_start
        while not self._stop.is_set():
            self._wake.wait()
            self._wake.clear()
            if self._stop.is_set():
                return
            if self._deliver():
                backoff = self.options.backoff_start
            else:
                self._stop.wait(backoff)
                backoff = min(backoff * 2, self.options.backoff_cap)
                self._wake.set()

    def _deliver(self) -> bool:
        """Send every pending write, in rounds; False when Orion could not take them (they stay pending)."""
        with self._lock:
            writes, self._pending = self._pending, []
            self._sending = len(writes)
        try:
            for body in self._bodies(writes):
                self.client.update(body)
                self.requests += 1
        except OrionRejected as exc:  # sending it again will not help: drop, say so, carry on
            self.outbound.failed(f"Orion refused the manager's writes, dropped: {exc}")
        except OrionError as exc:
            with self._lock:
                self._pending[:0] = writes  # older than anything written meanwhile
                self._sending = 0
            self.outbound.failed(str(exc))
            return False
        else:
            self.writes += len(writes)
            self.outbound.ok()
        with self._lock:
            self._sending = 0
        return True

    def _bodies(self, writes: list[tuple[str, str, Any]]) -> list[bytes]:
        """Batch-update bodies: rounds of entities in which every write keeps its order."""
        rounds: list[dict[str, dict[str, Any]]] = [{}]
        for robot, attribute, value in writes:
            entity = rounds[-1].get(robot)
            if entity is not None and (attribute in entity or
                                       any(_ORDER[a] > _ORDER[attribute] for a in entity if a in _ORDER)):
                rounds.append({})
                entity = None
            if entity is None:
                entity = rounds[-1][robot] = {"id": robot, "type": self.options.entity_type}
            entity[attribute] = value
        return [body for entities in rounds if entities for body in split_batch(entities.values())]

    # --- updates --------------------------------------------------------------------------------------------

    def _subscription_body(self, forced: bool = False) -> dict[str, Any]:
        """The manager's subscription, or (``forced``) the one to the forced attributes alone."""
        what, condition, attrs = (("robot descriptions, each periodic write", self._forced, self._forced) if forced
                                  else ("robot updates", self._condition, list(OUTBOUND)))
        return {
            "description": f"vcran manage: {what} for the fleet manager",
            "subject": {
                "entities": [{"id": robot, "type": self.options.entity_type} for robot in self.robots],
                "condition": {"attrs": condition},
            },
            "notification": {"http": {"url": self.options.notify_url}, "attrs": attrs, "attrsFormat": "normalized"},
        }

    def _read(self) -> list[dict[str, Any]]:
        """The robots' published attributes as Orion holds them; raises OrionError."""
        entities = self.client.entities(self.options.entity_type, list(self.robots), OUTBOUND)
        self.reads += 1
        return entities

    def _poll(self) -> None:
        self._forward(self._changed(self._read()))

    def _changed(self, entities: list[dict[str, Any]]) -> list[dict[str, Any]]:
        """The fleet's entities that a subscription on the manager's condition would have notified since
        the last read: every one the first time, then those of which a condition value changed (any
        published value, for an empty condition: Orion's "any attribute"). An entity Orion no longer
        holds is forgotten, so that it counts as changed when it is back (Orion notifies a creation)."""
        seen, self._seen = self._seen, {}
        changed = []
        for entity in entities:
            robot = entity.get("id")
            if not isinstance(robot, str) or robot not in self._robots:  # a list id is unhashable
                continue
            values = tuple(entity.get(attribute) for attribute in self._condition or OUTBOUND)
            self._seen[robot] = values
            if seen.get(robot) != values:
                changed.append(entity)
        return changed

    def _on_notification(self, subscription: str, data: list[dict[str, Any]]) -> None:
        written = subscription is not None and subscription == self._forced_subscription
        if not written and subscription != self._subscription:
            log.info("notification for unknown subscription %s ignored", subscription)
            return
        self.notifications += 1
        self._forward(data, written=written)

    def _forward(self, entities: list[dict[str, Any]], written: bool = False) -> None:
        """Decode the robots' attributes and hand them to the manager's thread as one batch. A forced
        attribute goes only when ``written`` (a notification of its own subscription: a write of it) or
        when it differs from the last one handed on; the manager's loop takes each one as a write."""
        batch: list[Outbound] = []
        for entity in entities:
            robot = entity.get("id")
            if not isinstance(robot, str) or robot not in self._robots:  # a list id is unhashable
                continue
            for attribute in OUTBOUND:
                if attribute not in entity:
                    continue
                if attribute in FORCED_UPDATES:
                    value, key = entity[attribute], (robot, attribute)
                    if not written and self._forced_seen.get(key, _NONE) == value:
                        continue
                    self._forced_seen[key] = value
                try:
                    message = decode_attribute(attribute, entity[attribute])
                except CodecError as exc:
                    log.warning("%s of %s does not decode, ignored: %s", attribute, robot, exc)
                    continue
                batch.append(Publish(0.0, robot, attribute, message))
        if batch:
            self.env.call_soon(lambda: self._notify(batch))


class OrionLoop(ClosedLoop):
    """:class:`ClosedLoop` whose link is a real Orion: the manager's side of ``vcran manage``.

    Besides the ``job_*`` events, ``log`` gets what the manager heard of the robots through Orion, from
    each robot's ``ran_status`` (issue 29 item 12: ``vcran report`` draws the fleet figure from them): a
    ``state`` event when its RanLogic state changed, ``task_completed`` and ``task_cancelled`` (with the
    reason) for each task newly in its lists, at the instant the notification (or read) reached the
    manager, before the manager's hooks see it. The first status heard of a robot is the baseline: tasks
    that ended before ``manage`` started are not logged as ending then."""

    def __init__(self, scenario: Scenario, manager: FleetManager, log: Log, client: OrionClient,
                 options: ManageOptions) -> None:
        super().__init__(scenario, manager, log)
        self.client, self.options = client, options
        self._log = log
        self._heard: dict[str, RanStatus] = {}

    def notified(self, batch: list[Outbound]) -> None:
        assert self.handle is not None
        for out in batch:
            if isinstance(out, Publish) and out.attribute == "ran_status" and isinstance(out.message, RanStatus):
                self._hear(self.handle.now, out.robot, out.message)
        super().notified(batch)

    def _hear(self, t: float, robot: str, status: RanStatus) -> None:
        before = self._heard.get(robot)
        self._heard[robot] = status
        state = before.state if before is not None else "WAITING"  # every robot starts WAITING (R1)
        if status.state != state:
            self._log(t, robot, "state", {"from": state, "to": status.state})
        if before is None:
            return
        done = set(before.completed)
        for task in status.completed:
            if task not in done:
                self._log(t, robot, "task_completed", {"task": task.label})
        ended = {end.task_id for end in before.cancelled}
        for end in status.cancelled:
            if end.task_id not in ended:
                self._log(t, robot, "task_cancelled", {"task": end.task_id.label, "reason": end.reason})

    def make_link(self, env: simpy.Environment, deliver: Deliver) -> OrionLink:
        assert isinstance(env, LiveEnvironment)
        link = OrionLink(env, self.client, self.fleet.robot_ids, self.options, self.manager.attributes, self.notified)
        link.open()
        return link
