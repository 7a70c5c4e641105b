"""``vcran report`` of a ``vcran manage --out`` folder (issue 29 item 12): it said "not a complete run
folder"; now it draws the fleet figure and writes the jobs table from what the manager knew, and says
what it cannot draw (the robots' own record is ``vcran live``'s folder). End to end as a user runs it:
``vcran broker`` + ``vcran live`` + ``vcran manage`` (tests/transports/test_manage.py's way), then the
report, whose figures and table are checked against the manage folder's own events and summary."""

from __future__ import annotations

import json

import httpx
import pytest

from tests.conftest import ROOT
from tests.transports.test_live import broker_process, free_port, live_time, stop, vcran, wait_until  # noqa: F401, F811
from transports.orion.link import LinkOptions
from transports.orion.manage import OrionLoop
from vcran.cli import main
from vcran.core.opil.ids import id_for
from vcran.core.opil.messages import RanStatus, TaskEnd
from vcran.io.scenario_file import load
from vcran.io.trace import EVENTS_FILE, event_records
from vcran.managers import Dispatcher

WAREHOUSE = ROOT / "scenarios" / "warehouse.toml"


def test_a_managed_live_runs_folder_is_reported(broker_process, tmp_path, capsys):  # noqa: F811
    pytest.importorskip("matplotlib")
    url = broker_process
    assert main(["orion", "init", str(WAREHOUSE), "--orion", url]) == 0
    live = vcran("live", str(WAREHOUSE), "--orion", url, "--out", str(tmp_path / "live"), "--factor", "20",
                 "--notify-url", f"http://127.0.0.1:{free_port()}/notify")
    try:
        assert wait_until(lambda: live_time(url) >= 1.0, 15)
        assert wait_until(lambda: httpx.get(f"{url}/v2/subscriptions").json() != [], 10)
        manage = vcran("manage", str(WAREHOUSE), "--orion", url, "--factor", "20", "--jobs", "3",
                       "--notify-url", f"http://127.0.0.1:{free_port()}/notify", "--out", str(tmp_path / "manage"))
        out, err = manage.communicate(timeout=90)
        assert manage.returncode == 0, err
    finally:
        stop(live)
    folder = tmp_path / "manage"
    summary = json.loads((folder / "summary.json").read_text())
    assert summary["fleet"] == [f"robot_{n}" for n in range(1, 11)] and summary["seed"] == 7  # warehouse.toml
    events = list(event_records(folder / EVENTS_FILE))
    # what the manager heard: each task it sent, completed, after it was sent, on the robot it was sent to
    sent = {(e["robot"], e["task"]): e["t"] for e in events if e["event"] == "job_assigned"}
    heard = {(e["robot"], e["task"]): e["t"] for e in events if e["event"] == "task_completed"}
    assert set(sent) == set(heard) and len(sent) == 6 and all(heard[k] > sent[k] for k in sent)
    moved = {e["robot"] for e in events if e["event"] == "state" and e["to"] == "MOTION"}
    assert moved == {robot for robot, _ in sent}

    report = tmp_path / "report"
    assert main(["report", str(folder), "--out", str(report)]) == 0
    printed, said = capsys.readouterr()
    assert sorted(p.name for p in report.iterdir()) == ["fleet.png", "kpi.md"]
    assert said == ("vcran report: the layout, the timeline and the robots' KPIs are not in a `vcran manage` "
                    "folder (the manager does not see them): report the `vcran live --out` folder for those\n")
    kpi = (report / "kpi.md").read_text()
    for line in ("| jobs arrived", "| completed"):
        assert f"{line}" in kpi and f"{line}" in printed
    rows = dict(tuple(c.strip() for c in row.strip("|").split("|")) for row in kpi.splitlines()
                if row.startswith("| ") and "job KPI" not in row)
    assert (rows["jobs arrived"], rows["completed"], rows["failed"]) == ("3", "3", "0")

    from vcran.report.fleet import fleet_series
    from vcran.report.managed import read_managed
    from vcran.report.spans import histories

    run = read_managed(folder)
    series = fleet_series(run, histories(run))
    assert (series.done[-1], series.failed[-1]) == (3, 0)
    assert max(series.busy) >= 1 and series.busy[-1] == 0  # heard busy, and idle again by the end
    busy = sum(h.busy for h in histories(run).values())  # the table's utilisation: heard busy time's share
    assert rows["fleet utilisation"] == f"{busy / (run.sim_time * 10):.1%}"


def test_the_first_status_heard_is_a_baseline(tmp_path):
    """Tasks a robot ended before ``manage`` started are not logged as ending when the manager first
    hears of them; a later status's new entries are, and a state change at any status."""
    logged = []
    loop = OrionLoop(load(WAREHOUSE), Dispatcher(), lambda t, robot, name, fields: logged.append((t, robot, name, fields)),
                     client=None, options=LinkOptions("ROBOT"))  # type: ignore[arg-type]
    old, new, gone = id_for("old"), id_for("new"), id_for("gone")
    loop._hear(1.0, "robot_1", RanStatus(state="MOTION", completed=(old,)))
    loop._hear(2.0, "robot_1", RanStatus(state="MOTION", completed=(old,)))
    loop._hear(3.0, "robot_1", RanStatus(state="WAITING", completed=(old, new),
                                         cancelled=(TaskEnd(gone, "timeout"),)))
    assert logged == [
        (1.0, "robot_1", "state", {"from": "WAITING", "to": "MOTION"}),
        (3.0, "robot_1", "state", {"from": "MOTION", "to": "WAITING"}),
        (3.0, "robot_1", "task_completed", {"task": "new"}),
        (3.0, "robot_1", "task_cancelled", {"task": "gone", "reason": "timeout"}),
    ]


def test_a_vda5050_managed_folder_reports_the_busy_time_the_master_heard(tmp_path):
    """A ``vcran manage --mqtt`` folder (summary ``"protocol": "vda5050"``) holds the vehicles' orders as the
    master heard them (``order_accepted``, ``order_ended``: docs/outputs.md); a vehicle is busy from an order
    heard accepted to its heard end, or to the run's end while it is open (docs/report.md). By hand: two
    vehicles over 100 s; v1 holds o1 from 10 to 40 (30 s) and o2 from 60 to the end (40 s); v2 none. Busy
    70 s of 2 x 100 robot-seconds: fleet utilisation 35.0 %. The same events in a folder whose summary names
    no protocol (written before VDA 5050 masters logged them) are read as OPIL's, as before: 0.0 %."""
    from tests.conftest import write_lines
    from vcran.core.jobs import JobBook
    from vcran.report.managed import read_managed

    events = [{"t": 10.0, "robot": "v1", "event": "order_accepted", "order_id": "o1", "order_update_id": 0, "update": False},
              {"t": 40.0, "robot": "v1", "event": "order_ended", "order_id": "o1", "how": "completed"},
              {"t": 60.0, "robot": "v1", "event": "order_accepted", "order_id": "o2", "order_update_id": 0, "update": False}]
    summary = {"scenario": "two", "protocol": "vda5050", "manager": "m:M", "seed": 1, "sim_time": 100.0,
               "fleet": ["v1", "v2"], "jobs": JobBook(lambda *_: None).summary(100.0)}
    for name, protocol in (("mqtt", "vda5050"), ("older", None)):
        folder = tmp_path / name
        folder.mkdir()
        write_lines(folder / EVENTS_FILE, [json.dumps(e) for e in events])
        (folder / "summary.json").write_text(json.dumps({k: v for k, v in summary.items() if protocol or k != "protocol"}))
        run = read_managed(folder)
        assert run.protocol == (protocol or "opil")
        report = tmp_path / f"report-{name}"
        assert main(["report", str(folder), "--out", str(report)]) == 0
        kpi = (report / "kpi.md").read_text()
        rows = dict(tuple(c.strip() for c in row.strip("|").split("|")) for row in kpi.splitlines()
                    if row.startswith("| ") and "job KPI" not in row)
        assert rows["fleet utilisation"] == ("35.0%" if protocol else "0.0%")
        assert ("VDA 5050 master m:M against an MQTT broker's vehicles" in kpi) == bool(protocol)
