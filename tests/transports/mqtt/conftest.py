"""The MQTT edge's tests run against a real Mosquitto (tests/transports/mqtt/mosquitto.py says where it
comes from and when they are skipped); never a mock."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from tests.transports.mqtt.mosquitto import Mosquitto, in_ci, unavailable


@pytest.fixture
def broker(tmp_path) -> Iterator[Mosquitto]:
    """A fresh Mosquitto per test: retained messages of one test never reach another."""
    reason = unavailable()
    if reason is not None:
        if in_ci():
            pytest.fail(f"CI runs the MQTT tests against Mosquitto (SPEC §11), but {reason}")
        pytest.skip(f"the MQTT edge's tests need a broker: {reason}")
    server = Mosquitto(tmp_path)
    server.start()
    try:
        yield server
    finally:
        server.stop()
