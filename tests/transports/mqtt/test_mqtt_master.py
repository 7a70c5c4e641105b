"""The master's side of VDA 5050 over MQTT (what ``vcran manage --mqtt`` uses, tests/transports/mqtt/test_mqtt_manage_link.py) against a real Mosquitto
and vcran's own vehicles' side."""

from __future__ import annotations

import logging
import threading

from tests.transports.mqtt.support import Driver, Watcher, config, wait_until
from transports.mqtt import MqttMaster, MqttOptions, MqttTransport, parse_url
from vcran.core.vda5050 import validation
from vcran.core.vda5050.codec import decode, encode
from vcran.core.vda5050.enums import Topic, Version
from vcran.core.wire import Inbound
from vcran.testing.vda5050.plans import order, pause


class Inbox:
    def __init__(self) -> None:
        self.got: list[Inbound] = []
        self._lock = threading.Lock()

    def __call__(self, inbound: Inbound) -> None:
        with self._lock:
            self.got.append(inbound)

    def of(self, robot: str, topic: str) -> list[Inbound]:
        with self._lock:
            return [i for i in self.got if i.entity == robot and i.attribute == topic]


def test_a_master_sees_the_fleet_and_drives_each_vehicle_in_its_version(broker):
    """The master gets each vehicle's connection, factsheet and states (visualization only when asked), and
    what it sends reaches the vehicle's robot as the vehicle's version encodes it (§6.2: QoS 0, not
    retained), valid against that version's official schema."""
    configs = {"r1": config("S1"), "r2": config("S2", Version.V2_0_0)}
    transport = MqttTransport(parse_url(broker.url), Driver.fleet(configs))
    driver = Driver(transport, configs, speed=10.0, period=1.0).start()
    inbox = Inbox()
    watcher = Watcher(broker.url, ("uagv/v2/vcran/+/order", "uagv/v2/vcran/+/instantActions"))
    master = MqttMaster(parse_url(broker.url), Driver.fleet(configs), inbox)
    master.open()
    try:
        kinds = ("state", "connection", "factsheet")
        assert wait_until(lambda: all(inbox.of(robot, kind) for robot in configs for kind in kinds))
        sent = order("o1", 0, [("a", 0, 0), ("b", 1, 0)], version=Version.V2_0_0)
        assert master.send("r2", sent) and master.send("r1", pause())
        assert wait_until(lambda: len(driver.delivered) == 2)
    finally:
        master.close()
        driver.stop()
    assert not any(i.attribute == "visualization" for i in inbox.got)
    assert decode(Topic.STATE, inbox.of("r2", "state")[0].raw, Version.V2_0_0).header.serial_number == "S2"
    delivered = {i.entity: i for _, i in driver.delivered}
    assert delivered["r2"].attribute == "order" and delivered["r2"].raw == encode(sent, Version.V2_0_0).decode()
    assert decode(Topic.ORDER, delivered["r2"].raw, Version.V2_0_0) == sent
    assert delivered["r1"].attribute == "instantActions"
    for seen in watcher.of():
        version = Version.V2_0_0 if "/S2/" in seen.topic else Version.V2_1_0
        assert seen.qos == 0 and not seen.retain
        assert validation.first_problem(validation.outbound(Topic(seen.kind), version), seen.doc) is None
    watcher.close()
    assert master.counts["sent"] == 2


def test_foreign_vehicles_and_bad_payloads_are_reported_once(broker, caplog):
    """Another fleet on the same broker: its messages are ignored, logged once per topic, all counted; a
    fleet vehicle's payload that is not JSON is handed on (the master decides) and reported once."""
    configs = {"r1": config("S1")}
    inbox = Inbox()
    master = MqttMaster(parse_url(broker.url), Driver.fleet(configs), inbox)
    master.open()
    stranger = Watcher(broker.url, ("nothing/#",))
    try:
        with caplog.at_level(logging.WARNING, logger="vcran.mqtt"):
            for _ in range(3):
                stranger.publish("uagv/v2/other/X/state", b"{}")
                stranger.publish("uagv/v2/vcran/S1/state", b"garbage")
            stranger.publish("uagv/v2/vcran/S1/state", b"{}")
            assert wait_until(lambda: len(inbox.got) == 4)
    finally:
        stranger.close()
        master.close()
    assert [i.raw for i in inbox.got] == ["garbage"] * 3 + ["{}"]
    assert master.tally.counts == {"foreign topics": 3, "bad payloads": 3}
    lines = [r.getMessage() for r in caplog.records]
    assert sum("uagv/v2/other/X/state" in line for line in lines) == 1
    assert sum("not JSON" in line for line in lines) == 1


def test_the_master_says_what_it_could_not_send_and_comes_back_after_a_restart(broker):
    configs = {"r1": config("S1")}
    inbox = Inbox()
    master = MqttMaster(parse_url(broker.url), Driver.fleet(configs), inbox,
                        options=MqttOptions(backoff_start=0.1, backoff_cap=0.5))
    master.open()
    try:
        broker.stop()
        assert wait_until(lambda: not master.up)
        assert master.send("r1", pause()) is False  # not queued: a stale order on reconnect could do harm
        broker.start()
        assert wait_until(lambda: master.up, timeout=30)
        publisher = Watcher(broker.url, ("nothing/#",))
        assert wait_until(lambda: master.client.connects == 2)
        publisher.publish("uagv/v2/vcran/S1/state", b"{}")  # subscriptions were made again on reconnecting
        assert wait_until(lambda: len(inbox.got) == 1)
        publisher.close()
    finally:
        master.close()
    assert master.counts["unsent"] == 1 and master.counts["received"] == 1
