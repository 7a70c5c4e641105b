"""The MQTT edge's tests run against a real Mosquitto (tests/transports/mqtt/mosquitto.py says where it
comes from and when they are skipped); never a mock."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from tests.transports.mqtt.mosquitto import Mosquitto, in_ci, unavailable
from tests.transports.mqtt.support import LiveRun


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


@pytest.fixture
def live_fleet(tmp_path) -> Iterator[Callable[..., LiveRun]]:
    """Start ``vcran live SCENARIO --mqtt URL`` processes: ``live_fleet(url, scenario, *vehicles, factor=F)``
    returns once each vehicle (``uagv/v2/<manufacturer>/<serial>``) is retained ONLINE; every one still
    running gets SIGTERM after the test (its run folder in ``tmp_path``)."""
    started: list[LiveRun] = []

    def start(url: str, scenario: Path | str, *vehicles: str, factor: float = 1.0) -> LiveRun:
        run = LiveRun(url, scenario, tmp_path / f"live-{len(started)}", factor=factor)
        started.append(run)
        run.wait_online(*vehicles)
        return run

    try:
        yield start
    finally:
        for run in started:
            run.stop()
