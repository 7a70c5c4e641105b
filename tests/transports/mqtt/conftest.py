"""The MQTT edge's tests run against a real Mosquitto (tests/transports/mqtt/mosquitto.py says where it
comes from and when they are skipped); never a mock."""

from __future__ import annotations

from collections.abc import Callable, Iterator

import pytest

from tests.transports.mqtt.mosquitto import Mosquitto, in_ci, unavailable


@pytest.fixture
def brokers(tmp_path) -> Iterator[Callable[..., Mosquitto]]:
    """Start Mosquittos (``brokers(anonymous=False)``: one that refuses anonymous clients); all stopped after."""
    reason = unavailable()
    if reason is not None:
        if in_ci():
            pytest.fail(f"CI runs the MQTT tests against Mosquitto (docs/contract.md §11), but {reason}")
        pytest.skip(f"the MQTT edge's tests need a broker: {reason}")
    started: list[Mosquitto] = []

    def start(**kwargs: bool) -> Mosquitto:
        folder = tmp_path / f"mosquitto-{len(started)}"
        folder.mkdir()
        server = Mosquitto(folder, **kwargs)
        started.append(server)
        server.start()
        return server

    try:
        yield start
    finally:
        for server in started:
            server.stop()


@pytest.fixture
def broker(brokers) -> Mosquitto:
    """A fresh Mosquitto per test: retained messages of one test never reach another."""
    return brokers()
