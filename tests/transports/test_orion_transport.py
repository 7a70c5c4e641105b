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
import pytest

from tests.conftest import ROOT
from tests.transports.test_live import wait_until
from transports.orion.client import OrionClient
from transports.orion.link import LinkOptions
from transports.orion.transport import OrionTransport
from transports.orion.workers import resilient
from vcran.cli import main
from vcran.core.opil.build import motion
from vcran.core.opil.codec import encode_attribute
from vcran.core.opil.messages import AssignmentStatus, RanError, RanStatus
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
        self.checks = 0  # subscription checks answered
        self.lose_subscriptions = False  # answer 404 to a subscription check, as a restarted Orion does
        self.entities: list[dict] = []  # what GET /v2/entities (a poll) answers
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
                self.checks += 1
                if self.fail_next_subscription_check:
                    self.fail_next_subscription_check = False
                    return httpx.Response(503)
                if self.lose_subscriptions:
                    return httpx.Response(404, json={"error": "NotFound", "description": "gone"})
                return httpx.Response(200, json={"id": sid})
            if path == "/v2/entities" and request.method == "GET":
                return httpx.Response(200, json=self.entities)
            return httpx.Response(200, json=[])


def transport(orion: FakeOrion, **options) -> OrionTransport:
    client = OrionClient("http://orion.test", transport=httpx.MockTransport(orion))
    return OrionTransport(client, LinkOptions("ROBOT", ROBOTS, **options))


def error(count: int) -> RanError:
    return RanError(code=f"e{count}", message="m", count=count)


def frame(t: float) -> Frame:
    return Frame(t, ROBOTS, np.zeros((2, 5)))


def delivered_errors(orion: FakeOrion) -> list[tuple[str, int]]:
    return [(e["id"], e["ran_error"]["value"]["count"]["value"])
            for body in orion.updates for e in body["entities"] if "ran_error" in e]


def test_every_ran_error_of_a_tick_is_delivered_in_order_in_one_request():
    # issue 13 item 4: several errors of one robot cost no extra request; each is an element of its own
    orion = FakeOrion()
    t = transport(orion)
    for n in (1, 2, 3):
        t.send(Publish(0.5, "robot_1", "ran_error", error(n)))
    t.send(Publish(0.5, "robot_2", "ran_error", error(9)))
    t.send(frame(1.0))
    assert t.sender.deliver() is None
    assert len(orion.updates) == 1
    assert delivered_errors(orion) == [("robot_1", 1), ("robot_2", 9), ("robot_1", 2), ("robot_1", 3)]
    assert [sorted(e) for e in orion.updates[0]["entities"]] == [
        ["current_motion", "id", "ran_error", "type"], ["current_motion", "id", "ran_error", "type"],
        ["id", "ran_error", "type"], ["id", "ran_error", "type"]]
    assert (t.sender.counts.attempts, t.sender.counts.accepted, t.sender.counts.delivered) == (1, 1, 4)


def test_the_broker_applies_repeated_elements_of_an_entity_in_order_and_notifies_each(tmp_path):
    """What the one-request delivery relies on: Orion applies op/update's elements one by one."""
    from vcran.broker import start_broker

    broker = start_broker(port=0)
    seen: list[int] = []
    from transports.orion.listener import Listener

    listener = Listener("127.0.0.1", 0, "/n", lambda sid, data: seen.extend(
        e["ran_error"]["value"]["count"]["value"] for e in data))
    try:
        client = OrionClient(broker.url)
        client.subscribe({"subject": {"entities": [{"id": "robot_1", "type": "ROBOT"}],
                                      "condition": {"attrs": ["ran_error"]}},
                          "notification": {"http": {"url": f"http://127.0.0.1:{listener.port}/n"},
                                           "attrs": ["ran_error"]}})
        t = OrionTransport(client, LinkOptions("ROBOT", ("robot_1",)))
        for n in (1, 2, 3):
            t.send(Publish(0.5, "robot_1", "ran_error", error(n)))
        assert t.sender.deliver() is None
        deadline = time.monotonic() + 5
        while len(seen) < 3 and time.monotonic() < deadline:
            time.sleep(0.02)
        assert seen == [1, 2, 3]
        stored = httpx.get(f"{broker.url}/v2/entities/robot_1/attrs/ran_error").json()
        assert stored["value"]["count"]["value"] == 3
        client.close()
    finally:
        listener.stop()
        broker.stop()


def test_a_refused_batch_content_drops_its_state_and_retries_its_errors_once(caplog):
    orion = FakeOrion(update_status=400)
    t = transport(orion, backoff_start=0.1, backoff_cap=1.0)
    t.send(Publish(0.5, "robot_1", "assignment_state", AssignmentStatus()))
    t.send(Publish(0.5, "robot_1", "ran_error", error(1)))
    t.send(frame(1.0))
    with caplog.at_level(logging.WARNING, logger="vcran.orion"):
        assert t.sender.deliver() == 0.1  # refused: back off
        pending = t.outbox.take()
        assert pending.state == {} and [e.value.count for e in pending.queued] == [1]
        t.outbox.give_back(pending)
        assert t.sender.deliver() == 0.2  # refused again: the error is reported, not sent a third time
    assert not t.outbox.take().queued
    assert t.sender.counts.undeliverable == 1 and t.sender.counts.refused == 2
    assert "1 ran_error(s) refused 2 times" in caplog.text
    assert sum("Orion refused a batch update" in r.getMessage() for r in caplog.records) == 1  # once per cause
    orion.update_status = 204
    t.send(frame(2.0))
    assert t.sender.deliver() is None and len(orion.updates) == 1  # the next tick is not blocked
    assert "Orion is back" in caplog.text


def test_an_expired_token_keeps_everything_and_backs_off():
    orion = FakeOrion(update_status=401)
    t = transport(orion, backoff_start=0.25, backoff_cap=2.0)
    t.send(Publish(0.5, "robot_2", "ran_status", RanStatus()))
    t.send(Publish(0.5, "robot_1", "ran_error", error(1)))
    t.send(Publish(0.6, "robot_1", "ran_error", error(2)))
    delays = []
    for tick in range(6):
        t.send(frame(float(tick)))
        delays.append(t.sender.deliver())
    assert delays == [0.25, 0.5, 1.0, 2.0, 2.0, 2.0]
    orion.update_status = 204
    assert t.sender.deliver() is None
    assert delivered_errors(orion) == [("robot_1", 1), ("robot_1", 2)]  # kept through the refusals, in order
    (body,) = orion.updates
    assert "ran_status" in body["entities"][1] and body["entities"][0]["current_motion"]  # state kept too
    assert t.sender.counts.undeliverable == 0


def test_errors_still_waiting_when_live_stops_are_reported_undeliverable(caplog):
    orion = FakeOrion(update_status=503)
    t = transport(orion)
    t.send(Publish(0.5, "robot_1", "ran_error", error(1)))
    t.send(Publish(0.6, "robot_2", "ran_error", error(2)))
    with caplog.at_level(logging.WARNING, logger="vcran.orion"):
        t.close()  # one last attempt, refused: said and counted, not silently lost
    assert "2 ran_error(s) not delivered: batch update: Orion answered 503" in caplog.text
    assert t.sender.counts.undeliverable == 2 and t.sender.counts.attempts == 1
    assert "2 undeliverable" in t.status()


def test_retry_after_is_honoured_and_capped():
    from transports.orion.client import retry_after
    from transports.orion.health import Backoff

    backoff = Backoff(0.25, 5.0)
    assert backoff.next(3.0) == 3.0 and backoff.next(None) == 0.5 and backoff.next(0.1) == 1.0
    assert backoff.next(3600.0) == 60.0  # a proxy cannot silence the fleet for an hour
    assert retry_after("7") == 7.0 and retry_after(None) is None and retry_after("soon") is None
    assert retry_after("Sun, 22 Nov 2026 20:00:30 GMT", now=1795377600.0) == 30.0
    assert retry_after("Sun, 22 Nov 2026 19:00:00 GMT", now=1795377600.0) == 0.0  # a date in the past


def test_a_failed_body_of_a_split_batch_gives_back_itself_and_the_later_ones():
    robots = tuple(f"robot_{i}" for i in range(3000))  # ~2 MB of current_motion: three bodies
    answers = iter([204, 503])
    sent: list[dict] = []

    def handler(request: httpx.Request) -> httpx.Response:
        status = next(answers, 204)
        if status == 204:
            sent.append(json.loads(request.content))
        return httpx.Response(status)

    client = OrionClient("http://orion.test", transport=httpx.MockTransport(handler))
    t = OrionTransport(client, LinkOptions("ROBOT", robots))
    t.send(Publish(0.5, "robot_2999", "ran_error", error(1)))  # in the last body
    t.send(Frame(1.0, robots, np.zeros((len(robots), 5))))
    assert t.sender.deliver() is not None
    first = [e["id"] for e in sent[0]["entities"]]
    assert 0 < len(first) < len(robots)
    assert t.sender.deliver() is None
    again = [e["id"] for body in sent[1:] for e in body["entities"]]
    assert again == list(robots)  # the frame comes back whole (a same-value write for the first body) ...
    assert delivered_errors(FakeOrionView(sent)) == [("robot_2999", 1)]  # ... and the error exactly once
    assert t.sender.counts.attempts == 2 + len(sent) - 1


class RefusingOrion:
    """Answers every batch update the same way (``mode``) until told otherwise; reads answer []."""

    def __init__(self, mode: str) -> None:
        self.mode = mode
        self.attempts = 0
        self.updates: list[dict] = []
        self.lock = threading.Lock()

    def __call__(self, request: httpx.Request) -> httpx.Response:
        if request.url.path != "/v2/op/update":
            return httpx.Response(200, json=[])
        with self.lock:
            self.attempts += 1
            n, mode = self.attempts, self.mode
        if mode == "204":
            self.updates.append(json.loads(request.content))
            return httpx.Response(204)
        if mode == "401":
            return httpx.Response(401, json={"error": "Unauthorized", "description": "token expired"})
        if mode == "429":
            return httpx.Response(429, headers={"Retry-After": "1"}, json={"error": "TooManyRequests"})
        if n % 2:  # 404-drop: a connection dropped without an answer, then a 404, and again
            raise httpx.RemoteProtocolError("Server disconnected without sending a response.", request=request)
        return httpx.Response(404, json={"error": "NotFound", "description": "no such service"})


def most_requests(elapsed: float, start: float, cap: float, retry_after: float = 0.0) -> int:
    """The most requests a sender that backs off as docs/contract.md §7 says can make in ``elapsed`` wall seconds of an
    Orion refusing each one: the first at once, each next one a delay later (``start`` doubling to ``cap``,
    never shorter than ``retry_after``). Derived from the backoff, not measured: a loaded machine only
    makes fewer, so a bound on the count, not on time, holds however busy the machine is."""
    requests, t, delay = 1, 0.0, start
    while (t := t + max(delay, retry_after) * 0.99) <= elapsed:  # 1 %: a timed wait may end a hair early
        requests, delay = requests + 1, min(delay * 2, cap)
    return requests


#: Each mode's Retry-After (429 asks for 1 s).
RETRY_AFTER = {"401": 0.0, "429": 1.0, "404-drop": 0.0}


@pytest.mark.slow
@pytest.mark.parametrize("mode", ["401", "429", "404-drop"])
def test_a_refusing_orion_gets_a_bounded_number_of_requests_and_every_error_in_the_end(mode, caplog):
    # issue 12 item 1: 40 ticks against an Orion refusing everything; then it accepts again
    orion = RefusingOrion(mode)
    t = OrionTransport(OrionClient("http://orion.test", transport=httpx.MockTransport(orion)),
                       LinkOptions("ROBOT", ROBOTS, backoff_start=0.05, backoff_cap=0.4))
    stop = threading.Event()
    sender = threading.Thread(target=t.sender.loop, args=(stop,), daemon=True)
    with caplog.at_level(logging.WARNING, logger="vcran.orion"):
        began = time.monotonic()
        sender.start()
        for tick in range(40):
            if tick % 4 == 0:
                t.send(Publish(tick / 20, ROBOTS[tick % 8 // 4], "ran_error", error(tick // 4 + 1)))
            t.send(frame(tick / 20))
            time.sleep(0.05)
        during = orion.attempts
        elapsed = time.monotonic() - began
        faults = [r.getMessage() for r in caplog.records]
        orion.mode = "204"
        t.send(frame(2.0))
        assert wait_until(lambda: len(delivered_errors(orion)) >= 10, 30)  # the backoff's next attempt
        stop.set()
        t.sender.release()
        sender.join(5)
    # not one request per tick, let alone the whole fleet each time: never more than the backoff allows
    assert 2 <= during <= most_requests(elapsed, 0.05, 0.4, RETRY_AFTER[mode])
    assert sorted(n for _, n in delivered_errors(orion)) == list(range(1, 11))  # none lost, none twice
    for robot in ROBOTS:
        mine = [n for r, n in delivered_errors(orion) if r == robot]
        assert mine == sorted(mine)  # each robot's in order
    assert t.sender.counts.undeliverable == 0 and t.sender.counts.delivered == 10
    assert len(faults) == (2 if mode == "404-drop" else 1)  # one line per distinct cause


def test_the_sender_wakes_from_its_backoff_when_the_inbound_side_sees_orion_lost_our_data():
    # issue 12 item 2: Orion restarted empty; the subscription keeper notices and asks for a resend
    orion = FakeOrion(update_status=503)
    t = transport(orion, notify_url="http://127.0.0.1:0/notify", keepalive=0.05, backoff_start=600.0, backoff_cap=600.0)
    t._env = LiveEnvironment(10)
    stop = t._stop
    threads = [threading.Thread(target=t.sender.loop, args=(stop,), daemon=True),
               threading.Thread(target=t._keep, args=(0.0,), daemon=True)]
    for thread in threads:
        thread.start()
    try:
        t.send(frame(1.0))
        assert wait_until(lambda: t.outbound.fault is not None, 30)  # the sender now sleeps 600 s
        with orion.lock:
            orion.update_status, orion.lose_subscriptions = 204, True
        assert wait_until(lambda: orion.updates, 60)  # long before its backoff would have ended
    finally:
        stop.set()
        t.sender.release()
        for thread in threads:
            thread.join(5)


class FakeOrionView:
    def __init__(self, updates: list[dict]) -> None:
        self.updates = updates


def test_transient_keepalive_failure_keeps_the_subscription():
    orion = FakeOrion()
    t = transport(orion, notify_url="http://127.0.0.1:0/notify", keepalive=0.05, backoff_start=0.05)
    t._env = LiveEnvironment(10)
    keeper = threading.Thread(target=t._keep, args=(0.0,), daemon=True)
    keeper.start()
    try:
        assert wait_until(lambda: orion.subscriptions, 30)
        orion.fail_next_subscription_check = True  # one 503: not a reason to subscribe again
        assert wait_until(lambda: not orion.fail_next_subscription_check, 30)  # the keeper got its 503 ...
        checks = orion.checks
        assert wait_until(lambda: orion.checks > checks, 30)  # ... and looked again, successfully
    finally:
        t._stop.set()
        keeper.join(5)
    assert orion.subscriptions == ["s0"]
    t.close()
    assert orion.deleted == ["s0"]


def test_a_read_started_before_a_notification_does_not_revert_its_value():
    t = transport(FakeOrion())
    env = t._env = LiveEnvironment(10)
    old = encode_attribute("motion_assignment", motion("T", "T_m1", 1, 2, 1, 0))
    new = encode_attribute("motion_assignment", motion("T", "T_m1", 1, 2, 5, 5))  # R10 replacement
    snapshot = dict(t._handed)  # a read starts ...
    t._take([{"id": "robot_1", "motion_assignment": new}], 0.0)  # ... a notification arrives ...
    t._take([{"id": "robot_1", "motion_assignment": old}], 0.0, since=snapshot)  # ... the read ends
    assert t._last[("robot_1", "motion_assignment")] == new
    assert env._calls.qsize() == 1
    t._take([{"id": "robot_9", "motion_assignment": old}], 0.0)  # not ours: not remembered either
    assert ("robot_9", "motion_assignment") not in t._last


def test_r10_polling_forwards_a_value_once_however_often_it_is_read_again():
    """R10 (docs/rules.md: live transports forward an unchanged attribute value only once): a poll reads
    every robot's command attributes again and again; only a value that differs from the last one read
    goes to the simulation, and each value that goes is one inbound record of the trace
    (transports/record.py), so a quiet fleet's trace does not grow with every poll."""
    orion = FakeOrion()
    t = transport(orion)
    env = t._env = LiveEnvironment(10)
    delivered: list[tuple[str, str, object]] = []
    t._deliver = lambda inbound: delivered.append((inbound.entity, inbound.attribute, inbound.raw))

    def poll() -> int:
        """One poll, its values handed over as the simulation would take them; returns how many went."""
        before = len(delivered)
        t._read()
        while not env._calls.empty():
            env._calls.get_nowait()()
        return len(delivered) - before

    first = encode_attribute("motion_assignment", motion("T", "T_m1", 1, 2, 1, 0))
    second = encode_attribute("motion_assignment", motion("T", "T_m1", 1, 2, 5, 5))  # R10 new content
    orion.entities = [{"id": "robot_1", "type": "ROBOT", "motion_assignment": first}]
    assert [poll() for _ in range(3)] == [1, 0, 0]  # read three times, forwarded once
    orion.entities = [{"id": "robot_1", "type": "ROBOT", "motion_assignment": second}]
    assert [poll() for _ in range(2)] == [1, 0]  # a changed value goes, once
    orion.entities = [{"id": "robot_1", "type": "ROBOT", "motion_assignment": first}]
    assert poll() == 1  # back to the first: a change again from what was read last
    assert delivered == [("robot_1", "motion_assignment", v) for v in (first, second, first)]
    assert t.reads == 6
    t.close()


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
        resilient("test", loop, stop)()  # first call raises, is logged, then the loop runs again
    assert len(calls) == 2 and "unexpected error" in caplog.text


def test_ran_status_lists_at_most_fifty_queued_tasks_and_counts_all():
    from vcran.core.opil.ranlogic import QUEUE_SHOWN, RanLogic

    logic = RanLogic("r")
    for i in range(120):
        logic.on_motion(i, motion(f"T{i}", f"T{i}_m", 1, 2, 1, 0))
    status = logic.ran_status()
    assert len(status.queue) == QUEUE_SHOWN == 50 and status.queued == 120
    assert status.queue[0].description == "T0"


def test_ran_errors_raised_during_an_outage_are_delivered_after_it_and_on_close():
    """Issue 13 item 7: errors of an outage wait for Orion and go out in order once it answers again;
    an error raised after the last tick goes out on close, not lost with the process."""
    orion = FakeOrion(update_status=503)
    t = transport(orion, backoff_start=0.1, backoff_cap=1.0)
    t.send(Publish(0.5, "robot_1", "ran_error", error(1)))
    t.send(frame(1.0))
    assert t.sender.deliver() is not None  # Orion is down: back off
    t.send(Publish(1.5, "robot_2", "ran_error", error(2)))
    t.send(frame(2.0))
    assert t.sender.deliver() is not None
    assert orion.updates == []
    orion.update_status = 204
    assert t.sender.deliver() is None
    assert delivered_errors(orion) == [("robot_1", 1), ("robot_2", 2)]
    t.send(Publish(2.5, "robot_1", "ran_error", error(3)))  # no tick after it
    t.close()
    assert delivered_errors(orion) == [("robot_1", 1), ("robot_2", 2), ("robot_1", 3)]
    assert t.sender.counts.undeliverable == 0


def test_a_poll_period_longer_than_any_wait_polls_once_and_stops_cleanly():
    # --poll-interval 1e12 (or --factor 1e-12) is a valid period; Event.wait past threading.TIMEOUT_MAX raised
    # OverflowError, which the resilient wrapper logged as a traceback every second, forever
    import threading

    from transports.orion.health import Health
    from transports.orion.workers import poll

    stop, read, errors = threading.Event(), threading.Event(), []
    reads = []

    def once() -> None:
        reads.append(1)
        read.set()

    def worker() -> None:
        try:
            poll(once, 1e12, Health("test polling"), stop, 0.25, 5.0)
        except BaseException as exc:  # noqa: BLE001 - what the thread would have died of
            errors.append(exc)

    thread = threading.Thread(target=worker)
    thread.start()
    assert read.wait(10)
    stop.set()
    thread.join(10)
    assert not thread.is_alive() and errors == [] and reads == [1]


def test_battery_goes_to_orion_with_the_robots_other_state():
    # docs/contract.md §4: battery is published at the telemetry cadence, and docs/contract.md §9: a fleet manager reads it from Orion.
    # The live sender kept only the four RAN attributes of an entity's state, so a live fleet's battery
    # was recorded in the trace as sent and never reached Orion (found by the fifth fresh-user review).
    from vcran.core.opil.messages import BatteryState

    orion = FakeOrion()
    t = transport(orion)
    t.send(Publish(0.5, "robot_1", "battery_state", BatteryState(charge=0.5, capacity=1.0, percentage=0.5)))
    t.send(Publish(0.5, "robot_1", "ran_status", RanStatus()))
    t.send(frame(1.0))
    assert t.sender.deliver() is None
    first = orion.updates[0]["entities"][0]
    assert list(first) == ["id", "type", "current_motion", "ran_status", "battery_state"]
    assert first["battery_state"]["type"] == "sensor_msgs.BatteryState"
    assert first["battery_state"]["value"]["percentage"] == {"type": "number", "value": 0.5}
