"""``vcran manage --mqtt URL``: a VDA 5050 master against vehicles on an MQTT broker (docs/vda5050.md, "Live over MQTT");
:mod:`vcran.commands.manage` runs it. :mod:`transports.mqtt.manage` is the link: the vehicles' ``state``,
``connection``, ``factsheet`` and ``visualization`` in, validated; the master's orders and instant actions out.
"""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

from vcran.commands import CommandError, _live_mqtt
from vcran.commands._live_mqtt import broker_url
from vcran.commands._live_mqtt import check as check  # the same options as vcran live --mqtt: none of --orion's
from vcran.core.scenario import VDA5050
from vcran.runner import EDGES

if TYPE_CHECKING:
    from transports.mqtt.manage import MqttLoop, MqttMasterLink
    from vcran.core.jobs import Log
    from vcran.core.manager import Manager
    from vcran.core.scenario import Scenario
    from vcran.sim.live import LiveEnvironment

#: The option of this edge (VDA 5050's): vcran manage checks the scenario's protocol against it.
OPTION = EDGES[VDA5050]


class MqttSide:
    """The master's connection to the broker, made when :meth:`attach` connects (every vehicle's topics
    subscribed before the master's ``on_start``)."""

    def __init__(self, args: argparse.Namespace, scenario: Scenario) -> None:
        from transports.mqtt.topics import check_fleet, fleet_of

        self.args, self.scenario = args, scenario
        self.url = broker_url(args.mqtt)
        try:
            check_fleet(fleet_of(scenario))
        except ValueError as exc:  # two vehicles on the same topics
            raise CommandError(f"{scenario.source}: {exc}") from None
        self.loop: MqttLoop | None = None

    def attach(self, manager: Manager, log: Log, env: LiveEnvironment) -> MqttLoop:
        from transports.mqtt import MqttUnavailable
        from transports.mqtt.manage import MqttLoop

        loop = MqttLoop(self.scenario, manager, log, self.url,  # type: ignore[arg-type]
                       connect_timeout=_live_mqtt.CONNECT_TIMEOUT)  # vcran live --mqtt's wait
        self.loop = loop  # closed by close() whatever attach raises (a manager's on_start too)
        try:
            loop.attach(env, lambda _inbound: None)
        except MqttUnavailable as exc:
            raise CommandError(f"cannot connect to the broker: {exc}") from None
        return loop

    @property
    def link(self) -> MqttMasterLink:
        from transports.mqtt.manage import MqttMasterLink

        assert self.loop is not None and isinstance(self.loop.link, MqttMasterLink)
        return self.loop.link

    def announce(self, name: str) -> str:
        return f"{name} on {len(self.scenario.robots)} VDA 5050 vehicle(s) at {self.url}, x{self.args.factor:g}"

    def traffic(self) -> str:
        return self.link.describe()

    def close(self) -> None:
        if self.loop is not None and self.loop.link is not None:
            self.link.close()


side = MqttSide  # what vcran manage builds with the edge's options, before any folder is made (its Side)
