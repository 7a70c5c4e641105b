"""``vcran live --mqtt URL``: VDA 5050 vehicles on an MQTT broker, for a master written in any language
(docs/contract.md §11; docs/vda5050.md, "Live over MQTT"); :mod:`vcran.commands.live` runs it.

Each vehicle has its own connection, ONLINE (retained) before the run starts; the glue publishes its state
on every event and at least every 30 s (or the scenario's state_interval), its visualization every telemetry
period. A run that ends (its duration, SIGINT or SIGTERM) says OFFLINE for every vehicle and disconnects.
Every order and instantActions is recorded as its payload arrived, so ``vcran replay DIR --verify``
reproduces the run.
"""

from __future__ import annotations

import argparse
from collections import Counter
from typing import TYPE_CHECKING

from vcran.commands import CommandError
from vcran.core.scenario import VDA5050
from vcran.runner import EDGES

if TYPE_CHECKING:
    from transports.mqtt import BrokerUrl, MqttTransport
    from vcran.core.scenario import Scenario
    from vcran.sim.model import Model

#: The options of ``--orion`` alone, as argparse names them.
#: The option of this edge (VDA 5050's): vcran live checks the scenario's protocol against it.
OPTION = EDGES[VDA5050]
ORION_ONLY = ("service", "service_path", "token_file", "notify_url", "listen", "poll_interval")
#: Wall seconds the vehicles (and ``vcran manage --mqtt``'s master) may take to connect before the command gives up:
#: transports.mqtt.client.CONNECT_TIMEOUT, the edge's default, written here because the commands import paho only
#: when they connect (a test shortens it).
CONNECT_TIMEOUT = 10.0


def check(args: argparse.Namespace) -> None:
    """The broker's URL, and no option of ``--orion``'s."""
    given = [f"--{name.replace('_', '-')}" for name in ORION_ONLY if getattr(args, name) is not None]
    if given:
        raise CommandError(f"{', '.join(given)}: only with --orion (--mqtt has none of them)")
    broker_url(args.mqtt)


def broker_url(text: str) -> BrokerUrl:
    """``--mqtt``'s broker, or a CommandError saying what is wrong with it (also for vcran manage --mqtt)."""
    try:
        from transports.mqtt import MqttUrlError, parse_url
    except ModuleNotFoundError as exc:  # the vda5050 extra is missing: the message says how to install it
        raise CommandError(str(exc)) from None
    try:
        return parse_url(text)
    except MqttUrlError as exc:
        raise CommandError(f"--mqtt {exc}") from None


class MqttEdge:
    """The fleet on the broker, every vehicle connected and ONLINE."""

    unit = "order"
    names = ("idle", "driving", "working", "paused")

    def __init__(self, args: argparse.Namespace, transport: MqttTransport) -> None:
        self.args, self.transport = args, transport
        self.options = {"transport": "live-mqtt", "factor": args.factor, "broker": str(transport.url)}

    def announce(self) -> str:
        vehicles = [str(v.address) for v in self.transport.vehicles.values()]
        shown = ", ".join(vehicles[:3]) + (f" and {len(vehicles) - 3} more" if len(vehicles) > 3 else "")
        return (f"live: {len(vehicles)} VDA 5050 vehicle(s) on {self.transport.url} ({shown}), "
                f"x{self.args.factor:g}; Ctrl-C stops")

    def states(self, model: Model) -> Counter[str]:
        """idle (no order), driving, working (an order, not driving: an action, waiting for its base), paused."""
        shown: Counter[str] = Counter()
        for node in model.protocol.nodes:  # type: ignore[attr-defined]
            vehicle = node.vehicle
            shown["paused" if vehicle.paused else "driving" if vehicle.driving
                  else "working" if vehicle.executing else "idle"] += 1
        return shown

    def traffic(self, wall: float) -> str:
        sent, delivered = self.transport.counts["sent"], self.transport.delivered
        return (f"out {sent / wall:.1f} messages/s ({sent} sent), "
                f"in {delivered / wall:.1f} messages/s ({delivered} delivered)")

    def latency(self) -> str | None:
        from vcran.commands.live import latency_line

        return latency_line("arrival to the state it caused", self.transport.answer_stats(),
                            "order and instantActions messages")

    def close(self) -> None:
        self.transport.close()


def connect(args: argparse.Namespace, scenario: Scenario) -> MqttEdge:
    from transports.mqtt import MqttTransport, MqttUnavailable
    from transports.mqtt.topics import fleet_of

    url = broker_url(args.mqtt)
    try:
        transport = MqttTransport(url, fleet_of(scenario))
    except ValueError as exc:  # two robots on the same topics, a level MQTT cannot carry
        raise CommandError(f"{scenario.source}: {exc}") from None
    try:
        transport.open(timeout=CONNECT_TIMEOUT)
    except MqttUnavailable as exc:
        raise CommandError(f"cannot connect to the broker: {exc}") from None
    return MqttEdge(args, transport)
