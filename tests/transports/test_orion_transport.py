"""The Orion transport's own logic, with httpx.MockTransport in place of Orion (no sockets for Orion).

These are the review's findings turned into tests: every ran_error is delivered, Orion's 4xx does not
block the fleet, a transient failure does not leak subscriptions, a stale read never overtakes a
notification, a busy notification port is a clear error, and a worker outlives a bug.
"""

from __future__ import annotations

import json
import logging
import socket
import threading
import time

import httpx
import numpy as np

from tests.conftest import ROOT
from transports.orion.client import OrionClient
from transports.orion.transport import LiveOptions, OrionTransport, _resilient
from vcran.cli import main
from vcran.core.build import motion
from vcran.core.codec import encode_attribute
from vcran.core.messages import RanError
from vcran.core.wire import Frame, Publish
from vcran.sim.live import LiveEnvironment

ROBOTS = ("robot_1", "robot_2")


class FakeOrion:
    """Answers like Orion for what the transport uses; records the batch updates it receives."""

    def __init__(self, update_status: int = 204) -> None:
        self.updates: list[dict] = []
        self.subscriptions: list[str] = []
        self.deleted: list[str] = []
        self.update_status = update_status
        self.fail_next_subscription_check = False
        self.lock = threading.Lock()

    def __call__(self, request: httpx.Request) -> httpx.Response:
        with self.lock:
            path = request.url.path
            if path == "/v2/op/update":
                if self.update_status != 204:
                    return httpx.Response(self.update_status, json={"error": "BadRequest", "description": "no"})
                self.updates.append(json.loads(request.content))
                return httpx.Response(204)
            if path == "/v2/subscriptions" and request.method == "POST":
                sid = f"s{len(self.subscriptions)}"
                self.subscriptions.append(sid)
                return httpx.Response(201, headers={"Location": f"/v2/subscriptions/{sid}"})
            if path.startswith("/v2/subscriptions/"):
                sid = path.rsplit("/", 1)[1]
                if request.method == "DELETE":
                    self.deleted.append(sid)
                    return httpx.Response(204)
                if self.fail_next_subscription_check:
                    self.fail_next_subscription_check = False
                    return httpx.Response(503)
                return httpx.Response(200, json={"id": sid})
            return httpx.Response(200, json=[])


def transport(orion: FakeOrion, **options) -> OrionTransport:
    client = OrionClient("http://orion.test", transport=httpx.MockTransport(orion))
    return OrionTransport(client, LiveOptions("ROBOT", ROBOTS, **options))


def error(count: int) -> RanError:
    return RanError(code=f"e{count}", message="m", count=count)


def frame(t: float) -> Frame:
    return Frame(t, ROBOTS, np.zeros((2, 5)))


def test_every_ran_error_of_a_tick_is_delivered_in_order():
    orion = FakeOrion()
    t = transport(orion)
    for n in (1, 2, 3):
        t.send(Publish(0.5, "robot_1", "ran_error", error(n)))
    t.send(Publish(0.5, "robot_2", "ran_error", error(9)))
    t.send(frame(1.0))
    assert t._deliver_pending()
    errors = [(e["id"], e["ran_error"]["value"]["count"]["value"])
              for body in orion.updates for e in body["entities"] if "ran_error" in e]
    assert errors == [("robot_1", 1), ("robot_2", 9), ("robot_1", 2), ("robot_1", 3)]
    assert all("current_motion" in e for e in orion.updates[0]["entities"])  # one state round
    assert len(orion.updates) == 3  # the tick's batch, then one round per further error of robot_1


def test_orion_refusing_a_batch_drops_it_and_does_not_block_the_next(caplog):
    orion = FakeOrion(update_status=400)
    t = transport(orion)
    t.send(frame(1.0))
    with caplog.at_level(logging.WARNING, logger="vcran.orion"):
        assert t._deliver_pending()  # dropped, not given back
    assert not t.outbox.take()
    assert "refused" in caplog.text
    orion.update_status = 204
    t.send(frame(2.0))
    assert t._deliver_pending() and len(orion.updates) == 1


def test_transient_keepalive_failure_keeps_the_subscription():
    orion = FakeOrion()
    t = transport(orion, notify_url="http://127.0.0.1:0/notify", keepalive=0.05, backoff_start=0.05)
    t._env = LiveEnvironment(10)
    keeper = threading.Thread(target=t._subscription_loop, daemon=True)
    keeper.start()
    try:
        deadline = time.monotonic() + 5
        while not orion.subscriptions and time.monotonic() < deadline:
            time.sleep(0.01)
        orion.fail_next_subscription_check = True  # one 503: not a reason to subscribe again
        time.sleep(0.5)
    finally:
        t._stop.set()
        keeper.join(5)
    assert orion.subscriptions == ["s0"]
    t._listener = None
    t.close()
    assert orion.deleted == ["s0"]


def test_a_read_started_before_a_notification_does_not_revert_its_value():
    t = transport(FakeOrion())
    env = t._env = LiveEnvironment(10)
    old = encode_attribute("motion_assignment", motion("T", "T_m1", 1, 2, 1, 0))
    new = encode_attribute("motion_assignment", motion("T", "T_m1", 1, 2, 5, 5))  # R10 replacement
    snapshot = dict(t._forwarded)  # a read starts ...
    t._forward([{"id": "robot_1", "motion_assignment": new}], 0.0)  # ... a notification arrives ...
    t._forward([{"id": "robot_1", "motion_assignment": old}], 0.0, unchanged_since=snapshot)  # ... read ends
    assert t._last[("robot_1", "motion_assignment")] == new
    assert env._calls.qsize() == 1
    t._forward([{"id": "robot_9", "motion_assignment": old}], 0.0)  # not ours: not remembered either
    assert ("robot_9", "motion_assignment") not in t._last


def test_busy_notification_port_is_a_clear_error(tmp_path, capsys):
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        port = busy.getsockname()[1]
        code = main(["live", str(ROOT / "scenarios" / "demo.toml"), "--orion", "http://127.0.0.1:9", "--out", str(tmp_path / "o"),
                     "--notify-url", f"http://127.0.0.1:{port}/notify", "--quiet"])
    assert code == 2
    assert "cannot listen for notifications" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()  # nothing half-written


def test_worker_loop_outlives_an_unexpected_error(caplog):
    calls = []
    stop = threading.Event()

    def loop():
        calls.append(1)
        if len(calls) == 1:
            raise KeyError("a bug")

    with caplog.at_level(logging.ERROR, logger="vcran.orion"):
        _resilient("test", loop, stop)()  # first call raises, is logged, then the loop runs again
    assert len(calls) == 2 and "unexpected error" in caplog.text


def test_ran_status_lists_at_most_fifty_queued_tasks_and_counts_all():
    from vcran.core.ranlogic import QUEUE_SHOWN, RanLogic

    logic = RanLogic("r")
    for i in range(120):
        logic.on_motion(i, motion(f"T{i}", f"T{i}_m", 1, 2, 1, 0))
    status = logic.ran_status()
    assert len(status.queue) == QUEUE_SHOWN == 50 and status.queued == 120
    assert status.queue[0].description == "T0"
