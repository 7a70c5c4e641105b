"""The link between a fleet manager and the RAN in a closed loop: Orion, in simulated time (docs/contract.md §9).

Both directions go through it, as they would through Orion:

* **manager -> RAN.** A write lands in Orion ``latency`` (+ a seeded draw from ``[0, jitter)``) seconds
  after it was made, never before an earlier write to the same robot (HTTP requests of one client, in
  order). Orion holds one value per robot and attribute; a write equal to the value held changes
  nothing and notifies nobody (Orion's default ``entityChange``). Under ``subscription`` every change
  reaches the RAN as it lands; under ``polling`` the RAN reads what Orion holds every ``poll_interval``
  seconds and gets each attribute that differs from what it read last, so a write overwritten before
  the next read is lost, exactly as in live mode (docs/contract.md §7).
* **RAN -> manager.** Everything the RAN publishes at one instant travels as one batch (one batch
  update, as live mode sends one per tick) and reaches the manager ``latency`` (+ jitter) later, batches
  in order; the protocol's loop turns a batch into the manager's updates (OPIL's
  :class:`vcran.sim.opil.loop.ClosedLoop`: the actual changes, and every write of ``robot_description``,
  which live mode forces through Orion, ``options=forcedUpdate``, so that a planner subscribing late gets
  it, docs/contract.md §2).

The link knows attributes by name only: which of them are ``periodic`` (published whatever happens, so
they never keep a run from ending idle) and of which ``every`` value waits out a ``link_down`` (the others
coalesce to the latest) are the protocol's to say (OPIL: ``robot_description``; ``ran_error``).

**loss** (a broker's link only, ``holds`` False: VDA 5050, whose messages travel at MQTT's QoS 0, §6.2): each
message, either way, is lost with probability ``loss``. It draws once from the link's seeded generator when it is
sent (the manager's write; the robot's publication, in the order published), before the draw of its jitter; a
lost message draws nothing more, never reaches the other side and is on its way to nobody (it keeps no run
alive). With ``loss`` 0 nothing is drawn, so the draws of a run without loss are those it always made. A lost
write never reaches the robot, so the trace (what reached it) does not have it, and a replay needs nothing
else to reproduce the loss (docs/contract.md §6). Orion's link loses nothing (HTTP over TCP): what an OPIL scenario
loses is a polling read's overwrite (docs/contract.md §7), and its scenarios refuse ``loss``.

``outage`` is the hook for the ``link_down`` fault (docs/contract.md §4): while a robot's link is down nothing
reaches it and nothing it publishes leaves; afterwards it reads what Orion holds (the latest value per
attribute) and its missed publications go out coalesced (the latest per attribute; every ``ran_error``
in order, for OPIL), as after an Orion outage in live mode.

Every latency is positive, so a write reaches the RAN at a later instant than the callback that made
it, and a recorded trace replays in the same order (docs/determinism.md).
"""

from __future__ import annotations

import random
from collections.abc import Callable
from dataclasses import dataclass
from heapq import heappop, heappush
from typing import Any

import simpy

from vcran.core.scenario import POLLING, LinkSettings
from vcran.core.wire import Deliver, Frame, Inbound, Outbound, Publish
from vcran.sim.timing import INBOUND, UPDATE, at

#: What a manager gets told: a batch of outbound messages, in the order the RAN published them.
Notify = Callable[[list[Outbound]], None]


@dataclass(frozen=True, slots=True)
class _Write:
    seq: int
    robot: str
    attribute: str
    message: Any
    raw: Any

    @property
    def value(self) -> tuple[Any, Any]:
        return self.message, self.raw


class Link:
    def __init__(
        self,
        env: simpy.Environment,
        robots: tuple[str, ...],
        settings: LinkSettings,
        rng: random.Random,
        deliver: Deliver,
        notify: Notify,
        *,
        periodic: frozenset[str] = frozenset(),
        every: frozenset[str] = frozenset(),
        holds: bool = True,
    ) -> None:
        """``holds`` False: a broker's publish and subscribe (MQTT, VDA 5050's link) instead of Orion's
        entities: every write reaches the robot once, as it lands, none held, none merged with an equal one."""
        self.env, self.robots, self.settings = env, robots, settings
        self._rng, self._deliver, self._notify = rng, deliver, notify
        self._periodic, self._every, self._holds = periodic, every, holds
        self._polling = settings.inbound == POLLING
        self._loss = 0.0 if holds else settings.loss
        # manager -> RAN
        self._seq = 0
        self._last_in: dict[str, float] = {}
        self._flying = 0                                      # writes not yet landed
        self._landing: list[tuple[float, int, _Write]] = []   # polling: writes by arrival time
        self._held: dict[tuple[str, str], tuple[Any, Any]] = {}
        self._read: dict[tuple[str, str], tuple[Any, Any]] = {}
        self._unread: dict[tuple[str, str], _Write] = {}      # changed since the RAN last read, in write order
        # RAN -> manager
        self._last_out = 0.0
        self._batch: _Batch | None = None
        self._updates_flying = 0                              # batches carrying more than periodic telemetry
        # outages (link_down)
        self._down: dict[str, float] = {}
        self._missed: dict[str, list[Publish]] = {}
        if self._polling:
            env.process(self._poll())

    # --- manager -> RAN ---------------------------------------------------------------------------------

    def write(self, robot: str, attribute: str, message: Any, raw: Any = None) -> None:
        """The manager writes ``attribute`` of ``robot`` now; it lands after the latency (unless it is lost)."""
        if self._loss and self._lost():
            return
        self._seq += 1
        w = _Write(self._seq, robot, attribute, message, raw)
        arrival = max(self._delay(), self._last_in.get(robot, 0.0))
        self._last_in[robot] = arrival
        self._flying += 1
        if not self._holds:
            at(self.env, arrival, INBOUND).callbacks.append(lambda _: self._pass(w))
        elif self._polling:
            heappush(self._landing, (arrival, w.seq, w))
        else:
            at(self.env, arrival, INBOUND).callbacks.append(lambda _: self._arrive(w))

    def _arrive(self, w: _Write) -> None:
        self._land(w)
        if w.robot not in self._down:
            self._read_robot(w.robot)

    def _pass(self, w: _Write) -> None:
        """A broker's message lands: straight on to the robot (what a robot whose link is down gets is its glue's to
        lose, as MQTT's QoS 0 loses it, vcran.sim.vda5050.glue)."""
        self._flying -= 1
        self._deliver(Inbound(w.robot, w.attribute, w.message, w.raw))

    def _land(self, w: _Write) -> None:
        """``w`` reaches Orion: a change of the value held is remembered as unread (moved to the end)."""
        self._flying -= 1
        key = (w.robot, w.attribute)
        if self._held.get(key) == w.value:
            return  # no actual change: Orion notifies nobody
        self._held[key] = w.value
        self._unread.pop(key, None)
        self._unread[key] = w

    def _poll(self):  # type: ignore[no-untyped-def]
        """Polling: every ``poll_interval`` the RAN reads every robot whose link is up."""
        k = 1
        while True:
            yield at(self.env, k * self.settings.poll_interval, INBOUND)
            now = self.env.now
            while self._landing and self._landing[0][0] <= now:
                self._land(heappop(self._landing)[2])
            if self._unread:
                self._read_robot(None)
            k += 1

    def _read_robot(self, robot: str | None) -> None:
        """The RAN reads what changed for ``robot`` (None: every robot whose link is up), in write order;
        a value equal to the one it read last is not delivered again."""
        for key, w in list(self._unread.items()):
            if (robot is not None and w.robot != robot) or w.robot in self._down:
                continue
            del self._unread[key]
            if self._read.get(key) == w.value:
                continue
            self._read[key] = w.value
            self._deliver(Inbound(w.robot, w.attribute, w.message, w.raw))

    @property
    def inbound_idle(self) -> bool:
        """Nothing the manager wrote is still on its way to the RAN (in flight, or held unread)."""
        return self._flying == 0 and not self._unread

    # --- RAN -> manager ---------------------------------------------------------------------------------

    def publish(self, out: Outbound) -> None:
        """The RAN publishes ``out`` now; it reaches the manager with this instant's batch."""
        if self._down:
            kept = self._while_down(out)
            if kept is None:
                return
            out = kept
        if self._loss and not isinstance(out, Frame) and self._lost():
            return
        batch = self._batch
        if batch is None or batch.t != self.env.now:
            batch = self._batch = _Batch(self.env.now)
            self._last_out = max(self._delay(), self._last_out)
            at(self.env, self._last_out, UPDATE).callbacks.append(lambda _: self._arrive_batch(batch))
        if not batch.update and not (isinstance(out, Frame) or out.attribute in self._periodic):
            batch.update = True
            self._updates_flying += 1
        batch.items.append(out)

    def _arrive_batch(self, batch: _Batch) -> None:
        if batch.update:
            self._updates_flying -= 1
        if self._batch is batch:
            self._batch = None
        self._notify(batch.items)

    @property
    def outbound_idle(self) -> bool:
        """No update other than periodic telemetry is on its way to the manager (or held by an outage)."""
        return self._updates_flying == 0 and not self._missed

    # --- link_down ----------------------------------------------------------------------------------------

    def outage(self, robot: str, until: float) -> None:
        """``robot``'s link is down from now until ``until`` (the ``link_down`` fault's hook, docs/contract.md §4)."""
        if robot not in self.robots:
            raise ValueError(f"no robot {robot!r} on this link")
        end = max(until, self._down.get(robot, until))
        self._down[robot] = end
        at(self.env, end, INBOUND).callbacks.append(lambda _: self._restore(robot, end))

    def _restore(self, robot: str, end: float) -> None:
        if self._down.get(robot) != end:
            return  # extended meanwhile
        del self._down[robot]
        self._read_robot(robot)
        for out in self._missed.pop(robot, []):
            self.publish(Publish(self.env.now, out.robot, out.attribute, out.message))

    def _while_down(self, out: Outbound) -> Outbound | None:
        """A publication while some link is down: a down robot's is kept (coalesced) for later."""
        if isinstance(out, Frame):
            keep = [i for i, r in enumerate(out.robots) if r not in self._down]
            return Frame(out.t, tuple(out.robots[i] for i in keep), out.columns[keep]) if keep else None
        if out.robot not in self._down:
            return out
        missed = self._missed.setdefault(out.robot, [])
        if out.attribute not in self._every:
            missed[:] = [m for m in missed if m.attribute != out.attribute]
        missed.append(out)
        return None

    def _lost(self) -> bool:
        """One message's loss draw (module docstring: once per message, before its jitter)."""
        return self._rng.random() < self._loss

    def _delay(self) -> float:
        s = self.settings
        return self.env.now + s.latency + (self._rng.random() * s.jitter if s.jitter > 0 else 0.0)


class _Batch:
    """What the RAN published at one instant, travelling together; ``update``: more than periodic telemetry."""

    __slots__ = ("t", "items", "update")

    def __init__(self, t: float) -> None:
        self.t = t
        self.items: list[Outbound] = []
        self.update = False
