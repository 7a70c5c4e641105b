"""The outbound side of the link: what the outbox holds, to Orion, as batch updates (docs/contract.md §7).

The sender takes the :class:`Outbox` when it is told to (a telemetry tick of the fleet; a fleet manager's
write) and writes it with ``POST /v2/op/update``, in one request (more only when a body would pass Orion's
1 MB limit). Each robot's values go in its entity elements in write order, and an element holds one value
per attribute in the order the reading side takes an entity's attributes (:data:`ORDER`: the RAN reads
motion, action, cancel; a fleet manager's handle sees ``current_motion`` before the rest). A value that
cannot keep that order in a robot's current element starts the robot's next one, after every robot's
current one. Orion applies the elements of a batch one after the other, as separate updates of the entity,
so every queued value (each ``ran_error``; each command a fleet manager writes) is delivered, in order, in
the one request: the fleet's tick is one element per robot (its ``current_motion``, its changed state and
its oldest waiting ``ran_error``), then one element per further ``ran_error``; a task of several motions
is several elements of its robot.

``robot_description`` (:data:`~vcran.core.opil.messages.FORCED_UPDATES`) goes in a request of its own, after
the tick's, with ``options=forcedUpdate``: its value never changes, and Orion notifies only changes, so
without the option a planner that subscribed after the first write would never get it (docs/contract.md §2). The
option forces every attribute of its request, hence the separate request: nothing else is notified
unchanged. It costs one more request per ``description_period`` (every robot's description in it).

When a request fails the sender stops there, gives back what Orion did not take and waits before the
next attempt (ticks and writes meanwhile are coalesced into the outbox, so nothing queues up but the
latest state and the queued values):

* Orion unreachable, too slow, 5xx, or 429: nothing is lost; the delay doubles from ``backoff_start`` to
  ``backoff_cap`` and is never shorter than a ``Retry-After`` (at most 60 s);
* any other 4xx refuses the request, not an outage. 400, 413 and 422 refuse its content: the state values
  of the refused body are dropped (the next tick carries fresh ones) and its queued values are retried
  once more, then reported undeliverable; any other 4xx (401 expired token, 403, 404 unknown tenant)
  says nothing about the content, so everything is kept, and retried with the same backoff. Either way
  each distinct cause is logged once, and nothing is resent in a loop.

The inbound side calls :meth:`Sender.wake` when it sees Orion back or missing our entities: the sender
then retries at once, with every robot's latest state, instead of sleeping through its backoff.
"""

from __future__ import annotations

import logging
import threading
from dataclasses import dataclass, field
from time import monotonic

from transports.orion.client import OrionClient, OrionError, OrionRejected
from transports.orion.health import Backoff, Health
from transports.orion.outbox import Batch, Outbox, Queued, Value
from vcran.core.opil.build import motion_message
from vcran.core.opil.messages import FORCED_UPDATES, INBOUND, Time
from vcran.core.wire import Frame

log = logging.getLogger("vcran.orion")

#: The order of the fleet's state in an entity (every attribute the RAN publishes: battery too, docs/contract.md §4;
#: a fleet manager reads it from Orion, docs/contract.md §9), then the queued values.
STATE_ORDER = ("current_motion", "assignment_state", "ran_status", "robot_description", "battery_state")
ORDER = {name: k for k, name in enumerate((*STATE_ORDER, "ran_error", *INBOUND))}
#: Orion's answers that refuse a request's content (NGSI v2 BadRequest, RequestEntityTooLarge,
#: Unprocessable): sending the same content again cannot help.
CONTENT_REFUSALS = frozenset({400, 413, 422})
#: A queued value in this many content refusals is reported undeliverable instead of being sent again.
MAX_REFUSALS = 2


@dataclass
class Counts:
    """What the sender did: requests tried and taken, and the fate of every queued value."""

    attempts: int = 0
    accepted: int = 0
    refused: int = 0  # a 4xx
    failed: int = 0  # unreachable, timeout, 5xx
    delivered: int = 0
    undeliverable: int = 0


@dataclass(eq=False)
class Element:
    """One entity element of a batch update and what it carries: ``state`` (the fleet's, without
    current_motion, which comes from the frame) goes back to the outbox if Orion does not take it, and so
    do the ``queued`` values."""

    robot: str
    attrs: dict[str, Value] = field(default_factory=dict)
    state: dict[str, Value] = field(default_factory=dict)
    queued: list[Queued] = field(default_factory=list)
    forced: bool = False  # written with options=forcedUpdate (FORCED_UPDATES), in a request of its own
    data: bytes = b""


class Sender:
    def __init__(self, client: OrionClient, outbox: Outbox, entity_type: str, robots: tuple[str, ...],
                 backoff: Backoff, health: Health | None = None, noun: str = "ran_error") -> None:
        self.client, self.outbox = client, outbox
        self.entity_type, self.robots = entity_type, robots
        self.backoff = backoff
        self.health = Health("outbound") if health is None else health
        self.noun = noun  # what the queued values are, in log lines
        self.counts = Counts()
        self._tick = threading.Event()
        self._wake = threading.Event()
        self._reported_drops = 0

    def tick(self) -> None:
        """Something to send: send what the outbox holds (unless backing off)."""
        self._tick.set()

    def wake(self) -> None:
        """Orion is back, or lost our entities: restore every robot's latest state, now."""
        self.outbox.resend_all()
        self._wake.set()
        self._tick.set()

    def loop(self, stop: threading.Event) -> None:
        retry_at: float | None = None
        while not stop.is_set():
            if retry_at is None:
                self._tick.wait()
            else:  # ticks do not cut a backoff short; a wake (or stop) does
                self._wake.wait(max(0.0, retry_at - monotonic()))
            self._tick.clear()
            self._wake.clear()
            if stop.is_set():
                return
            delay = self.deliver()
            retry_at = None if delay is None else monotonic() + delay

    def release(self) -> None:
        """Unblock :meth:`loop` (after setting its stop event)."""
        self._wake.set()
        self._tick.set()

    def finish(self) -> None:
        """A last attempt at closing; whatever queued value is still waiting is reported undeliverable."""
        if self.deliver() is not None:
            left = self.outbox.take().queued
            self.outbox.settle()
            if left:
                self.counts.undeliverable += len(left)
                log.warning("%s: %d %s(s) not delivered: %s", self.health.what, len(left), self.noun, self.health.fault)
        self._report_drops()

    def deliver(self) -> float | None:
        """Send what the outbox holds; None when Orion took all of it, else the seconds to wait before
        trying again (what it did not take is back in the outbox)."""
        from vcran.core.opil.codec import split_batch_counted

        batch = self.outbox.take()
        try:
            self._report_drops()
            if not batch:
                return None
            elements = [e for e in self._elements(batch) if self._encoded(e)]  # the tick's, then the forced
            frame = batch.frame
            done = 0
            for forced in (False, True):
                group = [e for e in elements if e.forced is forced]
                for body, count in split_batch_counted(e.data for e in group):
                    self.counts.attempts += 1
                    try:
                        self.client.update(body, forced=forced)
                    except OrionError as exc:
                        return self._failed(exc, frame, elements[done:done + count], elements[done + count:])
                    self.counts.accepted += 1
                    self.counts.delivered += sum(len(e.queued) for e in elements[done:done + count])
                    done += count
                frame = None  # delivered with the tick's request(s)
        finally:
            self.outbox.settle()
        self.backoff.reset()
        if self.health.ok("delivered the latest state"):
            self.wake()  # Orion may have come back empty: restore everything, not only the changes
        return None

    def _failed(self, exc: OrionError, frame: Frame | None, refused: list[Element], later: list[Element]) -> float:
        content = isinstance(exc, OrionRejected) and exc.status in CONTENT_REFUSALS
        back = Batch(frame=frame)
        lost: list[Queued] = []
        for element in refused if content else ():
            # State Orion refused as invalid is not sent again (the next tick has fresh state); its
            # queued values get one more chance, in case another element of the body was the invalid one.
            for item in element.queued:
                item.refusals += 1
                (lost if item.refusals >= MAX_REFUSALS else back.queued).append(item)
        for element in later if content else refused + later:
            if element.state:
                back.state.setdefault(element.robot, {}).update(element.state)
            back.queued += element.queued
        self.outbox.give_back(back)
        if isinstance(exc, OrionRejected):
            self.counts.refused += 1
            what = (f"its state values dropped, its {self.noun}s retried once" if content else
                    "everything kept") + ", retrying with backoff"
            self.health.failed(f"Orion refused a batch update ({exc}); {what}", f"{exc.status} {exc.error}")
        else:
            self.counts.failed += 1
            self.health.failed(f"{exc}; retrying with backoff")
        if lost:
            self.counts.undeliverable += len(lost)
            log.warning("%s: %d %s(s) refused %d times by Orion, not sent again: %s",
                        self.health.what, len(lost), self.noun, MAX_REFUSALS, exc)
        return self.backoff.next(exc.retry_after)

    def _report_drops(self) -> None:
        dropped = self.outbox.dropped
        if dropped > self._reported_drops:
            self.counts.undeliverable += dropped - self._reported_drops
            log.warning("%s: %d %s(s) dropped, more were waiting than the outbox keeps", self.health.what,
                        dropped - self._reported_drops, self.noun)
            self._reported_drops = dropped

    # --- encoding ---------------------------------------------------------------------------------------

    def _elements(self, batch: Batch) -> list[Element]:
        """The entity elements of a batch, in rounds (module docstring): every robot's state in fleet
        order, then the queued values in order; then the forced attributes (FORCED_UPDATES) of each robot,
        for a request of their own."""
        rounds: list[dict[str, Element]] = []
        current: dict[str, int] = {}  # each robot's current round

        def place(robot: str, attribute: str, value: Value) -> Element:
            k = current.get(robot, 0)
            while True:
                if k == len(rounds):
                    rounds.append({})
                element = rounds[k].setdefault(robot, Element(robot))
                if attribute not in element.attrs and all(ORDER[a] < ORDER[attribute] for a in element.attrs):
                    break
                k += 1
            current[robot] = k
            element.attrs[attribute] = value
            return element

        motions = {}
        if batch.frame is not None:
            stamp = Time.from_seconds(batch.frame.t)
            for robot, (x, y, theta, v, w) in zip(batch.frame.robots, batch.frame.columns.tolist(), strict=True):
                motions[robot] = motion_message(stamp, x, y, theta, v, w)
        forced: list[Element] = []
        for robot in self.robots:
            if robot in motions:
                place(robot, "current_motion", motions[robot])
            pending = batch.state.get(robot, {})
            for name in STATE_ORDER:
                if name not in pending:
                    continue
                if name in FORCED_UPDATES:
                    if not forced or forced[-1].robot != robot:
                        forced.append(Element(robot, forced=True))
                    element = forced[-1]
                    element.attrs[name] = pending[name]
                else:
                    element = place(robot, name, pending[name])
                element.state[name] = pending[name]
        for item in batch.queued:  # each robot's oldest first
            place(item.robot, item.attribute, item.value).queued.append(item)
        return [e for elements in rounds for e in elements.values()] + forced

    def _encoded(self, element: Element) -> bool:
        """Encode the element (``data``); an attribute that cannot be encoded is dropped with its queued
        value, which is counted undeliverable. False: nothing of it can be sent."""
        from vcran.core.opil.codec import CodecError, encode_attribute_json, encode_entity_json
        from vcran.core.orion_rules import MAX_REQUEST_BYTES

        attrs = element.attrs
        while attrs:
            try:
                head = encode_entity_json(element.robot, self.entity_type, {})[:-1]
                element.data = head + "".join(
                    f',"{name}":{value if isinstance(value, str) else encode_attribute_json(name, value)}'
                    for name, value in attrs.items()).encode() + b"}"
            except CodecError as exc:  # a bug, not Orion's fault: drop the attribute, keep the rest
                log.error("cannot encode %s of %s, dropped: %s", exc.attribute or "an attribute", element.robot, exc)
                attrs = {k: v for k, v in attrs.items() if k != exc.attribute} if exc.attribute in attrs else {}
                continue
            if len(element.data) > MAX_REQUEST_BYTES - 64:
                log.error("%s encodes to %d bytes, over Orion's request limit: not sent", element.robot, len(element.data))
                attrs = {}
            break
        sent = [item for item in element.queued if item.attribute in attrs]
        self.counts.undeliverable += len(element.queued) - len(sent)  # said above, not lost silently
        element.queued = sent
        element.state = {k: v for k, v in element.state.items() if k in attrs}
        return bool(attrs)
