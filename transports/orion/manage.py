"""A fleet manager against a real Orion, in real time (docs/contract.md §9, "The same fleet manager, live").

``vcran manage`` runs the very :class:`~vcran.core.opil.manager.FleetManager` object that
:func:`vcran.simulate` runs, with the same handle API: :class:`OrionLoop` is
:class:`vcran.sim.opil.loop.ClosedLoop` on a :class:`~vcran.sim.live.LiveEnvironment` (so ``now``, jobs and
``call_at`` timers follow the wall clock, scaled by the speed factor), with :class:`OrionManagerLink` in
place of the simulated link. That is the :class:`~transports.orion.link.OrionLink` of ``vcran live``
(transports/orion/link.py), with every guarantee of docs/contract.md §7, reading the robots' published attributes
and writing the manager's commands:

* **writes** (assignments and cancels) go into the link's outbox, queued in write order, and its sender
  writes them to Orion as batch updates, so a hook never waits on HTTP: whatever the manager wrote while
  the previous request was in flight (or Orion was down) goes out together, each robot's writes in order,
  every one of them delivered or reported undeliverable;
* **updates** come from the link's subscription to the robots' published attributes (with a notification
  URL), or from polling them. The subscription's condition is the manager's
  :attr:`~vcran.core.opil.manager.FleetManager.attributes`; every notification carries all of them, so
  ``handle.latest`` and ``handle.pose`` are as fresh as the robot's last notified change.
  ``robot_description`` (:data:`~vcran.core.opil.messages.FORCED_UPDATES`) has a subscription of its own:
  ``vcran live`` writes it every period with Orion's forcedUpdate, unchanged, and a notification of the
  whole entity cannot tell such a write from a description that merely rides along; this subscription's
  notifications can, so the manager is told of each periodic write, as in simulated time (docs/contract.md §2, §9).
  Polling tells the manager what the subscription would (the link's reads); a value that changes and
  changes back between two reads is missed, as polling misses it in ``vcran live`` (docs/live.md).
  Either way a batch enters the manager's thread through :meth:`LiveEnvironment.call_soon`: every hook
  runs in one thread, as in simulated time.
"""

from __future__ import annotations

import json
import logging
from collections.abc import Callable
from dataclasses import replace

import simpy

from transports.orion.client import OrionClient
from transports.orion.link import Change, LinkOptions, OrionLink, Subscription
from vcran.core.jobs import Log
from vcran.core.opil.codec import CodecError, decode_attribute, encode_attribute_json
from vcran.core.opil.manager import FleetManager
from vcran.core.opil.messages import FORCED_UPDATES, OUTBOUND, Message, RanStatus
from vcran.core.scenario import Scenario
from vcran.core.wire import Deliver, Outbound, Publish
from vcran.sim.live import LiveEnvironment
from vcran.sim.opil.loop import ClosedLoop

log = logging.getLogger("vcran.orion")

PUBLISHED = tuple(OUTBOUND)


class OrionManagerLink(OrionLink):
    """The manager's side of Orion: its writes out, the robots' updates in (:meth:`notify`, one batch
    per notification or read), for :class:`OrionLoop`'s manager."""

    def __init__(self, env: LiveEnvironment, client: OrionClient, options: LinkOptions,
                 attributes: frozenset[str] | None, notify: Callable[[list[Outbound]], None]) -> None:
        wanted = [a for a in PUBLISHED if attributes is None or a in attributes]
        updates = Subscription("vcran manage: robot updates for the fleet manager", tuple(wanted), PUBLISHED)
        subscriptions: tuple[Subscription, ...] = (updates,)
        forced = tuple(a for a in wanted if a in FORCED_UPDATES)
        if forced:
            subscriptions += (Subscription("vcran manage: robot descriptions, each periodic write, for the fleet "
                                           "manager", forced, forced, writes=True),)
        super().__init__(client, options, PUBLISHED, subscriptions, outbound="manager writes",
                         inbound="manager polling" if options.notify_url is None else "manager subscription",
                         queued="write")
        self.env, self.notify = env, notify

    def write(self, robot: str, attribute: str, message: Message | None, raw: object = None) -> None:
        value = (encode_attribute_json(attribute, message) if message is not None
                 else json.dumps(raw, separators=(",", ":"), allow_nan=False))  # JSON: the handle checked
        self.outbox.put(robot, attribute, value)
        self.sender.tick()

    @property
    def writes(self) -> int:
        """The manager's writes Orion took."""
        return self.sender.counts.delivered

    @property
    def inbound_idle(self) -> bool:
        """Everything the manager wrote has reached Orion (or was reported undeliverable)."""
        return self.outbox.idle

    @property
    def outbound_idle(self) -> bool:
        return True  # what the robots publish is theirs to send; nothing of it is held here

    def _hand_on(self, changes: list[Change], arrived: float) -> None:
        batch: list[Outbound] = []
        for robot, attribute, value in changes:
            try:
                batch.append(Publish(0.0, robot, attribute, decode_attribute(attribute, value)))
            except CodecError as exc:
                log.warning("%s of %s does not decode, ignored: %s", attribute, robot, exc)
        if batch:
            self.env.call_soon(lambda: self.notify(batch))


class OrionLoop(ClosedLoop):
    """:class:`ClosedLoop` whose link is a real Orion: the manager's side of ``vcran manage``.

    Besides the ``job_*`` events, ``log`` gets what the manager heard of the robots through Orion, from
    each robot's ``ran_status`` (issue 29 item 12: ``vcran report`` draws the fleet figure from them): a
    ``state`` event when its RanLogic state changed, ``task_completed`` and ``task_cancelled`` (with the
    reason) for each task newly in its lists, at the instant the notification (or read) reached the
    manager, before the manager's hooks see it. The first status heard of a robot is the baseline: tasks
    that ended before ``manage`` started are not logged as ending then."""

    def __init__(self, scenario: Scenario, manager: FleetManager, log: Log, client: OrionClient,
                 options: LinkOptions) -> None:
        super().__init__(scenario, manager, log)
        self.client, self.options = client, options
        self._log = log
        self._heard: dict[str, RanStatus] = {}

    def notified(self, batch: list[Outbound], forced: frozenset[str] = FORCED_UPDATES) -> None:
        assert self.handle is not None
        for out in batch:
            if isinstance(out, Publish) and out.attribute == "ran_status" and isinstance(out.message, RanStatus):
                self._hear(self.handle.now, out.robot, out.message)
        super().notified(batch, forced)

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

    def make_link(self, env: simpy.Environment, deliver: Deliver) -> OrionManagerLink:
        assert isinstance(env, LiveEnvironment)
        options = replace(self.options, robots=self.fleet.robot_ids)
        link = OrionManagerLink(env, self.client, options, self.manager.attributes, self.notified)
        link.start(env.speed, strict=True)  # Orion unreachable or refusing: an error before any hook runs
        return link
