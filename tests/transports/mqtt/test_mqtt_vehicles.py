"""The vehicles' side of VDA 5050 over MQTT against a real Mosquitto (docs/contract.md §11; VDA 5050 §6.2, §6.3,
§6.14, §6.15). Expected topics, QoS and retained flags are taken from the specification's text, quoted
beside each assertion, not from transports/mqtt/topics.py."""

from __future__ import annotations

import logging
import socket
import threading

import orjson
import pytest
import simpy

from tests.transports.mqtt.support import Driver, Watcher, config, retained, wait_until
from transports.mqtt import MqttOptions, MqttTransport, MqttUnavailable, parse_url
from vcran.core.vda5050 import validation
from vcran.core.vda5050.codec import Invalid, decode
from vcran.core.vda5050.enums import ConnectionState, Topic, Version
from vcran.core.vda5050.vehicle import Vehicle
from vcran.core.wire import Publish


def _valid(seen, version: Version) -> None:
    problem = validation.first_problem(validation.outbound(Topic(seen.kind), version), seen.doc)
    assert problem is None, f"{seen.topic}: {problem}"


def test_topics_qos_retained_flags_and_connection_states(broker):
    """§6.3: uagv/v2/<manufacturer>/<serialNumber>/<topic>; §6.2: QoS 0 for state, visualization and
    factsheet, QoS 1 for connection; §6.14 and §6.15: connection and factsheet retained, ONLINE on
    connecting, OFFLINE before a graceful disconnect; every message valid for the vehicle's version."""
    configs = {"r1": config("S-1"), "r2": config("S.2", Version.V2_0_0, manufacturer="ACME")}
    watcher = Watcher(broker.url)
    transport = MqttTransport(parse_url(broker.url), Driver.fleet(configs))
    driver = Driver(transport, configs, speed=20.0, period=1.0).start()
    try:
        assert wait_until(lambda: len(watcher.of("state")) >= 6)
        for prefix, version in (("uagv/v2/vcran/S-1", Version.V2_1_0), ("uagv/v2/ACME/S.2", Version.V2_0_0)):
            mine = [s for s in watcher.of() if s.topic.startswith(prefix + "/")]
            # ONLINE first ("AGV comes online: ... 2. Send ... ONLINE"), then what the vehicle published
            # at start: its factsheet and its first state.
            assert [s.kind for s in mine[:3]] == ["connection", "factsheet", "state"]
            assert {s.topic for s in mine} == {f"{prefix}/{t}" for t in
                                                ("connection", "factsheet", "state", "visualization")}
            for s in mine:
                assert s.qos == (1 if s.kind == "connection" else 0), s.topic
                _valid(s, version)
                assert s.doc["version"] == version.value
            online = mine[0].doc
            assert (online["connectionState"], online["headerId"]) == ("ONLINE", 0)
            assert online["timestamp"].startswith("1970-01-01T00:00:00.")  # simulated time 0 on the default epoch
            states = [s.doc["headerId"] for s in mine if s.kind == "state"]
            assert states == list(range(len(states)))  # headerIds as the vehicle stamped them, none lost
        # A newcomer gets connection and factsheet (retained), never a state (not retained).
        got = retained(broker.url, ("uagv/v2/vcran/S-1/state", "uagv/v2/vcran/S-1/factsheet",
                                    "uagv/v2/vcran/S-1/connection"))
        assert set(got) == {"uagv/v2/vcran/S-1/factsheet", "uagv/v2/vcran/S-1/connection"}
        assert all(s.retain for s in got.values())
        assert got["uagv/v2/vcran/S-1/connection"].doc["connectionState"] == "ONLINE"
    finally:
        driver.stop()
    # Closed gracefully: OFFLINE (retained), with the headerId after ONLINE's.
    assert wait_until(lambda: len(watcher.of("connection")) == 4)
    watcher.close()
    for prefix in ("uagv/v2/vcran/S-1", "uagv/v2/ACME/S.2"):
        offline = retained(broker.url, (f"{prefix}/connection",))[f"{prefix}/connection"]
        assert offline.retain and offline.qos == 1
        assert (offline.doc["connectionState"], offline.doc["headerId"]) == ("OFFLINE", 1)


def test_orders_and_instant_actions_enter_the_simulation_as_sent(broker):
    """A master's order and instantActions reach the vehicle's robot as Inbound(robot, topic, raw text),
    byte for byte, at the simulated time they arrived; another vehicle's topics never reach it."""
    configs = {"r1": config("S1"), "r2": config("S2")}
    transport = MqttTransport(parse_url(broker.url), Driver.fleet(configs))
    transport.open()
    master = Watcher(broker.url, ("nothing/#",))
    master.publish("uagv/v2/vcran/S1/order", b'{"early": true}')  # before the run: kept for its start
    assert wait_until(lambda: transport.waiting == 1)
    driver = Driver(transport, configs, speed=10.0, period=5.0).start()
    try:
        order = b'{"headerId": 7, "orderId": "o\xc3\xa9"}'
        master.publish("uagv/v2/vcran/S2/order", order)
        master.publish("uagv/v2/vcran/S9/order", b"{}")  # no such vehicle in this fleet
        master.publish("uagv/v2/vcran/S1/instantActions", b'{"actions": []}')
        assert wait_until(lambda: len(driver.delivered) >= 3)
    finally:
        master.close()
        driver.stop()
    got = [(i.entity, i.attribute, i.raw) for _, i in driver.delivered]
    assert got[0] == ("r1", "order", '{"early": true}')
    assert sorted(got[1:]) == [("r1", "instantActions", '{"actions": []}'), ("r2", "order", order.decode())]
    assert all(t > 0 for t, _ in driver.delivered)  # stamped with the simulated time of their arrival


def test_bad_payloads_are_delivered_refusable_and_reported_once(broker, caplog):
    """A payload that is not JSON (or not even UTF-8) still reaches the vehicle, which refuses it with a
    validationError (§6.6.4.1, via codec.decode); the edge logs it once per vehicle and topic and counts
    every one; nothing crashes."""
    configs = {"r1": config("S1")}
    transport = MqttTransport(parse_url(broker.url), Driver.fleet(configs))
    driver = Driver(transport, configs, speed=10.0, period=5.0).start()
    master = Watcher(broker.url, ("nothing/#",))
    try:
        with caplog.at_level(logging.WARNING, logger="vcran.mqtt"):
            assert wait_until(lambda: transport.connected == 1)
            for payload in (b"not json", b"{", b"\xff\xfe{}", b"[1, 2"):
                master.publish("uagv/v2/vcran/S1/order", payload)
            master.publish("uagv/v2/vcran/S1/instantActions", b"nope")
            assert wait_until(lambda: len(driver.delivered) == 5)
    finally:
        master.close()
        driver.stop()
    for _, inbound in driver.delivered:
        refused = decode(Topic(inbound.attribute), inbound.raw, Version.V2_1_0)
        assert isinstance(refused, Invalid) and refused.problem.startswith("not JSON"), inbound
    assert transport.tally.counts["bad payloads"] == 5
    lines = [r.getMessage() for r in caplog.records if "not JSON" in r.getMessage()]
    assert len(lines) == 2 and any("/order" in line for line in lines) and any("/instantActions" in line for line in lines)


def test_oversized_payloads_are_dropped_and_reported(broker):
    configs = {"r1": config("S1")}
    transport = MqttTransport(parse_url(broker.url), Driver.fleet(configs), MqttOptions(max_payload=100))
    driver = Driver(transport, configs, speed=10.0, period=5.0).start()
    master = Watcher(broker.url, ("nothing/#",))
    try:
        assert wait_until(lambda: transport.connected == 1)
        master.publish("uagv/v2/vcran/S1/order", orjson.dumps({"pad": "x" * 200}))
        master.publish("uagv/v2/vcran/S1/order", b"{}")
        assert wait_until(lambda: len(driver.delivered) == 1)
    finally:
        master.close()
        driver.stop()
    assert driver.delivered[0][1].raw == "{}"
    assert transport.tally.counts["oversized payloads"] == 1


def _cut(transport: MqttTransport, robot: str) -> None:
    """End ``robot``'s connection without an MQTT DISCONNECT, as a cable pulled or a crash would."""
    transport.client(robot).socket().shutdown(socket.SHUT_RDWR)


def test_last_will_connectionbroken_is_retained_when_the_connection_breaks(broker):
    """§6.14: "When connection between the AGV and the broker stops unexpectedly, the broker will send the
    last will topic ... CONNECTIONBROKEN"; "All messages on this topic shall be sent with a retained flag";
    QoS 1. Its headerId follows ONLINE's (0), its timestamp when it was set (simulated time 0)."""
    configs = {"r1": config("S1")}
    options = MqttOptions(backoff_start=60.0, backoff_cap=60.0)  # stays away: the will stays the retained message
    transport = MqttTransport(parse_url(broker.url), Driver.fleet(configs), options)
    transport.open()
    topic = "uagv/v2/vcran/S1/connection"
    try:
        _cut(transport, "r1")
        assert wait_until(lambda: retained(broker.url, (topic,))[topic].doc["connectionState"] == "CONNECTIONBROKEN")
        will = retained(broker.url, (topic,))[topic]
        assert will.retain and will.qos == 1
        assert will.doc["headerId"] == 1 and will.doc["timestamp"].startswith("1970-01-01T00:00:00.")
        _valid(will, Version.V2_1_0)
    finally:
        transport.close()
    assert retained(broker.url, (topic,))[topic].doc["connectionState"] == "CONNECTIONBROKEN"  # nothing to say OFFLINE


def test_a_broken_connection_reconnects_and_sends_what_was_held(broker):
    """After the will, the vehicle reconnects on its own: ONLINE with the next headerId (2), then the latest
    state it produced while away; the run went on meanwhile."""
    configs = {"r1": config("S1")}
    options = MqttOptions(backoff_start=2.0, backoff_cap=2.0)
    transport = MqttTransport(parse_url(broker.url), Driver.fleet(configs), options)
    transport.open()
    watcher = Watcher(broker.url, ("uagv/v2/vcran/S1/connection", "uagv/v2/vcran/S1/state"))
    driver = Driver(transport, configs, speed=20.0, period=0.5).start()
    try:
        assert wait_until(lambda: len(watcher.of("state")) >= 2)
        _cut(transport, "r1")
        assert wait_until(lambda: driver.count("state", up=False) >= 2)  # the simulation goes on while away
        assert wait_until(lambda: len(watcher.of("connection")) >= 3)
        assert wait_until(lambda: watcher.of()[-1].kind == "state")
    finally:
        driver.stop()
        watcher.close()
    states = [(s.kind, s.doc.get("connectionState"), s.doc["headerId"]) for s in watcher.of()]
    connection = [(c, h) for k, c, h in states if k == "connection"]
    assert connection[:3] == [("ONLINE", 0), ("CONNECTIONBROKEN", 1), ("ONLINE", 2)]
    back = states.index(("connection", "ONLINE", 2))
    before = [h for k, _, h in states[:back] if k == "state"]
    after = [h for k, _, h in states[back + 1:] if k == "state"]
    held = [h for r, t, h, _, up in driver.produced if t == "state" and not up]
    # the first state after ONLINE is the last one produced while away; the ones before it are dropped
    assert after[0] == max(held) and not set(held[:-1]) & set(before + after)
    assert after == list(range(after[0], after[0] + len(after)))


def test_hundred_vehicles_connect_publish_and_say_offline(broker):
    """One connection per vehicle (a last will each): 100 vehicles come ONLINE, each publishes its factsheet,
    3 states and 3 visualizations, and goes OFFLINE; a watcher counts every message."""
    configs = {f"r{i:03d}": config(f"S{i:03d}") for i in range(100)}
    watcher = Watcher(broker.url, ("uagv/#",))
    transport = MqttTransport(parse_url(broker.url), Driver.fleet(configs))
    transport.open(timeout=30)
    assert transport.connected == 100
    driver = Driver(transport, configs, speed=10.0, period=1.0).start()
    try:
        assert wait_until(lambda: driver.count("state") >= 300, timeout=60)
    finally:
        driver.stop()
    produced = {t: driver.count(t) for t in ("factsheet", "state", "visualization")}
    assert produced["factsheet"] == 100 and produced["state"] >= 300
    assert wait_until(lambda: len(watcher.of("connection")) == 200, timeout=30)
    assert wait_until(lambda: len(watcher.of("state")) == produced["state"], timeout=30)
    counts = {t: len(watcher.of(t)) for t in ("factsheet", "state", "visualization")}
    watcher.close()
    assert counts == produced
    states = sorted(s.doc["connectionState"] for s in watcher.of("connection"))
    assert states == ["OFFLINE"] * 100 + ["ONLINE"] * 100
    assert transport.counts["dropped"] == 0


def test_an_unreachable_broker_fails_open_clearly_and_leaves_nothing_running():
    """No broker at the URL: open() names the URL and the reason, and every connection thread is gone."""
    from tests.transports.mqtt.mosquitto import free_port

    before = threading.active_count()
    url = parse_url(f"mqtt://127.0.0.1:{free_port()}")
    transport = MqttTransport(url, Driver.fleet({"r1": config("S1"), "r2": config("S2")}),
                              MqttOptions(backoff_start=0.05, backoff_cap=0.1))
    with pytest.raises(MqttUnavailable, match=rf"^{url}: 2 of 2 connections after 0.5 s \(cannot reach the broker"):
        transport.open(timeout=0.5)
    transport.close()
    assert threading.active_count() == before


def test_the_transport_refuses_what_is_not_a_vehicle_s_to_publish():
    """A bug in the glue, said at once: connection is the edge's own (§6.14), order is the master's."""
    configs = {"r1": config("S1")}
    transport = MqttTransport(parse_url("mqtt://127.0.0.1"), Driver.fleet(configs))
    logic = Vehicle(configs["r1"])
    with pytest.raises(ValueError, match="owns connection"):
        transport.send(Publish(0.0, "r1", "connection", logic.connection(0.0, ConnectionState.ONLINE)))
    with pytest.raises(ValueError, match="not 'order'"):
        transport.send(Publish(0.0, "r1", "order", logic.factsheet(0.0)))
    with pytest.raises(ValueError, match="no vehicle 'r9'"):
        transport.send(Publish(0.0, "r9", "state", logic.factsheet(0.0)))
    with pytest.raises(TypeError, match="LiveEnvironment"):
        transport.attach(simpy.Environment(), lambda _: None)
    transport.close()


def test_a_broker_that_refuses_the_vehicles_fails_open_with_its_reason(brokers):
    """A broker that takes no anonymous clients: open() says the broker refused, and why (CONNACK's code)."""
    closed = brokers(anonymous=False)
    transport = MqttTransport(parse_url(closed.url), Driver.fleet({"r1": config("S1")}),
                              MqttOptions(backoff_start=0.05, backoff_cap=0.1))
    with pytest.raises(MqttUnavailable, match=r"not connected after 2 s \(the broker refused the connection: "
                                              r"Not authorized\)"):
        transport.open(timeout=2)
    transport.close()
