"""``vcran live --orion URL``: OPIL robots driven through Orion (docs/live.md); :mod:`vcran.commands.live` runs it."""

from __future__ import annotations

import argparse
from collections import Counter
from typing import TYPE_CHECKING

from vcran.commands import CommandError
from vcran.commands._orion import LISTEN, POLL_INTERVAL, check_inbound, client_from_args
from vcran.core.scenario import OPIL
from vcran.io.progress import STATES
from vcran.runner import EDGES

if TYPE_CHECKING:
    from transports.orion.transport import OrionTransport
    from vcran.core.scenario import Scenario
    from vcran.sim.model import Model

check = check_inbound  # the edge's options, as vcran manage --orion checks them
#: The option of this edge (OPIL's): vcran live checks the scenario's protocol against it.
OPTION = EDGES[OPIL]


class OrionEdge:
    """The fleet's Orion transport, its notification listener bound (a busy port is an error, not a half run)."""

    unit = "task"
    names = STATES

    def __init__(self, args: argparse.Namespace, transport: OrionTransport) -> None:
        self.args, self.transport = args, transport
        self.inbound = "subscription" if args.notify_url else "polling"
        self.options = {"transport": "live", "factor": args.factor, "inbound": self.inbound}

    def announce(self) -> str:
        args = self.args
        mode = (f"subscription to {args.notify_url}" if args.notify_url
                else f"polling every {self.transport.options.poll_interval:g} s")
        return (f"live: {len(self.transport.options.robots)} robot(s) on {args.orion}, x{args.factor:g}, {mode}; "
                "Ctrl-C stops")

    def states(self, model: Model) -> Counter[str]:
        return Counter(node.logic.state.value for node in model.protocol.nodes)  # type: ignore[attr-defined]

    def traffic(self, wall: float) -> str:
        sent = self.transport.sender.counts
        return f"outbound {sent.attempts / wall:.1f} requests/s ({sent.accepted} of {sent.attempts} accepted)"

    def latency(self) -> str | None:
        from vcran.commands.live import latency_line

        return latency_line("inbound to effect", self.transport.latency_stats(), "messages")

    def close(self) -> None:
        self.transport.close()


def connect(args: argparse.Namespace, scenario: Scenario) -> OrionEdge:
    from transports.orion.link import LinkOptions
    from transports.orion.transport import OrionTransport

    listen = args.listen if args.listen is not None else LISTEN
    options = LinkOptions(
        entity_type=scenario.settings.entity_type, robots=tuple(r.id for r in scenario.robots),
        notify_url=args.notify_url, listen_host=listen,
        poll_interval=args.poll_interval if args.poll_interval is not None else POLL_INTERVAL,
    )
    transport = OrionTransport(client_from_args(args), options)
    try:
        transport.open()
    except OSError as exc:
        raise CommandError(f"cannot listen for notifications on {listen}, {args.notify_url}: {exc.strerror}") from None
    return OrionEdge(args, transport)
