"""The broker's HTTP shell and notifier over real loopback sockets: restart on the same port, delivery
order, failing and slow listeners, and the ``vcran broker`` command."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Iterator

import httpx
import pytest
from broker_support import Listener, raw_request

from vcran.broker import BrokerHandle, start_broker
from vcran.broker.server import DISCARD_LIMIT


@pytest.fixture
def broker() -> Iterator[BrokerHandle]:
    with start_broker() as handle:
        yield handle


@pytest.fixture
def listener() -> Iterator[Listener]:
    listener = Listener()
    yield listener
    listener.stop()


def subscribe(client: httpx.Client, url: str) -> str:
    body = {"subject": {"entities": [{"idPattern": ".*"}]}, "notification": {"http": {"url": url}}}
    response = client.post("/v2/subscriptions", json=body)
    assert response.status_code == 201
    return response.headers["Location"].rsplit("/", 1)[1]


def test_restart_on_the_same_port_starts_empty_and_old_clients_reconnect() -> None:
    first = start_broker()
    client = httpx.Client(base_url=first.url)
    assert client.post("/v2/entities", json={"id": "r1", "type": "ROBOT"}).status_code == 201
    assert client.get("/v2/entities/r1").status_code == 200  # keeps a pooled connection open
    first.stop()
    with pytest.raises(httpx.ConnectError):
        client.get("/v2/entities/r1")
    with start_broker(port=first.port) as second:
        assert second.url == first.url
        assert client.get("/v2/entities/r1").status_code == 404
    first.stop()  # stopping twice is harmless
    client.close()


def test_notifications_of_one_subscription_arrive_in_order(broker: BrokerHandle, listener: Listener) -> None:
    with httpx.Client(base_url=broker.url) as client:
        subscribe(client, listener.url)
        client.post("/v2/entities", json={"id": "r1", "type": "ROBOT", "seq": {"value": 0}})
        for seq in range(1, 30):
            assert client.patch("/v2/entities/r1/attrs", json={"seq": {"value": seq}}).status_code == 204
    assert broker.wait_notifications(timeout=10)
    seqs = [httpx.Response(200, content=n.body).json()["data"][0]["seq"]["value"] for n in listener.take()]
    assert seqs == list(range(30))


def test_an_unreachable_listener_is_counted_in_fails_counter(broker: BrokerHandle) -> None:
    dead = Listener()
    dead.stop()  # nothing listens on its port any more
    with httpx.Client(base_url=broker.url) as client:
        subscription = subscribe(client, dead.url)
        assert client.post("/v2/entities", json={"id": "r1", "a": {"value": 1}}).status_code == 201
        assert broker.wait_notifications(timeout=10)
        shown = client.get(f"/v2/subscriptions/{subscription}").json()
        assert shown["status"] == "active"  # Orion 4.7 has no "failed" status (orion-api.md)
        assert shown["notification"]["lastFailureReason"] == "Couldn't connect to server"
        assert shown["notification"]["failsCounter"] == 1  # Orion's count of consecutive failures
        assert client.patch("/v2/entities/r1/attrs", json={"a": {"value": 2}}).status_code == 204
        assert broker.wait_notifications(timeout=10)
        assert client.get(f"/v2/subscriptions/{subscription}").json()["notification"]["failsCounter"] == 2
        assert client.get("/version").status_code == 200  # and the broker carries on


def test_a_slow_listener_does_not_hold_up_requests(broker: BrokerHandle) -> None:
    release = threading.Event()
    slow = Listener(gate=release)
    try:
        with httpx.Client(base_url=broker.url) as client:
            subscribe(client, slow.url)
            started = time.monotonic()
            for i in range(5):
                assert client.post("/v2/entities", json={"id": f"r{i}", "a": {"value": i}}).status_code == 201
            assert time.monotonic() - started < 2
            assert not broker.wait_notifications(timeout=0.1)
        release.set()
        assert broker.wait_notifications(timeout=5)
        assert len(slow.take()) == 5
    finally:
        release.set()
        slow.stop()


def test_bodies_that_are_not_read(broker: BrokerHandle) -> None:
    too_big = raw_request(
        broker.port,
        f"POST /v2/entities HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\nContent-Length: {DISCARD_LIMIT + 1}",
        b"{}",
    )
    assert too_big.status == 413 and too_big.headers["connection"] == "close"
    no_length = raw_request(broker.port, "PUT /v2/entities/r1/attrs HTTP/1.1\r\nHost: x", b'{"a": {"value": 1}}')
    assert no_length.status == 411
    assert httpx.get(f"{broker.url}/version").status_code == 200


def test_vcran_broker_command_prints_its_url_and_stops_on_sigterm() -> None:
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    # The command module on its own: vcran.cli would import every other subcommand too.
    code = (
        "import argparse, sys; from vcran.commands import broker; parser = argparse.ArgumentParser(); "
        "broker.add_arguments(parser); sys.exit(broker.run(parser.parse_args(sys.argv[1:])))"
    )
    process = subprocess.Popen([sys.executable, "-c", code, "--port", "0"], stdout=subprocess.PIPE, text=True, env=env)
    try:
        assert process.stdout is not None
        line = process.stdout.readline()
        assert "in memory only" in line
        url = line.split()[4]
        assert httpx.get(f"{url}/version").json()["orion"]["version"] == "4.7.0"
        process.send_signal(signal.SIGTERM)
        assert process.wait(timeout=10) == 0
    finally:
        process.kill()


def test_vcran_broker_is_registered_and_its_help_says_data_is_in_memory_only() -> None:
    from vcran.cli import COMMANDS
    from vcran.commands import broker

    assert COMMANDS["broker"] == "broker"
    assert "memory only" in broker.HELP and "lost on exit" in broker.HELP


def test_stop_does_not_wait_for_a_delivery_in_flight() -> None:
    gate = threading.Event()
    stuck = Listener(gate=gate)  # does not answer until the test ends
    broker = start_broker()
    try:
        with httpx.Client(base_url=broker.url) as client:
            subscribe(client, stuck.url)
            assert client.post("/v2/entities", json={"id": "r1", "a": {"value": 1}}).status_code == 201
        deadline = time.monotonic() + 5
        while not stuck.received and time.monotonic() < deadline:
            time.sleep(0.01)
        started = time.monotonic()
        broker.stop()
        assert time.monotonic() - started < 1
    finally:
        broker.stop()
        gate.set()
        stuck.stop()  # answers the delivery the broker left in flight, and joins its handler thread
        for thread in threading.enumerate():  # the delivery's worker ends with it, before the next test
            if thread.name.startswith("vcran-notifier-"):
                thread.join(timeout=10)
                assert not thread.is_alive(), f"{thread.name} outlived its broker"
