"""The broker goes away and comes back on the same port (docs/contract.md §11: "reconnect with back-off, the simulation
goes on, nothing the vehicles publish while it is down corrupts a run"), against a real Mosquitto."""

from __future__ import annotations

from tests.transports.mqtt.support import Driver, Watcher, config, wait_until
from transports.mqtt import MqttOptions, MqttTransport, parse_url


def test_a_broker_restart_loses_nothing_that_matters_and_stalls_nothing(broker):
    """While Mosquitto is down the simulated clock goes on and the vehicles keep producing; visualization
    produced meanwhile is dropped, only each vehicle's latest state is kept, and it is the first state the
    master gets after the vehicle's ONLINE once the broker is back (no state twice, none stale).

    Order of events, made certain without timing anything: the vehicles retry every 3 s; the broker is
    started again only after a retry failed, and the watcher subscribes at once, long before the next
    retry, so it sees everything the vehicles send on their return."""
    configs = {"r1": config("S1"), "r2": config("S2")}
    transport = MqttTransport(parse_url(broker.url), Driver.fleet(configs), MqttOptions(backoff_start=3.0, backoff_cap=3.0))
    transport.open()
    driver = Driver(transport, configs, speed=20.0, period=0.5).start()
    try:
        assert wait_until(lambda: driver.count("state") >= 6)
        broker.stop()
        assert wait_until(lambda: transport.connected == 0)
        down_at = driver.env.now
        assert wait_until(lambda: all(transport.client(r).failures >= 1 for r in configs))
        assert wait_until(lambda: driver.count("state", up=False) >= 4)
        assert driver.env.now > down_at  # the simulation did not wait for the broker
        broker.start()
        watcher = Watcher(broker.url, ("uagv/#",))
        assert wait_until(lambda: transport.connected == 2, timeout=30)
        assert wait_until(lambda: len(watcher.of("state")) >= 6)
    finally:
        driver.stop()
    watcher.close()
    for robot, prefix in (("r1", "uagv/v2/vcran/S1/"), ("r2", "uagv/v2/vcran/S2/")):
        seen = [s for s in watcher.of() if s.topic.startswith(prefix)]
        # ONLINE with headerId 2: 0 was the first ONLINE, 1 the will that went down with the broker
        assert (seen[0].kind, seen[0].doc["connectionState"], seen[0].doc["headerId"]) == ("connection", "ONLINE", 2)
        away = {t: [h for r, k, h, _, up in driver.produced if r == robot and k == t and not up]
                for t in ("state", "visualization")}
        states = [s.doc["headerId"] for s in seen if s.kind == "state"]
        assert states[0] == away["state"][-1]  # the latest state produced while away, first after ONLINE
        assert states == list(range(states[0], states[0] + len(states)))  # then every one, in order
        assert not set(away["visualization"]) & {s.doc["headerId"] for s in seen if s.kind == "visualization"}
        assert seen[1].kind == "state"  # nothing of the outage before it: no visualization held
    assert transport.counts["dropped"] >= sum(1 for p in driver.produced if p[1] == "visualization" and not p[4])
