"""Addressing of VDA 5050 over MQTT without a broker: broker URLs, topic levels (§6.3), QoS and retained
flags (§6.2, §6.14, §6.15) and the connection topic's headerIds (§6.4, §6.14)."""

from __future__ import annotations

from dataclasses import replace

import orjson
import pytest

import vcran
from tests.transports.mqtt.support import config
from transports.mqtt.connection import ConnectionTopic
from transports.mqtt.topics import (
    DELIVERY,
    BrokerUrl,
    FleetVehicle,
    MqttUrlError,
    VehicleAddress,
    check_fleet,
    parse_topic,
    parse_url,
)
from vcran.core.vda5050.enums import Topic, Version
from vcran.core.vda5050.fleet import vehicle_config


@pytest.mark.parametrize(("text", "host", "port"), [
    ("mqtt://localhost", "localhost", 1883),  # 1883: MQTT's registered port
    ("mqtt://127.0.0.1:18830", "127.0.0.1", 18830),
    ("MQTT://Broker.example:1883/", "broker.example", 1883),
    ("mqtt://[::1]:1884", "::1", 1884),
])
def test_broker_urls(text, host, port):
    assert parse_url(text) == BrokerUrl(host, port)


def test_an_ipv6_broker_url_prints_with_brackets():
    assert str(parse_url("mqtt://[::1]")) == "mqtt://[::1]:1883"


@pytest.mark.parametrize(("text", "says"), [
    ("mqtts://broker:8883", "TLS (mqtts://) is not supported"),
    ("tcp://broker:1883", "the scheme must be mqtt://"),
    ("http://broker", "the scheme must be mqtt://"),
    ("broker:1883", "the scheme must be mqtt://"),
    ("mqtt://user:secret@broker", "credentials in the URL are not supported"),
    ("mqtt://broker:99999", "not a valid URL"),
    ("mqtt://broker:port", "not a valid URL"),
    ("mqtt://broker:0", "port 0"),
    ("mqtt://", "no host"),
    ("mqtt://broker/topic", "a path, query or fragment"),
    ("mqtt://broker?x=1", "a path, query or fragment"),
    ("mqtt://bro ker", "white space"),
    ("", "empty URL"),
])
def test_bad_broker_urls_say_what_is_wrong_in_one_line(text, says):
    with pytest.raises(MqttUrlError) as caught:
        parse_url(text)
    message = str(caught.value)
    assert says in message and "\n" not in message and message.startswith(repr(text))


def test_topic_levels_follow_section_6_3():
    """§6.3's example: uagv/v2/KIT/0001/order."""
    address = VehicleAddress("uagv", "v2", "KIT", "0001")
    assert address.topic(Topic.ORDER) == "uagv/v2/KIT/0001/order"
    assert parse_topic("uagv/v2/KIT/0001/instantActions") == (address, Topic.INSTANT_ACTIONS)
    for text in ("uagv/v2/KIT/0001", "uagv/v2/KIT/0001/orders", "a/uagv/v2/KIT/0001/order", "uagv/v2/KIT//order"):
        assert parse_topic(text) is None, text


@pytest.mark.parametrize("bad", ["a/b", "a+", "#", "$SYS", "", "nul\0"])
def test_a_topic_level_refuses_what_mqtt_or_section_6_3_forbids(bad):
    """§6.3: "the / character ... shall not be used"; "The $ character ... should not be used either";
    + and # are MQTT's wildcards."""
    with pytest.raises(ValueError, match="serialNumber"):
        VehicleAddress("uagv", "v2", "KIT", bad)


def test_delivery_as_section_6_2_6_14_and_6_15_say():
    """§6.2: "QoS level 0 ... for the topics order, instantActions, state, factsheet and visualization. The
    topic connection shall use the QoS level 1"; §6.14 and §6.15: "All messages on this topic shall be sent
    with a retained flag" (connection, factsheet)."""
    qos0 = ("order", "instantActions", "state", "factsheet", "visualization")
    assert {t.value: d.qos for t, d in DELIVERY.items()} == {**dict.fromkeys(qos0, 0), "connection": 1}
    assert sorted(t.value for t, d in DELIVERY.items() if d.retain) == ["connection", "factsheet"]


def test_a_fleet_vehicle_comes_from_the_vehicle_s_config():
    vehicle = FleetVehicle.of("r1", config("0001", Version.V2_0_0, manufacturer="KIT"), "agv")
    assert (str(vehicle.address), vehicle.version) == ("agv/v2/KIT/0001", Version.V2_0_0)


def test_a_fleet_has_one_robot_per_id_and_per_topic():
    a = FleetVehicle.of("r1", config("S1"))
    with pytest.raises(ValueError, match="'r1' is listed twice"):
        check_fleet([a, FleetVehicle.of("r1", config("S2"))])
    with pytest.raises(ValueError, match="'r1' and 'r2' share the topics uagv/v2/vcran/S1"):
        check_fleet([a, FleetVehicle.of("r2", config("S1"))])
    assert check_fleet([a, FleetVehicle.of("r2", config("S1"), "other")]).keys() == {"r1", "r2"}
    with pytest.raises(ValueError, match="no vehicle"):
        check_fleet([])


def test_connection_header_ids_count_without_gaps_in_the_order_a_subscriber_sees():
    """§6.4: headerId "incremented by 1 with each sent ... message", per topic; §6.14: the will is set when
    connecting. By hand: attempt 1 sets the will 1 and sends ONLINE 0; the connection breaks (the broker
    sends will 1); a failed attempt sets will 3; the next sets will 3 again and sends ONLINE 2; a graceful
    close sends OFFLINE 3 (the will's id: the broker drops the will)."""
    now = [0.0]
    topic = ConnectionTopic(FleetVehicle.of("r1", config("S1")), lambda: now[0])

    def read(payload: bytes) -> tuple[str, int, str]:
        doc = orjson.loads(payload)
        return doc["connectionState"], doc["headerId"], doc["timestamp"]

    assert topic.will()[0] == "uagv/v2/vcran/S1/connection"
    assert read(topic.will()[1])[:2] == ("CONNECTIONBROKEN", 1)
    assert read(topic.online())[:2] == ("ONLINE", 0)
    now[0] = 12.5
    assert read(topic.will()[1]) == ("CONNECTIONBROKEN", 3, "1970-01-01T00:00:12.50Z")
    assert read(topic.will()[1])[:2] == ("CONNECTIONBROKEN", 3)
    assert read(topic.online())[:2] == ("ONLINE", 2)
    assert read(topic.offline())[:2] == ("OFFLINE", 3)


def test_the_connection_topic_is_on_the_scenarios_calendar():
    """The edge stamps connection messages on the vehicle's calendar, which ``vcran live --mqtt`` takes from the
    scenario (``vehicle_config(robot, settings)``, as the simulation's vehicles and a master do): ONLINE before
    the run, at simulated 0, is the epoch itself; a will set at 12.5 s is 12.5 s later (by hand)."""
    scenario = vcran.load_scenario("vda5050")
    dated = replace(scenario.settings, epoch="2026-11-27T21:30:00.123Z")
    now = [0.0]
    topic = ConnectionTopic(FleetVehicle.of("robot_1", vehicle_config(scenario.robots[0], dated)), lambda: now[0])
    assert orjson.loads(topic.online())["timestamp"] == "2026-11-27T21:30:00.12Z"
    now[0] = 12.5
    assert orjson.loads(topic.will()[1])["timestamp"] == "2026-11-27T21:30:12.62Z"
