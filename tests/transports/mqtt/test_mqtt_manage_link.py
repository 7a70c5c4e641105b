"""``vcran manage --mqtt``'s loop without processes (docs/contract.md §9, §11): :class:`transports.mqtt.manage.MqttLoop`
hosts a Master on a LiveEnvironment against vehicles on a real Mosquitto, vcran's own vehicles' side
(:class:`MqttTransport`, driven by the tests' miniature simulation :class:`Driver`: factsheet at start, then
state and visualization every period)."""

from __future__ import annotations

import logging
import threading
from pathlib import Path

import orjson
import pytest

from tests.transports.mqtt.support import Driver, Watcher, config, wait_until
from transports.mqtt import MqttTransport, MqttUnavailable, parse_url
from transports.mqtt.manage import MqttLoop, MqttMasterLink
from vcran.core.scenario import Scenario
from vcran.core.vda5050.codec import decode, encode
from vcran.core.vda5050.enums import Topic, Version
from vcran.core.vda5050.factsheet import Factsheet
from vcran.core.vda5050.master import Master
from vcran.core.vda5050.state import Connection, State, Visualization
from vcran.io.scenario_file import load
from vcran.sim.live import LiveEnvironment

#: Two vehicles as the scenario and the Driver both name them: robot r1 (serial S1, 2.1.0), r2 (S2, 2.0.0).
CONFIGS = {"r1": config("S1"), "r2": config("S2", Version.V2_0_0)}


def two_vehicles(folder: Path) -> Scenario:
    path = folder / "two.toml"
    path.write_text('[simulation]\nname = "two"\nprotocol = "vda5050"\nduration = 3600.0\n'
                    + "".join(f'[[robots]]\nid = "{robot}"\nmanufacturer = "vcran"\nserial_number = "{c.serial_number}"\n'
                              f'version = "{c.version.value}"\npose = [{2.0 * n}, 0.0, 0.0]\n'
                              for n, (robot, c) in enumerate(CONFIGS.items())))
    return load(path)


class Listener(Master):
    """Keeps what each hook got and in which thread; pauses S2 on its first state."""

    def on_start(self) -> None:
        self.got: list[tuple[str, str, object]] = []
        self.threads: set[int] = set()
        self.paused = ""

    def _got(self, kind: str, serial: str, message: object) -> None:
        self.got.append((kind, serial, message))
        self.threads.add(threading.get_ident())

    def on_state(self, serial: str, state: State) -> None:
        self._got("state", serial, state)
        if serial == "S2" and not self.paused:
            self.paused = self.handle.instant("S2", "startPause")

    def on_connection(self, serial: str, connection: Connection) -> None:
        self._got("connection", serial, connection)

    def on_factsheet(self, serial: str, factsheet: Factsheet) -> None:
        self._got("factsheet", serial, factsheet)

    def of(self, kind: str, serial: str) -> list[object]:
        return [m for k, s, m in self.got if k == kind and s == serial]


def run_until(env: LiveEnvironment, done, limit: float = 600.0) -> None:  # type: ignore[no-untyped-def]
    """Run the loop's environment in this thread until ``done()`` (checked every 0.1 simulated s), ``limit`` at most."""
    end = env.event()

    def check():  # type: ignore[no-untyped-def]
        while not done():
            yield env.timeout(0.1)
        end.succeed()

    env.process(check())
    env.run(until=env.any_of([end, env.timeout(limit)]))


def test_the_master_hears_each_vehicle_validated_in_its_thread_and_sends_in_the_vehicles_version(broker, tmp_path,
                                                                                                caplog):
    """Every topic a fleet vehicle publishes reaches the master decoded and valid, its handle reads it, every
    hook runs in the simulation's thread; what the master sends reaches the vehicle's side encoded in that
    vehicle's version (a 2.0.0 instantActions for S2). A message on a fleet vehicle's topic that does not
    validate is reported once per vehicle and topic and counted, and never reaches the master; one of a
    vehicle outside the fleet likewise (MqttMaster's foreign topics)."""
    url = parse_url(broker.url)
    driver = Driver(MqttTransport(url, Driver.fleet(CONFIGS)), CONFIGS, speed=20.0, period=1.0).start()
    master = Listener()
    env = LiveEnvironment(speed=20.0)
    loop = MqttLoop(two_vehicles(tmp_path), master, lambda *_: None, url)
    watcher = Watcher(broker.url, ("test/publisher",))  # publishes only
    caplog.set_level(logging.WARNING, logger="vcran.mqtt")
    try:
        loop.attach(env, lambda _: None)
        bad = b'{"headerId": 1}'  # a state without its other required fields (the official schema): invalid
        for _ in range(2):
            watcher.publish("uagv/v2/vcran/S1/state", bad)
        watcher.publish("uagv/v2/other/X9/state", bad)

        def heard_all() -> bool:
            link = loop.link
            return (link is not None and link.master.tally.counts["foreign topics"] >= 1
                    and link.master.tally.counts["invalid messages"] >= 2 and len(master.of("state", "S1")) >= 2
                    and all(master.of(kind, s) for kind in ("state", "connection", "factsheet") for s in ("S1", "S2")))

        run_until(env, heard_all)
        assert heard_all()
        assert wait_until(lambda: len(driver.delivered) >= 1)
    finally:
        watcher.close()
        link = loop.link
        if link is not None:
            link.close()
        driver.stop()
    assert master.threads == {threading.get_ident()}  # the simulation's thread: this one
    for serial in ("S1", "S2"):
        states = master.of("state", serial)
        assert all(isinstance(s, State) and s.header.serial_number == serial for s in states)
        assert master.handle.state(serial) == states[-1]  # the handle read it before the hook ran
        connection = master.of("connection", serial)[0]
        assert isinstance(connection, Connection) and connection.connection_state.value == "ONLINE"
    # the pause reached r2's side as 2.0.0 encodes it, byte for byte
    (_, delivered), = [d for d in driver.delivered if d[1].entity == "r2"]
    assert delivered.attribute == "instantActions"
    sent = decode(Topic.INSTANT_ACTIONS, delivered.raw, Version.V2_0_0)
    assert sent.actions[0].action_id == master.paused and delivered.raw == encode(sent, Version.V2_0_0).decode()
    assert orjson.loads(delivered.raw)["version"] == "2.0.0"
    assert link is not None and link.sent == 1 and link.unsent == 0 and link.inbound_idle
    tally = link.master.tally.counts
    assert tally["invalid messages"] == 2 and tally["foreign topics"] == 1
    invalid = [r.getMessage() for r in caplog.records if "invalid state" in r.getMessage()]
    assert len(invalid) == 1 and "required field missing" in invalid[0], invalid  # once, saying what is wrong


class Watching(Listener):
    """:class:`Listener` that hears ``visualization`` too."""

    topics = frozenset({"state", "connection", "factsheet", "visualization"})

    def on_visualization(self, serial: str, visualization: Visualization) -> None:
        self._got("visualization", serial, visualization)


@pytest.mark.parametrize("master", [Listener, Watching])
def test_the_master_is_subscribed_to_visualization_only_if_it_hears_it(broker, tmp_path, master):
    """docs/vda5050.md, "Your own master": a master hears what its ``topics`` list, live as in simulated time.
    The vehicles publish a state and a visualization every period; a master that hears visualization gets
    each vehicle's (its hook, and the handle's reading); one that does not (the default ``topics``) is not
    subscribed to it, so none reaches it, however many states do."""
    url = parse_url(broker.url)
    driver = Driver(MqttTransport(url, Driver.fleet(CONFIGS)), CONFIGS, speed=20.0, period=1.0).start()
    hearing = master()
    loop = MqttLoop(two_vehicles(tmp_path), hearing, lambda *_: None, url)
    try:
        loop.attach(env := LiveEnvironment(speed=20.0), lambda _: None)
        run_until(env, lambda: all(len(hearing.of("state", s)) >= 3 for s in ("S1", "S2")))
    finally:
        if loop.link is not None:
            loop.link.close()
        driver.stop()
    heard = {serial for serial, topic in hearing.handle._latest if topic is Topic.VISUALIZATION}
    if master is Watching:
        assert {s for s in ("S1", "S2") if hearing.of("visualization", s)} == heard == {"S1", "S2"}
    else:
        assert heard == set() and not hearing.hears(Topic.VISUALIZATION)
        assert all(len(hearing.of("state", s)) >= 3 for s in ("S1", "S2"))  # two periods and more went by


def test_a_send_the_broker_did_not_take_is_counted_and_reported_once(brokers, tmp_path, caplog):
    """The broker gone: nothing is queued (a stale order sent on reconnect could do harm); each send is
    counted as not sent, the first per vehicle is reported, the link is idle (nothing on its way)."""
    server = brokers()
    env = LiveEnvironment(speed=1.0)
    vehicles = Driver.fleet(CONFIGS)
    link = MqttMasterLink(env, parse_url(server.url), vehicles, lambda _: None)
    link.open()
    caplog.set_level(logging.WARNING, logger="vcran.mqtt")
    try:
        server.stop()
        assert wait_until(lambda: not link.master.up)
        from vcran.testing.vda5050.plans import pause

        for _ in range(3):
            link.write("r1", "instantActions", pause())
    finally:
        link.close()
    assert (link.sent, link.unsent) == (0, 3) and link.inbound_idle
    reported = [r.getMessage() for r in caplog.records if "not sent" in r.getMessage()]
    assert len(reported) == 1 and "to r1" in reported[0]
    # the end-of-run figure counts them once, as not sent, and not again among the problems a peer caused (no
    # vehicle published anything: nothing heard, no problem)
    assert link.describe() == "0 message(s) sent, 3 not sent (broker down); 0 heard"


def test_an_unreachable_broker_is_an_error_before_any_hook_runs(tmp_path):
    """Nothing listens on the port: MqttUnavailable from attach, and the master's on_start never ran."""
    from tests.transports.mqtt.mosquitto import free_port

    master = Listener()
    loop = MqttLoop(two_vehicles(tmp_path), master, lambda *_: None, parse_url(f"mqtt://127.0.0.1:{free_port()}"),
                    connect_timeout=1.0)
    with pytest.raises(MqttUnavailable):
        loop.attach(LiveEnvironment(), lambda _: None)
    assert not hasattr(master, "got")


def test_a_payload_is_parsed_once_and_one_that_is_not_json_is_counted_once(monkeypatch):
    """The link hears each payload parsed once: the edge's screen parses it and hands the JSON value on to
    decoding (codec.decode_parsed), which does not parse it again. A payload that is not JSON is counted
    once, as a bad payload, not also as an invalid message; JSON that is no connection message (a list) is
    an invalid message. Three payloads arrive as paho hands them over (MqttMaster's callback, no broker
    needed): three parses, one message heard, one bad payload, one invalid message."""
    from transports.mqtt.client import MqttOptions

    env = LiveEnvironment(speed=1.0)
    link = MqttMasterLink(env, parse_url("mqtt://127.0.0.1:1"), Driver.fleet(CONFIGS), lambda _: None,
                          MqttOptions())
    online = orjson.dumps({"headerId": 0, "timestamp": "2026-01-01T00:00:00.00Z", "version": "2.1.0",
                           "manufacturer": "vcran", "serialNumber": "S1", "connectionState": "ONLINE"})
    parsed: list[bytes] = []
    loads = orjson.loads
    monkeypatch.setattr(orjson, "loads", lambda data: parsed.append(data) or loads(data))
    topic = "uagv/v2/vcran/S1/connection"
    try:
        for payload in (online, b"not json", b"[1]"):
            link.master._received(topic, payload)  # paho's on_message, as on the network thread
    finally:
        monkeypatch.undo()
        link.close()
    assert parsed == [online, b"not json", b"[1]"]
    assert dict(link.master.tally.counts) == {"bad payloads": 1, "invalid messages": 1}
    assert link.describe() == "0 message(s) sent, 0 not sent (broker down); 1 heard (1 bad payloads, 1 invalid messages)"
