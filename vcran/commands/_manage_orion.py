"""``vcran manage --orion URL``: an OPIL fleet manager against the robots Orion holds (docs/live.md, "A fleet manager,
live"); :mod:`vcran.commands.manage` runs it. The manager learns of the robots' updates from a subscription
(``--notify-url``: Orion must be able to reach vcran there) or, by default, by polling Orion every
``--poll-interval`` simulated seconds; :mod:`transports.orion.manage` and :mod:`transports.orion.link` are the link.
"""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

from vcran.commands import CommandError
from vcran.commands._orion import LISTEN, POLL_INTERVAL, check_inbound, client_from_args
from vcran.core.scenario import OPIL
from vcran.runner import EDGES

if TYPE_CHECKING:
    from transports.orion.manage import OrionLoop, OrionManagerLink
    from vcran.core.jobs import Log
    from vcran.core.manager import Manager
    from vcran.core.scenario import Scenario
    from vcran.sim.live import LiveEnvironment

check = check_inbound  # the edge's options, as vcran live --orion checks them
#: The option of this edge (OPIL's): vcran manage checks the scenario's protocol against it.
OPTION = EDGES[OPIL]


class OrionSide:
    """The manager's side of Orion: a client now (a URL or token file that cannot work is refused before any
    folder exists), the link when :meth:`attach` subscribes or reads the fleet."""

    def __init__(self, args: argparse.Namespace, scenario: Scenario) -> None:
        self.args, self.scenario = args, scenario
        self.polling = args.notify_url is None
        self.poll_interval = POLL_INTERVAL if args.poll_interval is None else args.poll_interval
        self.listen = LISTEN if args.listen is None else args.listen
        self.client = client_from_args(args)
        self.loop: OrionLoop | None = None

    def attach(self, manager: Manager, log: Log, env: LiveEnvironment) -> OrionLoop:
        from transports.orion.client import OrionError
        from transports.orion.link import LinkOptions
        from transports.orion.manage import OrionLoop

        options = LinkOptions(self.scenario.settings.entity_type, notify_url=self.args.notify_url,
                              listen_host=self.listen, poll_interval=self.poll_interval)
        loop = OrionLoop(self.scenario, manager, log, self.client, options)  # type: ignore[arg-type]
        self.loop = loop  # closed by close() whatever attach raises (a manager's on_start too)
        try:
            loop.attach(env, lambda _inbound: None)
        except OrionError as exc:
            what = "read the fleet from" if self.polling else "subscribe to the fleet on"
            raise CommandError(f"cannot {what} {self.args.orion}: {exc}") from None
        except OSError as exc:
            raise CommandError(f"cannot listen for notifications on {self.listen}, {self.args.notify_url}: "
                               f"{exc.strerror}") from None
        return loop

    @property
    def link(self) -> OrionManagerLink:
        from transports.orion.manage import OrionManagerLink

        assert self.loop is not None and isinstance(self.loop.link, OrionManagerLink)
        return self.loop.link

    def announce(self, name: str) -> str:
        mode = f"polling every {self.poll_interval:g} s" if self.polling else f"subscription to {self.args.notify_url}"
        return f"{name} on {len(self.scenario.robots)} robot(s) at {self.args.orion}, x{self.args.factor:g}, {mode}"

    def traffic(self) -> str:
        """What the manager wrote, and what reached it: notifications, or the reads of Orion when polling."""
        link = self.link
        inbound = f"{link.reads} read(s)" if self.polling else f"{link.notifications} notification(s)"
        return f"{link.writes} write(s) in {link.updates} request(s), {inbound}"

    def close(self) -> None:
        if self.loop is not None and self.loop.link is not None:
            self.link.close()
        self.client.close()


side = OrionSide  # what vcran manage builds with the edge's options, before any folder is made (its Side)
