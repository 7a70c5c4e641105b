"""``vcran manage`` (docs/contract.md §9, issue 10 item 6): the same fleet manager against a real Orion in real time,
end to end over loopback: ``vcran broker`` + ``vcran live`` (the warehouse's robots) + ``vcran manage``
(the Dispatcher), each its own process as a user would start them; and its polling mode, in process against
vcran's broker, where the test decides when Orion changes or goes away."""

from __future__ import annotations

import json
import signal
import socket
import subprocess
from collections.abc import Callable
from pathlib import Path
from typing import Any

import httpx
import pytest

from tests.conftest import ROOT
from tests.transports.test_live import broker_process, free_port, live_time, stop, vcran, wait_until  # noqa: F401, F811
from transports.orion.client import OrionClient
from transports.orion.link import LinkOptions
from transports.orion.manage import OrionManagerLink
from vcran.broker import start_broker
from vcran.cli import main
from vcran.core.opil.build import motion_message
from vcran.core.opil.codec import encode_attribute
from vcran.core.opil.messages import RanStatus, Time
from vcran.core.wire import Outbound, Publish
from vcran.io.trace import EVENTS_FILE, event_records

WAREHOUSE = ROOT / "scenarios" / "warehouse.toml"


def warehouse_live(url: str, out: Path) -> subprocess.Popen:
    """``vcran orion init`` and ``vcran live`` (subscribed) of the warehouse's robots, ticking and listening."""
    assert main(["orion", "init", str(WAREHOUSE), "--orion", url]) == 0
    live = vcran("live", str(WAREHOUSE), "--orion", url, "--out", str(out), "--factor", "20",
                 "--notify-url", f"http://127.0.0.1:{free_port()}/notify")
    try:
        assert wait_until(lambda: live_time(url) >= 1.0, 60)  # the robots tick
        assert wait_until(lambda: httpx.get(f"{url}/v2/subscriptions").json() != [], 60)  # and listen
    except BaseException:
        stop(live)
        raise
    return live


@pytest.mark.parametrize("inbound", ["subscription", "polling"])
def test_the_dispatcher_completes_the_warehouses_first_jobs_through_the_broker(broker_process, tmp_path,  # noqa: F811
                                                                               inbound):
    """In both modes: the manager subscribed to Orion (``--notify-url``), or polling it (its default)."""
    url = broker_process
    live = warehouse_live(url, tmp_path / "live")
    try:
        extra = ["--notify-url", f"http://127.0.0.1:{free_port()}/notify"] if inbound == "subscription" else []
        manage = vcran("manage", str(WAREHOUSE), "--orion", url, "--factor", "20", "--jobs", "3", *extra,
                       "--out", str(tmp_path / "manage"))
        out, err = manage.communicate(timeout=90)  # until_idle: it ends once the three jobs have ended
        assert manage.returncode == 0, err
        assert "3 job(s) arrived, 3 completed, 0 failed, 0 open" in out
        start, end = out.splitlines()
        if inbound == "subscription":
            assert start.endswith(f"x20, subscription to {extra[1]}; Ctrl-C stops") and end.endswith(" notification(s)")
        else:  # the end line counts what polling did: reads of Orion, not notifications it never had
            assert start.endswith("x20, polling every 0.25 s; Ctrl-C stops") and end.endswith(" read(s)"), out
        subscriptions = httpx.get(f"{url}/v2/subscriptions").json()
        assert len(subscriptions) == 1  # the manager deleted its own on the way out; live's remains
    finally:
        stop(live)
    summary = json.loads((tmp_path / "manage" / "summary.json").read_text())
    assert summary["jobs"]["completed"] == 3 and summary["manager"] == "vcran.managers.dispatcher:Dispatcher"
    events = list(event_records(tmp_path / "manage" / EVENTS_FILE))
    assert sorted(e["job"] for e in events if e["event"] == "job_completed") == ["job_1", "job_2", "job_3"]
    # each job: a pickup task and a drop-off task, on the robots the live run completed them on
    robots = json.loads((tmp_path / "live" / "summary.json").read_text())["robots"]
    completed = {task for r in robots.values() for task in r["completed"]}
    assigned = {e["task"] for e in events if e["event"] == "job_assigned"}
    assert assigned == {f"job_{n}_{phase}1" for n in (1, 2, 3) for phase in ("pick", "drop")}
    assert assigned <= completed


def test_manage_refuses_a_scenario_without_a_manager_and_an_unreachable_orion(tmp_path, capsys):
    demo = ROOT / "scenarios" / "demo.toml"
    notify = f"http://127.0.0.1:{free_port()}/notify"
    assert main(["manage", str(demo), "--orion", "http://127.0.0.1:1", "--notify-url", notify]) == 2
    assert "names no fleet manager" in capsys.readouterr().err
    out = tmp_path / "manage"
    assert main(["manage", str(WAREHOUSE), "--orion", f"http://127.0.0.1:{free_port()}", "--notify-url", notify,
                 "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("vcran manage: cannot subscribe to the fleet") and "unreachable" in err
    assert list(tmp_path.iterdir()) == []  # nothing ran: no folder, complete or not, left behind


def test_manage_refuses_an_out_folder_that_is_not_a_vcran_output(tmp_path, capsys):
    """Its --out is written like a run folder's (vcran.io.runfolder): a folder holding anything else is
    refused before Orion is contacted, and left as it was."""
    out = tmp_path / "mine"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    notify = f"http://127.0.0.1:{free_port()}/notify"
    assert main(["manage", str(WAREHOUSE), "--orion", "http://127.0.0.1:1", "--notify-url", notify, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("vcran manage: ") and "is not a vcran run folder" in err and err.count("\n") == 1
    assert [p.name for p in tmp_path.iterdir()] == ["mine"] and [p.name for p in out.iterdir()] == ["notes.txt"]
    # an --orion that cannot work is refused before any folder is made
    assert main(["manage", str(WAREHOUSE), "--orion", "not-a-url", "--notify-url", notify,
                 "--out", str(tmp_path / "new")]) == 2
    assert "--orion 'not-a-url'" in capsys.readouterr().err and [p.name for p in tmp_path.iterdir()] == ["mine"]


def test_a_manager_that_raises_ends_manage_with_one_line_and_exit_1(broker_process, tmp_path):  # noqa: F811
    """The same boundary as ``vcran run``: the user's manager failed (which hook, when), not vcran."""
    url = broker_process
    assert main(["orion", "init", str(WAREHOUSE), "--orion", url]) == 0
    earlier = tmp_path / "manage"  # an earlier run's folder, which the failed run must not mix into
    earlier.mkdir()
    (earlier / "events.jsonl.zst").write_bytes(b"earlier")
    (earlier / "summary.json").write_text('{"earlier": true}')
    manage = vcran("manage", str(WAREHOUSE), "--orion", url, "--factor", "100", "--jobs", "1", "--quiet",
                   "--manager", "tests.testing.loop_managers:Raising", "--out", str(earlier),
                   "--notify-url", f"http://127.0.0.1:{free_port()}/notify", cwd=ROOT)
    out, err = manage.communicate(timeout=60)
    assert (manage.returncode, out) == (1, ""), err
    assert err.startswith("vcran manage: the fleet manager raised RuntimeError: my bug (in fleet manager "
                          "Raising: on_job at t=") and err.count("\n") == 1, err
    assert httpx.get(f"{url}/v2/subscriptions").json() == []  # it still cleaned up after itself
    # the failed run is visibly incomplete, beside the earlier run's folder, which is as it was
    assert (earlier / "events.jsonl.zst").read_bytes() == b"earlier"
    assert json.loads((earlier / "summary.json").read_text()) == {"earlier": True}
    assert [p.name for p in (tmp_path / "manage.incomplete").iterdir()] == ["events.jsonl.zst"]


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM], ids=["ctrl-c", "sigterm"])
def test_a_signal_mid_manage_ends_it_normally_with_its_outputs_and_no_subscription_left(broker_process, tmp_path,  # noqa: F811
                                                                                         signum):
    """docs/live.md "The end": Ctrl-C (or SIGTERM) ends ``vcran manage`` as its duration would: exit 0, no
    traceback, the job events and summary written, its subscription deleted."""
    url = broker_process
    assert main(["orion", "init", str(WAREHOUSE), "--orion", url]) == 0
    manage = vcran("manage", str(WAREHOUSE), "--orion", url, "--factor", "20", "--quiet",
                   "--notify-url", f"http://127.0.0.1:{free_port()}/notify", "--out", str(tmp_path / "manage"))
    try:
        assert wait_until(lambda: httpx.get(f"{url}/v2/subscriptions").json() != [], 15)  # it listens
        assert wait_until(lambda: "job_1" in json.dumps(httpx.get(f"{url}/v2/entities").json()), 20)  # and works
    finally:
        manage.send_signal(signum)
        out, err = manage.communicate(timeout=30)
    assert manage.returncode == 0 and "Traceback" not in err, err
    assert httpx.get(f"{url}/v2/subscriptions").json() == []
    assert sorted(p.name for p in tmp_path.iterdir()) == ["manage"]  # complete: renamed into place
    summary = json.loads((tmp_path / "manage" / "summary.json").read_text())
    assert summary["manager"] == "vcran.managers.dispatcher:Dispatcher"
    assert 0 < summary["jobs"]["arrived"] < 240  # stopped within the hour's workload
    events = list(event_records(tmp_path / "manage" / EVENTS_FILE))
    assert any(e["event"] == "job_assigned" and e["job"] == "job_1" for e in events)


# --- polling, in process ---------------------------------------------------------------------------------

ROBOTS = ("robot_1", "robot_2")


class CallNow:
    """The part of a LiveEnvironment an OrionLink uses: its speed, and ``call_soon``, here run at once in
    the polling thread, so that the test sees each batch as the link hands it to the manager."""

    speed = 1.0

    def call_soon(self, fn: Callable[[], Any]) -> None:
        fn()


class CountingClient(OrionClient):
    """Counts the reads the link attempts, successful or not: a test waits for reads, never for time."""

    def __init__(self, url: str) -> None:
        super().__init__(url)
        self.attempts = 0

    def entities(self, *args: Any, **kw: Any) -> list[dict[str, Any]]:
        self.attempts += 1
        return super().entities(*args, **kw)


def put(url: str, robot: str, **attrs: Any) -> None:
    """Write attributes of a robot's entity in Orion, as ``vcran live`` publishes them."""
    entity = {"id": robot, "type": "ROBOT", **{a: encode_attribute(a, m) for a, m in attrs.items()}}
    assert httpx.post(f"{url}/v2/op/update", json={"actionType": "append", "entities": [entity]}).status_code == 204


def motion_at(t: float):
    return motion_message(Time.from_seconds(t), t, 0.0, 0.0, 0.0, 0.0)


def polling_link(url: str, batches: list[list[Outbound]], attributes: frozenset[str] | None) -> OrionManagerLink:
    client = CountingClient(url)
    options = LinkOptions("ROBOT", ROBOTS, poll_interval=0.02, backoff_start=0.02, backoff_cap=0.1)
    link = OrionManagerLink(CallNow(), client, options, attributes, batches.append)  # type: ignore[arg-type]
    link.start(CallNow.speed, strict=True)
    return link


def read_again(link: OrionManagerLink, reads: int = 2) -> None:
    """Return once ``reads`` more reads have begun (and the one before them ended): what Orion held when
    this was called has been read at least once, and handed on if it was to be."""
    client = link.client
    assert isinstance(client, CountingClient)
    target = client.attempts + reads
    assert wait_until(lambda: client.attempts > target, 20)


def updates(batch: list[Outbound]) -> set[tuple[str, str, Any]]:
    return {(p.robot, p.attribute, p.message) for p in batch if isinstance(p, Publish)}


def test_polling_forwards_an_entity_only_when_one_of_the_managers_attributes_changed():
    """docs/contract.md §9: polling tells the manager what a subscription on its ``attributes`` would: everything
    Orion holds at first, then a robot's published attributes (all of them, as a notification carries
    them) when one of its condition attributes changed; an unchanged robot is not handed on again."""
    broker = start_broker(port=0)
    url = broker.url
    put(url, "robot_1", ran_status=RanStatus(state="WAITING"), current_motion=motion_at(0))
    put(url, "robot_2", ran_status=RanStatus(state="WAITING"), current_motion=motion_at(0))
    batches: list[list[Outbound]] = []
    link = polling_link(url, batches, frozenset({"ran_status"}))
    try:
        assert updates(batches[0]) == {(r, a, m) for r in ROBOTS for a, m in (
            ("ran_status", RanStatus(state="WAITING")), ("current_motion", motion_at(0)))}
        read_again(link)
        assert len(batches) == 1  # nothing changed: nothing more
        put(url, "robot_1", current_motion=motion_at(1))  # not the manager's condition: no update
        read_again(link)
        assert len(batches) == 1
        put(url, "robot_1", ran_status=RanStatus(state="BUSY"))  # the condition: robot_1, as it is now
        read_again(link)
        assert [updates(b) for b in batches[1:]] == [
            {("robot_1", "ran_status", RanStatus(state="BUSY")), ("robot_1", "current_motion", motion_at(1))}]
        read_again(link)
        assert len(batches) == 2
        assert link.notifications == 0 and link.reads >= 6 and httpx.get(f"{url}/v2/subscriptions").json() == []
    finally:
        link.close()
        broker.stop()


@pytest.mark.parametrize("attributes", [None, frozenset({"motion_assignment"})], ids=["all", "none-published"])
def test_a_manager_on_every_attribute_is_told_each_poll_that_finds_a_change(attributes):
    """``attributes`` None (every published attribute): a change of any of them hands the robot on; so
    does one that names no published attribute, as a subscription's empty condition (Orion: any)."""
    broker = start_broker(port=0)
    url = broker.url
    put(url, "robot_1", current_motion=motion_at(0))
    batches: list[list[Outbound]] = []
    link = polling_link(url, batches, attributes)
    try:
        read_again(link)
        put(url, "robot_1", current_motion=motion_at(1))
        read_again(link)
        assert [updates(b) for b in batches] == [{("robot_1", "current_motion", motion_at(t))} for t in (0, 1)]
    finally:
        link.close()
        broker.stop()


def test_orion_going_away_while_polling_is_logged_once_and_polling_recovers(caplog):
    """docs/contract.md §7 faults, for the manager: Orion down mid-run is one line per cause (not one per poll),
    retried with backoff, one line when it is back; what it holds then reaches the manager."""
    broker = start_broker(port=0)
    port, url = broker.port, broker.url
    put(url, "robot_1", ran_status=RanStatus(state="WAITING"))
    batches: list[list[Outbound]] = []
    with caplog.at_level("WARNING", logger="vcran.orion"):
        link = polling_link(url, batches, frozenset({"ran_status"}))
        try:
            broker.stop()
            read_again(link, 5)  # five failed reads at least
            assert link.inbound.fault is not None
            broker = start_broker(port=port)  # a fresh Orion on the same port: robot_1 published anew
            put(url, "robot_1", ran_status=RanStatus(state="BUSY"))
            read_again(link)
            assert link.inbound.fault is None
        finally:
            link.close()
            broker.stop()
    assert [updates(b) for b in batches] == [{("robot_1", "ran_status", RanStatus(state=s))} for s in ("WAITING", "BUSY")]
    lines = [r.getMessage() for r in caplog.records]
    # five failed reads or more, logged once per cause: the broker's stop may drop a kept-alive
    # connection (RemoteProtocolError) before connections are refused (ConnectError), a second cause
    down = [m for m in lines if "retrying with backoff" in m]
    assert 1 <= len(down) <= 2 and len(set(down)) == len(down), down
    assert all(m.startswith("manager polling: read entities: ") and "unreachable" in m for m in down), down
    assert len([m for m in lines if "Orion is back" in m]) == 1


@pytest.mark.parametrize(("extra", "message"), [
    (["--poll-interval", "0"], "--poll-interval must be a finite number above 0, got 0"),
    (["--poll-interval", "-1"], "--poll-interval must be a finite number above 0, got -1"),
    (["--poll-interval", "nan"], "--poll-interval must be a finite number above 0, got nan"),
    (["--poll-interval", "inf"], "--poll-interval must be a finite number above 0, got inf"),
    (["--listen", "0.0.0.0"], "--listen is where the notification listener binds: it needs --notify-url"),
    (["--notify-url", "http://127.0.0.1:1/notify", "--poll-interval", "1"],
     "--poll-interval is the polling period: without --notify-url only"),
])
def test_manage_polling_usage_errors_exit_2_before_orion_is_contacted(extra, message, tmp_path, capsys):
    out = tmp_path / "manage"
    assert main(["manage", str(WAREHOUSE), "--orion", "http://127.0.0.1:1", *extra, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err == f"vcran manage: {message}\n"
    assert list(tmp_path.iterdir()) == []


def test_manage_polling_an_unreachable_orion_at_start_is_one_line_and_exit_2(tmp_path, capsys):
    assert main(["manage", str(WAREHOUSE), "--orion", f"http://127.0.0.1:{free_port()}",
                 "--out", str(tmp_path / "manage")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("vcran manage: cannot read the fleet from http://127.0.0.1:") and "unreachable" in err
    assert err.count("\n") == 1 and list(tmp_path.iterdir()) == []


def test_manage_on_a_busy_notification_port_names_the_address_and_exits_2(tmp_path, capsys):
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        notify = f"http://127.0.0.1:{busy.getsockname()[1]}/notify"
        assert main(["manage", str(WAREHOUSE), "--orion", "http://127.0.0.1:1", "--notify-url", notify,
                     "--out", str(tmp_path / "manage")]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"vcran manage: cannot listen for notifications on 127.0.0.1, {notify}: "), err
    assert err.count("\n") == 1 and list(tmp_path.iterdir()) == []


def test_a_notification_entity_with_an_id_that_is_no_string_is_skipped_not_raised():
    """docs/contract.md §7: a notification is outside input. An entity whose id is a list (unhashable) raised TypeError
    in the membership test, the listener answered 500 and the batch's other robots were lost too."""
    batches: list[list[Outbound]] = []
    options = LinkOptions("ROBOT", ROBOTS, "http://127.0.0.1:9/notify")
    link = OrionManagerLink(CallNow(), OrionClient("http://127.0.0.1:9"), options, None, batches.append)  # type: ignore[arg-type]
    link._ours["s"] = link.subscriptions[0]  # as if subscribed
    status = encode_attribute("ran_status", RanStatus(state="WAITING"))
    link._on_notification("s", [{"id": ["robot_1"], "type": "ROBOT", "ran_status": status},
                                 {"id": {"a": 1}, "type": "ROBOT", "ran_status": status},
                                 {"id": "robot_2", "type": "ROBOT", "ran_status": status}])
    assert [updates(b) for b in batches] == [{("robot_2", "ran_status", RanStatus(state="WAITING"))}]
    link.client.close()


def test_the_manager_is_told_of_each_forced_description_write_and_of_no_unchanged_one(tmp_path):
    """docs/contract.md §2, §9, issue 29 item 2: ``vcran live`` writes robot_description every period, unchanged, with
    forcedUpdate; the manager is told of each such write (as in simulated time,
    tests/sim/test_loop.py::test_every_periodic_robot_description_reaches_the_manager_as_live_mode_forces_it),
    and not of the unchanged description that every notification of the whole entity carries."""
    from vcran.core.opil.messages import PolygonStamped
    from vcran.core.scenario import RobotConfig
    from vcran.sim.opil.ran import description

    config = RobotConfig(id="robot_1")
    desc = description(config, PolygonStamped.from_xy(config.footprint))
    broker = start_broker(port=0)
    url = broker.url
    put(url, "robot_1", robot_description=desc, ran_status=RanStatus(state="WAITING"))
    batches: list[list[Outbound]] = []
    options = LinkOptions("ROBOT", ROBOTS, f"http://127.0.0.1:{free_port()}/notify")
    link = OrionManagerLink(CallNow(), OrionClient(url), options, None, batches.append)  # type: ignore[arg-type]
    link.start(CallNow.speed, strict=True)
    forced = {"actionType": "append", "entities": [
        {"id": "robot_1", "type": "ROBOT", "robot_description": encode_attribute("robot_description", desc)}]}

    def descriptions() -> int:
        return sum(1 for b in batches for p in b if isinstance(p, Publish) and p.attribute == "robot_description")

    try:
        assert descriptions() == 1  # the first read: what Orion holds
        put(url, "robot_1", ran_status=RanStatus(state="BUSY"))  # a notification of the whole entity
        assert wait_until(lambda: any(("robot_1", "ran_status", RanStatus(state="BUSY")) in updates(b)
                                      for b in batches), 10)
        assert descriptions() == 1  # the description it carried is no write of it
        for n in (2, 3):  # two periodic writes, as vcran live's sender makes them
            assert httpx.post(f"{url}/v2/op/update?options=forcedUpdate", json=forced).status_code == 204
            assert wait_until(lambda: descriptions() == n, 10)  # noqa: B023
        assert len(httpx.get(f"{url}/v2/subscriptions").json()) == 2
    finally:
        link.close()
        broker.stop()
    assert all(p.message == desc for b in batches for p in b if isinstance(p, Publish) and p.attribute == "robot_description")
