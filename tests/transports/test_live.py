"""Live mode over real loopback HTTP (docs/contract.md §7): vcran broker, orion init, live, send, replay --verify.

The end-to-end tests run the CLI commands as separate processes, exactly as a user would. The fault
tests run the live transport in-process, so that they can stop the broker under it, look at its state
and time what matters.
"""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import threading
import time
import tomllib
from pathlib import Path

import httpx
import pytest

from tests.conftest import ROOT
from vcran.cli import main

pytest.importorskip("vcran.core.opil.codec")

from transports.orion.client import OrionClient  # noqa: E402
from transports.orion.link import LinkOptions  # noqa: E402
from transports.orion.transport import OrionTransport  # noqa: E402
from vcran.broker import start_broker  # noqa: E402
from vcran.core.opil.codec import decode_attribute, encode_attribute  # noqa: E402
from vcran.io.scenario_file import parse  # noqa: E402
from vcran.io.trace import event_records, records  # noqa: E402
from vcran.runner import run_to  # noqa: E402
from vcran.sim.live import LiveEnvironment  # noqa: E402

DEMO = ROOT / "scenarios" / "demo.toml"


def wait_until(predicate, timeout: float, step: float = 0.02) -> bool:
    """Poll ``predicate`` until it is true or ``timeout`` wall seconds have passed."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if predicate():
            return True
        time.sleep(step)
    return predicate()


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def vcran(*args: str, **kw) -> subprocess.Popen:
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    return subprocess.Popen([sys.executable, "-m", "vcran", *args], env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, **kw)


@pytest.fixture
def broker_process():
    """``vcran broker`` as its own process, as a user would start it."""
    port = free_port()
    proc = vcran("broker", "--port", str(port))
    line = proc.stdout.readline()
    assert str(port) in line, line + proc.stderr.read()
    yield f"http://127.0.0.1:{port}"
    stop(proc)


def stop(proc: subprocess.Popen) -> tuple[str, str]:
    """SIGINT, as a user's Ctrl-C; a process that does not exit in time is killed, never left behind."""
    proc.send_signal(signal.SIGINT)
    try:
        return proc.communicate(timeout=20)
    except subprocess.TimeoutExpired:
        proc.kill()
        out, err = proc.communicate()
        raise AssertionError(f"{proc.args} did not stop on SIGINT:\n{err}") from None


def ran_status(url: str, robot: str = "robot_1") -> dict | None:
    r = httpx.get(f"{url}/v2/entities/{robot}/attrs/ran_status")
    if r.status_code != 200:
        return None
    return decode_attribute("ran_status", r.json())


def live_time(url: str, robot: str = "robot_1") -> float:
    """The stamp of the robot's current_motion: proof that a live run is publishing (and so polling)."""
    r = httpx.get(f"{url}/v2/entities/{robot}/attrs/current_motion")
    if r.status_code != 200:
        return -1.0
    return decode_attribute("current_motion", r.json()).current_position.header.stamp.to_seconds()


@pytest.mark.parametrize("inbound", ["subscription", "polling"])
def test_demo_end_to_end_through_the_broker(broker_process, tmp_path, inbound):
    url = broker_process
    assert main(["orion", "init", str(DEMO), "--orion", url]) == 0
    out = tmp_path / "live"
    extra = ["--notify-url", f"http://127.0.0.1:{free_port()}/notify"] if inbound == "subscription" else []
    live = vcran("live", str(DEMO), "--orion", url, "--out", str(out), "--factor", "20", *extra)
    try:
        assert wait_until(lambda: live_time(url) >= 1.0, 15)  # the live run ticks (init wrote t = 0)
        if inbound == "subscription":  # values overwritten before the subscription exists are gone (docs/contract.md §7)
            assert wait_until(lambda: httpx.get(f"{url}/v2/subscriptions").json() != [], 10)
        sender = vcran("send", str(DEMO), "--orion", url, "--factor", "20", "--quiet")
        assert sender.wait(timeout=30) == 0, sender.stderr.read()
        done = lambda: [i.description for i in ran_status(url).completed] == ["100", "200", "300"]  # noqa: E731
        assert wait_until(done, 20), ran_status(url)
    finally:
        stdout, stderr = stop(live)
    assert live.returncode == 0, stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["robots"]["robot_1"]["completed"] == ["100", "200", "300"]
    assert summary["robots"]["robot_1"]["cancelled"] == []
    assert summary["stations"]["conveyor_2"]["parts"] == 1
    assert main(["replay", str(out), "--out", str(tmp_path / "replay"), "--verify", "--quiet"]) == 0


def test_a_killed_live_run_keeps_its_recording_up_to_its_last_tick(broker_process, tmp_path):
    # issue 12 item 8: outputs are flushed every tick, and replay accepts the cut-off recording
    url = broker_process
    out = tmp_path / "live"
    live = vcran("live", str(DEMO), "--orion", url, "--out", str(out), "--factor", "20", "--quiet")
    try:
        # a run in progress writes into <out>.incomplete (docs/outputs.md); flushed at every tick
        growing = out.with_name("live.incomplete")
        assert wait_until(lambda: (growing / "trace.jsonl.zst").exists(), 20)
        time.sleep(1.0)  # x20: some 20 simulated seconds under way
        sender = vcran("send", str(DEMO), "--orion", url, "--factor", "20", "--quiet")
        assert sender.wait(timeout=30) == 0, sender.stderr.read()
        assert wait_until(lambda: any(r["dir"] == "in" for _, r in records(growing / "trace.jsonl.zst")), 10)
        assert any(True for _ in event_records(growing / "events.jsonl.zst", cut_off=True))
    finally:
        live.kill()  # SIGKILL: no handler, no close, no summary
        live.communicate(timeout=20)
    assert not out.exists() and not (growing / "summary.json").exists()  # visibly incomplete
    check = vcran("replay", str(growing), "--out", str(tmp_path / "replay"), "--verify")
    stdout, stderr = check.communicate(timeout=60)
    assert check.returncode == 0, stderr
    assert "no end record" in stderr and "as far as it goes" in stdout


# --- in-process: faults --------------------------------------------------------------------------------

FLEET = """
[simulation]
duration = 10000.0
task_timeout = {timeout}
[[robots]]
id = "robot_1"
max_velocity = 2.0
"""


class LiveRun:
    """``run_to`` with the Orion transport in a background thread; ``stop()`` ends it like SIGINT does."""

    def __init__(self, tmp_path: Path, url: str, *, speed: float = 10.0, timeout: float = 30.0,
                 notify: bool = True, poll: float = 0.25, client: OrionClient | None = None, extra: str = "") -> None:
        self.scenario = parse(tomllib.loads(FLEET.format(timeout=timeout) + extra), "<live test>")
        self.env = LiveEnvironment(speed)
        notify_url = f"http://127.0.0.1:{free_port()}/notify" if notify else None
        self.transport = OrionTransport(client or OrionClient(url), LinkOptions(
            "ROBOT", ("robot_1",), notify_url=notify_url, poll_interval=poll, backoff_cap=0.5, keepalive=0.3))
        self.out = tmp_path / "live"
        self.model = None
        self.result = None
        self.error: BaseException | None = None

        def target() -> None:
            try:
                self.result = run_to(self.scenario, self.out, self.transport, env=self.env,
                                     on_start=lambda m: setattr(self, "model", m))
            except BaseException as exc:  # surfaced by stop()
                self.error = exc

        self.thread = threading.Thread(target=target, daemon=True)
        self.thread.start()
        assert wait_until(lambda: self.model is not None, 10)

    def events(self, name: str) -> list[dict]:
        from vcran.io.trace import EVENTS_FILE

        return [e for e in event_records(self.out / EVENTS_FILE) if e["event"] == name]

    def stop(self):
        self.env.call_soon(self.model.stop)
        self.thread.join(timeout=20)
        assert not self.thread.is_alive()
        if self.error:
            raise self.error
        return self.result


def write(url: str, attribute: str, message, robot: str = "robot_1") -> None:
    r = httpx.post(f"{url}/v2/entities/{robot}/attrs", json={attribute: encode_attribute(attribute, message)})
    assert r.status_code == 204, r.text


def task(name: str, n: int = 2):
    from vcran.core.opil.build import action, motion

    return [motion(name, f"{name}_m{i}", i, n, i, 0) for i in range(1, n)] + [action(name, f"{name}_a", n, n)]


def init(url: str) -> None:
    r = httpx.post(f"{url}/v2/op/update", json={"actionType": "append", "entities": [{"id": "robot_1", "type": "ROBOT"}]})
    assert r.status_code == 204


@pytest.mark.slow
def test_broker_restart_mid_run(tmp_path):
    broker = start_broker(port=0)
    port, url = broker.port, broker.url
    init(url)
    run = LiveRun(tmp_path, url)
    try:
        assert wait_until(lambda: ran_status(url) is not None, 10)
        broker.stop()  # Orion gone: the simulation goes on, outbound state is kept
        t_down = run.env.now
        assert wait_until(lambda: run.env.now > t_down + 5 and run.transport.outbound.fault is not None, 30)
        broker = start_broker(port=port)  # a fresh, empty Orion on the same port
        # outbound state delivered again (op/update append recreates the entity) ...
        assert wait_until(lambda: ran_status(url) is not None, 10)
        # ... and the subscription re-created: a write after the restart reaches the simulation
        assert wait_until(lambda: run.transport.inbound.fault is None and
                          httpx.get(f"{url}/v2/subscriptions").json() != [], 10)
        for m in task("after"):
            write(url, "motion_assignment" if hasattr(m, "point") else "action_assignment", m)
        assert wait_until(lambda: [i.description for i in ran_status(url).completed] == ["after"], 10)
    finally:
        result = run.stop()
        broker.stop()
    assert result.summary["robots"]["robot_1"]["completed"] == ["after"]
    # what was recorded through the outage replays exactly (docs/contract.md §6)
    assert main(["replay", str(run.out), "--out", str(tmp_path / "rep"), "--verify", "--quiet"]) == 0


@pytest.mark.slow
def test_5xx_and_slow_answers_do_not_stall_the_simulation(tmp_path, caplog):
    """docs/contract.md §7: Orion answering 503, then holding an answer back, never holds up the simulation. Shown by
    counting, not timing: simulated time goes on while every update is refused, and while one request waits
    for its answer for as long as the test likes (a pace measured against the wall clock failed on a loaded
    machine)."""
    phase = {"now": "down"}
    answer = threading.Event()  # lets the held request have its answer
    held = threading.Event()  # a request is waiting for its answer

    def handler(request: httpx.Request) -> httpx.Response:
        if request.url.path != "/v2/op/update":
            return httpx.Response(200, json=[])
        if phase["now"] == "down":
            return httpx.Response(503, json={"error": "ServiceUnavailable", "description": "down"})
        held.set()
        answer.wait(60)  # slow, but answering
        return httpx.Response(204)

    client = OrionClient("http://orion.invalid", transport=httpx.MockTransport(handler))
    with caplog.at_level("WARNING", logger="vcran.orion"):
        run = LiveRun(tmp_path, "http://orion.invalid", notify=False, client=client)
        try:
            assert wait_until(lambda: run.transport.outbound.fault is not None, 30)  # refused, backing off
            t = run.env.now
            assert wait_until(lambda: run.env.now > t + 5, 30)  # ... and the simulation goes on
            phase["now"] = "slow"
            assert wait_until(held.is_set, 30)  # a request is in flight, unanswered ...
            t = run.env.now
            assert wait_until(lambda: run.env.now > t + 5, 30)  # ... and the simulation goes on
            assert not answer.is_set() and run.transport.outbound.fault is not None
            answer.set()
            assert wait_until(lambda: run.transport.outbound.fault is None, 30)
        finally:
            answer.set()
            run.stop()
    assert main(["replay", str(run.out), "--out", str(tmp_path / "rep"), "--verify", "--quiet"]) == 0
    downs = [r for r in caplog.records if "retrying with backoff" in r.getMessage()]
    assert len(downs) == 1  # logged once, not once per tick
    assert any("is back" in r.getMessage() for r in caplog.records)


def test_listener_refuses_bad_notifications_and_ignores_unknown_subscriptions(tmp_path):
    broker = start_broker(port=0)
    init(broker.url)
    run = LiveRun(tmp_path, broker.url)
    try:
        listener = run.transport.listener
        assert wait_until(lambda: run.transport._sids[0] is not None, 10)
        base = f"http://127.0.0.1:{listener.port}{listener.path}"
        big = httpx.post(base, content=b"{" + b" " * (listener.max_body + 1) + b"}",
                         headers={"Content-Type": "application/json"})
        assert big.status_code == 413
        assert httpx.post(base, content=b'{"subscriptionId": ', headers={"Content-Type": "application/json"}).status_code == 400
        assert httpx.post(base, json={"hello": "world"}).status_code == 400
        from vcran.core.opil.build import motion

        stray = {"subscriptionId": "not-ours", "data": [
            {"id": "robot_1", "type": "ROBOT", "motion_assignment": encode_attribute("motion_assignment", motion("X", "X_m", 1, 2, 1, 0))}]}
        assert httpx.post(base, json=stray).status_code == 204
        time.sleep(0.3)
    finally:
        run.stop()
        broker.stop()
    assert run.events("task_queued") == []  # the stray notification entered nothing


@pytest.mark.slow
@pytest.mark.parametrize("inbound,expected", [("polling", "timeout"), ("subscription", "completed")])
def test_polling_loses_overwritten_values_subscription_does_not(tmp_path, inbound, expected):
    """Two motions written to the same attribute between two polls: polling sees only the second, so the
    task never assembles and R7 cancels it; notifications deliver both. Under subscription R7's timeout is
    far beyond the test (3 simulated seconds, 0.3 s of wall time, cancelled the task on a loaded machine
    before its last notification arrived); under polling it is the outcome, so it stays short."""
    broker = start_broker(port=0)
    init(broker.url)
    run = LiveRun(tmp_path, broker.url, speed=10, timeout=3.0 if inbound == "polling" else 3600.0,
                  notify=inbound == "subscription", poll=30.0)
    try:
        if inbound == "subscription":
            assert wait_until(lambda: run.transport._sids[0] is not None and run.transport.requests >= 1, 10)
        else:
            assert wait_until(lambda: run.transport.requests >= 1, 10)  # the first poll is done; next in 3 s
        m1, m2, a = task("T", 3)
        write(broker.url, "motion_assignment", m1)
        write(broker.url, "motion_assignment", m2)
        write(broker.url, "action_assignment", a)
        if inbound == "polling":
            assert wait_until(lambda: run.model.cancelled["robot_1"] != [], 15)
        else:
            assert wait_until(lambda: run.model.completed["robot_1"] != [], 15)
    finally:
        run.stop()
        broker.stop()
    robot = run.result.summary["robots"]["robot_1"]
    if expected == "timeout":
        assert robot["cancelled"] == [{"task": "T", "reason": "timeout"}] and robot["completed"] == []
    else:
        assert robot["completed"] == ["T"]


def test_values_written_while_the_subscription_was_gone_are_not_lost(tmp_path):
    """Orion keeps its data but loses vcran's subscription: the keeper re-creates it and reads the entity
    again, so an assignment written in between still reaches the simulation (docs/contract.md §7)."""
    broker = start_broker(port=0)
    init(broker.url)
    run = LiveRun(tmp_path, broker.url)
    try:
        assert wait_until(lambda: run.transport._sids[0] is not None, 10)
        first = run.transport._sids[0]
        assert httpx.delete(f"{broker.url}/v2/subscriptions/{first}").status_code == 204
        for m in task("gap"):  # written while nobody is subscribed: no notification
            write(broker.url, "motion_assignment" if hasattr(m, "point") else "action_assignment", m)
        assert wait_until(lambda: run.model.completed["robot_1"] == ["gap"], 15)
        assert run.transport._sids[0] not in (None, first)
    finally:
        run.stop()
        broker.stop()


def test_r12_lone_surrogate_in_a_notification_is_rejected_and_the_run_goes_on(tmp_path):
    """A notification whose cancel_order carries "\\udc00" (valid JSON, not valid Unicode) used to kill the
    live run in the trace writer; it is a malformed input like any other (R12), recorded and replayable."""
    from vcran.core.opil.build import cancel

    broker = start_broker(port=0)
    init(broker.url)
    run = LiveRun(tmp_path, broker.url)
    try:
        assert wait_until(lambda: run.transport._sids[0] is not None, 10)
        bad = encode_attribute("cancel_order", cancel("T"))
        bad["value"]["task_id"]["value"]["description"]["value"] = "\udc00"
        body = json.dumps({"subscriptionId": run.transport._sids[0],
                           "data": [{"id": "robot_1", "type": "ROBOT", "cancel_order": bad}]})
        listener = run.transport.listener
        answer = httpx.post(f"http://127.0.0.1:{listener.port}{listener.path}", content=body,
                            headers={"Content-Type": "application/json"})
        assert answer.status_code == 204
        for m in task("after"):
            write(broker.url, "motion_assignment" if hasattr(m, "point") else "action_assignment", m)
        assert wait_until(lambda: run.model.completed["robot_1"] == ["after"], 15)
    finally:
        result = run.stop()
        broker.stop()
    assert result.summary["robots"]["robot_1"]["errors"] == 1
    assert [e["code"] for e in run.events("rejected")] == ["malformed"]
    assert main(["replay", str(run.out), "--out", str(tmp_path / "rep"), "--verify", "--quiet"]) == 0


def test_notifications_orion_failed_to_deliver_are_read_from_orion(tmp_path):
    """Orion gives up on a notification (the listener was unreachable, or too slow in a burst) and says
    so in the subscription's lastFailure/failsCounter; the keeper sees it and reads the entities, so the
    values those notifications carried still reach the simulation (docs/contract.md §7: no loss window)."""
    broker = start_broker(port=0)
    init(broker.url)
    run = LiveRun(tmp_path, broker.url)
    try:
        assert wait_until(lambda: run.transport._sids[0] is not None and run.transport.requests >= 1, 10)
        sid = run.transport._sids[0]
        dead = f"http://127.0.0.1:{free_port()}/notify"  # every notification from now on fails
        patch = {"notification": {"http": {"url": dead}, "attrs": ["motion_assignment", "action_assignment",
                                                                  "cancel_order"]}}
        assert httpx.patch(f"{broker.url}/v2/subscriptions/{sid}", json=patch).status_code == 204
        for m in task("lost"):
            write(broker.url, "motion_assignment" if hasattr(m, "point") else "action_assignment", m)
        assert broker.wait_notifications(timeout=10)
        assert httpx.get(f"{broker.url}/v2/subscriptions/{sid}").json()["notification"]["failsCounter"] == 2
        assert wait_until(lambda: run.model.completed["robot_1"] == ["lost"], 15)
    finally:
        run.stop()
        broker.stop()


def test_a_failure_success_failure_within_one_second_still_reads_as_a_failure():
    """Orion shows delivery times in whole seconds and resets failsCounter at a success: between two looks
    of the keeper, fail, succeed and fail again within one second leave lastFailure and failsCounter as
    they were. The notifications counted meanwhile tell (docs/contract.md §7: no loss window)."""
    from transports.orion.link import _failures

    def shown(**notification):
        return {"id": "s", "notification": {"attrs": [], **notification}}

    failed = shown(timesSent=3, lastFailure="2026-11-23T10:00:05.000Z", failsCounter=1)
    again = shown(timesSent=5, lastFailure="2026-11-23T10:00:05.000Z", failsCounter=1,
                  lastSuccess="2026-11-23T10:00:05.000Z")
    assert _failures(again) != _failures(failed)
    # successes alone change nothing the keeper acts on
    fine = shown(timesSent=3, lastSuccess="2026-11-23T10:00:04.000Z")
    assert _failures(shown(timesSent=9, lastSuccess="2026-11-23T10:00:09.000Z")) == _failures(fine) == (None,) * 3


@pytest.mark.slow
def test_s4_link_down_live_the_robot_neither_publishes_nor_receives_until_it_is_back(tmp_path):
    """docs/contract.md §4 link_down in live mode: from t = 0 to 50 (5 wall seconds at 10x) robot_1 publishes nothing
    (Orion holds no ran_status of it) and a task written meanwhile waits in Orion; back up, the robot
    reads it and runs it, and the recording replays."""
    broker = start_broker(port=0)
    init(broker.url)
    run = LiveRun(tmp_path, broker.url, extra='[[faults]]\nt = 0.0\nrobot = "robot_1"\nkind = "link_down"\nduration = 50.0\n')
    try:
        assert wait_until(lambda: run.transport._sids[0] is not None, 10)
        for m in task("held"):
            write(broker.url, "motion_assignment" if hasattr(m, "point") else "action_assignment", m)
        assert run.env.now < 50.0 and ran_status(broker.url) is None  # down: nothing published yet
        assert wait_until(lambda: run.model.completed["robot_1"] == ["held"], 20)
        assert ran_status(broker.url) is not None
    finally:
        run.stop()
        broker.stop()
    (queued,) = run.events("task_queued")
    assert queued["t"] == 50.0  # read when the link came back, not when Orion notified it
    assert [e["kind"] for e in run.events("fault_end")] == ["link_down"]
    assert main(["replay", str(run.out / "trace.jsonl.zst"), "--out", str(tmp_path / "rep"), "--verify", "--quiet"]) == 0
