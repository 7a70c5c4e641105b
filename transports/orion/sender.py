"""The outbound side of live mode: the fleet's changes to Orion, one batch update per tick (SPEC §7).

At every telemetry tick the sender takes the :class:`Outbox` and writes it with ``POST /v2/op/update``:
one entity element per robot (its ``current_motion`` and changed state, with its oldest waiting
``ran_error``), then one more element of the same entity per further ``ran_error`` of that tick. Orion
applies the elements of a batch one after the other, as separate updates of the entity, so every error is
delivered, in order, in the one request of the tick (more requests only when a body would pass Orion's
1 MB limit).

``robot_description`` (:data:`~vcran.core.messages.FORCED_UPDATES`) goes in a request of its own, after
the tick's, with ``options=forcedUpdate``: its value never changes, and Orion notifies only changes, so
without the option a planner that subscribed after the first write would never get it (SPEC §2). The
option forces every attribute of its request, hence the separate request: nothing else is notified
unchanged. It costs one more request per ``description_period`` (every robot's description in it).

When a request fails the sender stops there, gives back what Orion did not take and waits before the
next attempt (ticks meanwhile are coalesced into the outbox, so nothing queues up but the latest state
and the errors):

* Orion unreachable, too slow, 5xx, or 429: nothing is lost; the delay doubles from ``backoff_start`` to
  ``backoff_cap`` and is never shorter than a ``Retry-After`` (at most 60 s);
* any other 4xx refuses the request, not an outage. 400, 413 and 422 refuse its content: the state values
  of the refused body are dropped (the next tick carries fresh ones) and its ``ran_error``s are retried
  once more, then reported undeliverable; any other 4xx (401 expired token, 403, 404 unknown tenant)
  says nothing about the content, so everything is kept, and retried with the same backoff. Either way
  each distinct cause is logged once, and nothing is resent in a loop.

The inbound side calls :meth:`Sender.wake` when it sees Orion back or missing our entities: the sender
then retries at once, with every robot's latest state, instead of sleeping through its backoff.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Iterator
from dataclasses import dataclass, field
from time import monotonic

from transports.orion.client import OrionClient, OrionError, OrionRejected
from transports.orion.health import Backoff, Health
from transports.orion.outbox import Batch, Outbox, PendingError
from vcran.core.build import motion_message
from vcran.core.messages import FORCED_UPDATES, Message, Time
from vcran.core.wire import Frame

log = logging.getLogger("vcran.orion")

#: Order of attributes inside one entity of a batch update: every attribute the RAN publishes (battery
#: too, SPEC §4; a fleet manager reads it from Orion, §9), the one ``ran_error`` of the element last.
ATTRIBUTE_ORDER = ("current_motion", "assignment_state", "ran_status", "robot_description", "battery_state", "ran_error")
#: Orion's answers that refuse a request's content (NGSI v2 BadRequest, RequestEntityTooLarge,
#: Unprocessable): sending the same content again cannot help.
CONTENT_REFUSALS = frozenset({400, 413, 422})
#: A ran_error in this many content refusals is reported undeliverable instead of being sent again.
MAX_REFUSALS = 2


@dataclass
class Counts:
    """What the sender did: requests tried and taken, and the fate of every ``ran_error``."""

    attempts: int = 0
    accepted: int = 0
    refused: int = 0  # a 4xx
    failed: int = 0  # unreachable, timeout, 5xx
    errors_delivered: int = 0
    errors_undeliverable: int = 0


@dataclass(eq=False)
class Element:
    """One entity element of a batch update and what it carries: ``state`` (without current_motion,
    which comes from the frame) goes back to the outbox if Orion does not take it, and so does ``error``."""

    robot: str
    data: bytes
    state: dict[str, Message] = field(default_factory=dict)
    error: PendingError | None = None
    forced: bool = False  # written with options=forcedUpdate (FORCED_UPDATES), in a request of its own


class Sender:
    def __init__(self, client: OrionClient, outbox: Outbox, entity_type: str, robots: tuple[str, ...],
                 backoff: Backoff) -> None:
        self.client, self.outbox = client, outbox
        self.entity_type, self.robots = entity_type, robots
        self.backoff = backoff
        self.health = Health("outbound")
        self.counts = Counts()
        self._tick = threading.Event()
        self._wake = threading.Event()
        self._reported_drops = 0

    def tick(self) -> None:
        """A telemetry tick: send what the outbox holds (unless backing off)."""
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
        """A last attempt at closing; whatever ``ran_error`` is still waiting is reported undeliverable."""
        if self.deliver() is not None:
            left = self.outbox.take().errors
            if left:
                self.counts.errors_undeliverable += len(left)
                log.warning("outbound: %d ran_error(s) not delivered: %s", len(left), self.health.fault)
        self._report_drops()

    def deliver(self) -> float | None:
        """Send what the outbox holds; None when Orion took all of it, else the seconds to wait before
        trying again (what it did not take is back in the outbox)."""
        from vcran.core.codec import split_batch_counted

        batch = self.outbox.take()
        self._report_drops()
        if not batch:
            return None
        elements = list(self._elements(batch))  # the tick's elements, then the forced ones
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
                self.counts.errors_delivered += sum(1 for e in elements[done:done + count] if e.error is not None)
                done += count
            frame = None  # delivered with the tick's request(s)
        self.backoff.reset()
        if self.health.ok("delivered the fleet's latest state"):
            self.wake()  # Orion may have come back empty: restore everything, not only the changes
        return None

    def _failed(self, exc: OrionError, frame: Frame | None, refused: list[Element], later: list[Element]) -> float:
        content = isinstance(exc, OrionRejected) and exc.status in CONTENT_REFUSALS
        back = Batch(frame=frame)
        lost: list[PendingError] = []
        for element in refused if content else ():
            # State Orion refused as invalid is not sent again (the next tick has fresh state); its
            # errors get one more chance, in case another element of the body was the invalid one.
            if element.error is not None:
                element.error.refusals += 1
                (lost if element.error.refusals >= MAX_REFUSALS else back.errors).append(element.error)
        for element in later if content else refused + later:
            error = element.error
            if element.state:
                back.state.setdefault(element.robot, {}).update(element.state)
            if error is not None:
                back.errors.append(error)
        self.outbox.give_back(back)
        if isinstance(exc, OrionRejected):
            self.counts.refused += 1
            what = ("its state values dropped, its ran_errors retried once" if content else
                    "everything kept") + ", retrying with backoff"
            self.health.failed(f"Orion refused a batch update ({exc}); {what}", f"{exc.status} {exc.error}")
        else:
            self.counts.failed += 1
            self.health.failed(f"{exc}; retrying with backoff")
        if lost:
            self.counts.errors_undeliverable += len(lost)
            log.warning("outbound: %d ran_error(s) refused %d times by Orion, not sent again: %s",
                        len(lost), MAX_REFUSALS, exc)
        return self.backoff.next(exc.retry_after)

    def _report_drops(self) -> None:
        dropped = self.outbox.errors_dropped
        if dropped > self._reported_drops:
            self.counts.errors_undeliverable += dropped - self._reported_drops
            log.warning("outbound: %d ran_error(s) dropped, more were waiting than the outbox keeps",
                        dropped - self._reported_drops)
            self._reported_drops = dropped

    # --- encoding ---------------------------------------------------------------------------------------

    def _elements(self, batch: Batch) -> Iterator[Element]:
        """The entity elements of a batch, in fleet order, then each robot's further errors in order, then
        the forced attributes (FORCED_UPDATES) of each robot, for a request of their own."""
        motions = {}
        if batch.frame is not None:
            stamp = Time.from_seconds(batch.frame.t)
            for robot, (x, y, theta, v, w) in zip(batch.frame.robots, batch.frame.columns.tolist(), strict=True):
                motions[robot] = motion_message(stamp, x, y, theta, v, w)
        errors: dict[str, list[PendingError]] = {}
        for error in batch.errors:
            errors.setdefault(error.robot, []).append(error)
        forced: list[tuple[str, dict[str, Message]]] = []
        for robot in self.robots:
            pending = batch.state.get(robot, {})
            state = {name: pending[name] for name in ATTRIBUTE_ORDER[1:-1]
                     if name in pending and name not in FORCED_UPDATES}
            if any(name in pending for name in FORCED_UPDATES):
                forced.append((robot, {name: pending[name] for name in ATTRIBUTE_ORDER if name in FORCED_UPDATES
                                       and name in pending}))
            queue = errors.get(robot, [])
            first = queue.pop(0) if queue else None
            attrs = ({"current_motion": motions[robot]} if robot in motions else {}) | state
            if first is not None:
                attrs["ran_error"] = first.message
            if attrs:
                yield from self._encoded(Element(robot, b"", state, first), attrs)
        for robot in self.robots:  # fleet order; each robot's errors oldest first
            for error in errors.get(robot, []):
                yield from self._encoded(Element(robot, b"", {}, error), {"ran_error": error.message})
        for robot, state in forced:
            yield from self._encoded(Element(robot, b"", state, forced=True), dict(state))

    def _encoded(self, element: Element, attrs: dict[str, Message]) -> Iterator[Element]:
        from vcran.core.codec import CodecError, encode_entity_json
        from vcran.core.orion_rules import MAX_REQUEST_BYTES

        while attrs:
            try:
                data = encode_entity_json(element.robot, self.entity_type, attrs)
            except CodecError as exc:  # a bug, not Orion's fault: drop the attribute, keep the rest
                log.error("cannot encode %s of %s, dropped: %s", exc.attribute or "an attribute", element.robot, exc)
                attrs = {k: v for k, v in attrs.items() if k != exc.attribute} if exc.attribute in attrs else {}
                continue
            if len(data) > MAX_REQUEST_BYTES - 64:
                log.error("%s encodes to %d bytes, over Orion's request limit: not sent", element.robot, len(data))
                break
            if element.error is not None and "ran_error" not in attrs:
                self.counts.errors_undeliverable += 1  # its encoding failed: said above, not lost silently
                element.error = None
            element.data = data
            yield element
            return
        if element.error is not None:  # never sent: say so rather than lose it silently
            self.counts.errors_undeliverable += 1
