"""The fleet's side of live mode (docs/contract.md §7): a virtual fleet that a real fleet manager drives through Orion.

:class:`OrionTransport` is the :class:`~transports.orion.link.OrionLink` (subscription keeper or poller,
notification listener, sender; docs/live.md) that reads the fleet's commands (``motion_assignment``,
``action_assignment``, ``cancel_order``) and writes what the RAN publishes, as the RAN's transport:

* the **simulation thread** (SimPy, :class:`~vcran.sim.live.LiveEnvironment`) calls :meth:`send`, which
  only writes into the outbox and wakes the sender: it never waits on the network. The sender writes the
  fleet's changes once per telemetry tick (one request, every ``ran_error`` included; more only when a
  body would pass Orion's 1 MB limit);
* inbound attribute values go into the simulation through :meth:`LiveEnvironment.call_soon`, which stamps
  them with the simulated time at which they entered; each is one inbound record of the trace.
"""

from __future__ import annotations

from functools import partial
from time import monotonic

import simpy

from transports.base import Deliver, Transport, wall_stats
from transports.orion.client import OrionClient
from transports.orion.link import Change, LinkOptions, OrionLink, Subscription
from vcran.core.opil.messages import INBOUND
from vcran.core.wire import Frame, Inbound, Outbound, Publish
from vcran.sim.live import LiveEnvironment

COMMANDS = tuple(INBOUND)


class OrionTransport(OrionLink, Transport):
    def __init__(self, client: OrionClient, options: LinkOptions) -> None:
        super().__init__(client, options, COMMANDS, (Subscription("vcran live: fleet commands", COMMANDS, COMMANDS),))
        self.latencies: list[float] = []  # wall seconds from arrival to entering the simulation
        self._env: LiveEnvironment | None = None
        self._deliver: Deliver | None = None

    def attach(self, env: simpy.Environment, deliver: Deliver) -> None:
        if not isinstance(env, LiveEnvironment):
            raise TypeError("the Orion transport runs on a LiveEnvironment (real time)")
        self._env, self._deliver = env, deliver
        self.start(env.speed)

    def send(self, out: Outbound) -> None:
        if isinstance(out, Frame):
            self.outbox.put_frame(out)
            self.sender.tick()  # one batch per telemetry tick
        else:
            assert isinstance(out, Publish)
            self.outbox.put(out.robot, out.attribute, out.message)

    def latency_stats(self) -> dict[str, float]:
        return wall_stats(self.latencies)

    def _hand_on(self, changes: list[Change], arrived: float) -> None:
        env = self._env
        assert env is not None
        for robot, attribute, value in changes:
            env.call_soon(partial(self._enter, Inbound(robot, attribute, raw=value), arrived))

    def _enter(self, inbound: Inbound, arrived: float) -> None:
        assert self._deliver is not None
        self.latencies.append(monotonic() - arrived)
        if len(self.latencies) > 100_000:
            del self.latencies[:50_000]
        self._deliver(inbound)
