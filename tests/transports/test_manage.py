"""``vcran manage`` (SPEC §9, issue 10 item 6): the same fleet manager against a real Orion in real time,
end to end over loopback: ``vcran broker`` + ``vcran live`` (the warehouse's robots) + ``vcran manage``
(the Dispatcher), each its own process as a user would start them."""

from __future__ import annotations

import json
import signal

import httpx
import pytest

from tests.conftest import ROOT
from tests.transports.test_live import broker_process, free_port, live_time, stop, vcran, wait_until  # noqa: F401, F811
from vcran.cli import main
from vcran.io.trace import EVENTS_FILE, event_records

WAREHOUSE = ROOT / "scenarios" / "warehouse.toml"


def test_the_dispatcher_completes_the_warehouses_first_jobs_through_the_broker(broker_process, tmp_path):  # noqa: F811
    url = broker_process
    assert main(["orion", "init", str(WAREHOUSE), "--orion", url]) == 0
    live = vcran("live", str(WAREHOUSE), "--orion", url, "--out", str(tmp_path / "live"), "--factor", "20",
                 "--notify-url", f"http://127.0.0.1:{free_port()}/notify")
    try:
        assert wait_until(lambda: live_time(url) >= 1.0, 15)  # the robots tick
        assert wait_until(lambda: httpx.get(f"{url}/v2/subscriptions").json() != [], 10)  # and listen
        manage = vcran("manage", str(WAREHOUSE), "--orion", url, "--factor", "20", "--jobs", "3",
                       "--notify-url", f"http://127.0.0.1:{free_port()}/notify", "--out", str(tmp_path / "manage"))
        out, err = manage.communicate(timeout=90)  # until_idle: it ends once the three jobs have ended
        assert manage.returncode == 0, err
        assert "3 job(s) arrived, 3 completed, 0 failed, 0 open" in out
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
