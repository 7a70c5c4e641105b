"""``vcran manage SCENARIO --mqtt URL`` end to end (docs/contract.md §9, §11; issue 31 item 5, "The closed loop"): the
very Master that ``vcran.simulate`` runs (the reference MasterControl) against ``vcran live SCENARIO --mqtt
URL``'s vehicles, two processes on a real Mosquitto, as a user starts them (docs/vda5050.md, "Live over MQTT").

What is expected comes from the scenario (scenarios/vda5050-warehouse.toml: ten vehicles, serial numbers
0001 to 0010, manufacturer "vcran"; jobs from a seeded stream, each one pick at a line and one drop at a
dock; ``until_idle``) and from the commands' contract: manage ends by itself once every job has ended,
live ends on SIGTERM, both exit 0, and the live run replays byte for byte.
"""

from __future__ import annotations

import json
import signal
import subprocess
import sys
from dataclasses import replace
from datetime import UTC, datetime
from itertools import islice
from pathlib import Path

import orjson
import pytest

import vcran
from tests.conftest import ROOT
from tests.transports.mqtt.test_live_mqtt import replay_verify
from vcran.io.scenario_file import load
from vcran.io.trace import EVENTS_FILE, event_records, records, trace_in

pytestmark = pytest.mark.slow

WAREHOUSE = ROOT / "scenarios" / "vda5050-warehouse.toml"
FACTOR, JOBS = 10.0, 3


def warehouse(folder: Path) -> Path:
    """The bundled vda5050-warehouse, its first vehicle under its own interfaceName "plant" (§6.3): its topics
    are plant/v2/vcran/0001/..., the others' uagv/v2/vcran/<serial>/..."""
    text = WAREHOUSE.read_text()
    first = 'serial_number = "0001"\n'
    assert text.count(first) == 1
    path = folder / "warehouse.toml"
    path.write_text(text.replace(first, first + 'interface_name = "plant"\n'))
    return path


def manage(*args: str) -> subprocess.Popen[str]:
    return subprocess.Popen([sys.executable, "-m", "vcran", "manage", *args], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, stdin=subprocess.DEVNULL, text=True)


def test_the_warehouse_master_completes_its_jobs_against_vcran_live_mqtt_and_the_run_replays(broker, live_fleet,
                                                                                            tmp_path):
    """vcran live (A) serves the fleet; vcran manage (B) runs MasterControl on the first three jobs: every job
    completed, B ends by itself (until_idle), A on SIGTERM, both exit 0; A's folder replays with --verify."""
    began = datetime.now(UTC).replace(microsecond=0)
    scenario = warehouse(tmp_path)
    vehicles = ["plant/v2/vcran/0001", *(f"uagv/v2/vcran/{n:04d}" for n in range(2, 11))]
    live = live_fleet(broker.url, scenario, *vehicles, factor=FACTOR)  # each vehicle retained ONLINE
    out_b = tmp_path / "manage"
    process = manage(str(scenario), "--mqtt", broker.url, "--factor", f"{FACTOR:g}", "--jobs", str(JOBS),
                     "--out", str(out_b))
    try:
        out, err = process.communicate(timeout=180)
    finally:
        if process.poll() is None:
            process.kill()
            process.communicate()
    code, live_out, live_err = live.stop()  # SIGTERM: the normal end of a live run
    assert process.returncode == 0, err
    assert code == 0, live_err
    start, end = out.splitlines()
    assert start == (f"manage: vcran.managers.vda5050:MasterControl on 10 VDA 5050 vehicle(s) at {broker.url}, "
                     f"x{FACTOR:g}; Ctrl-C stops")
    assert end.startswith("manage ended at ") and f"{JOBS} job(s) arrived, {JOBS} completed, 0 failed, 0 open;" in end
    assert "0 not sent" in end and "invalid" not in end, end

    summary = json.loads((out_b / "summary.json").read_text())
    assert summary["manager"] == "vcran.managers.vda5050:MasterControl"
    assert summary["jobs"]["arrived"] == summary["jobs"]["completed"] == JOBS
    events = event_records(out_b / EVENTS_FILE)
    assert sorted(e["job"] for e in events if e["event"] == "job_completed") == [f"job_{n}" for n in range(1, JOBS + 1)]
    # The orders the master gave for the jobs (job_assigned: vehicle and orderId) are the orders the live fleet
    # completed, no other; and the same the same master gives in simulated time (every vehicle idle when
    # each job arrives: the nearest one to the pickup, the first vehicle, on topics plant/..., among them).
    assigned = {(e["robot"], e["task"]) for e in event_records(out_b / EVENTS_FILE) if e["event"] == "job_assigned"}
    robots = json.loads((live.out / "summary.json").read_text())["robots"]
    assert assigned == {(robot, order) for robot, r in robots.items() for order in r["completed"]}
    sliced = load(scenario)
    sliced = replace(sliced, jobs=tuple(islice(sliced.workload(), JOBS)), job_stream=None)
    simulated = vcran.simulate(sliced).events
    assert assigned == {(e["robot"], e["task"]) for e in simulated if e["event"] == "job_assigned"}
    assert len(assigned) == 2 * JOBS and "robot_1" in {robot for robot, _ in assigned}  # a pick and a drop each

    # The master stamps its orders on the wall clock at its start, its simulated time running FACTOR times as fast
    # (vcran.commands.live.on_wall_clock, docs/vda5050.md): each order the live fleet received is stamped after
    # this test began and within FACTOR times the test's wall time since, not in 1970.
    sent = [orjson.loads(r["raw"])["timestamp"] for _, r in records(trace_in(live.out), ("in",))
            if r.get("dir") == "in" and r["attr"] == "order"]
    assert len(sent) >= 2 * JOBS  # a pick and a drop for each job, and an order to park
    latest = began + FACTOR * (datetime.now(UTC) - began)
    assert all(began <= datetime.fromisoformat(t) <= latest for t in sent), (began, latest, sent)

    verified = replay_verify(live.out)
    assert verified.returncode == 0, verified.stdout + verified.stderr
    assert "verify: every outbound record, leg (telemetry) and event matches the recording" in verified.stdout

    heard_busy_time_is_reported(out_b, live.out, assigned)


def heard_busy_time_is_reported(out_b: Path, live_out: Path, assigned: set[tuple[str, str]]) -> None:
    """``vcran report`` of B's folder: fleet utilisation is the busy time B heard in the vehicles' states (it
    logs ``order_accepted`` and ``order_ended`` as it hears them, docs/vda5050.md "Live over MQTT"), no longer
    0 %. Derived from A's own record, not from the report's code: every order B gave for a job is heard
    accepted and completed on its vehicle, and each order B heard end lasted, as heard, as long as A's vehicle
    held it (accepted to ended, in A's events), give or take the link's latency both ways; the two processes'
    clocks start apart, so durations are compared, not instants."""
    from vcran.cli import main
    from vcran.core.vda5050.outcomes import Ended, Opened, OrderLog
    from vcran.report.managed import read_managed
    from vcran.report.spans import histories

    def spans(events: list[dict]) -> dict[tuple[str, str], tuple[float, float, str]]:
        """(robot, order) -> (accepted, ended, how), each robot's orders fed in order (its OrderLog)."""
        logs: dict[str, OrderLog] = {}
        opened: dict[str, float] = {}
        out = {}
        for e in events:
            change = logs.setdefault(e["robot"], OrderLog()).feed(e)
            if isinstance(change, Opened):
                opened[e["robot"]] = change.t
            elif isinstance(change, Ended):
                out[(e["robot"], change.order_id)] = (opened.pop(e["robot"]), change.t, change.outcome)
        return out

    heard = spans(event_records(out_b / EVENTS_FILE))
    own = spans(event_records(live_out / EVENTS_FILE))
    assert assigned <= set(heard) and all(heard[k][2] == "completed" for k in assigned), (assigned, heard)
    assert set(heard) <= set(own)
    latency = 2.0  # simulated seconds: 0.2 wall seconds at FACTOR 10, at each end of an order
    for key, (start, end, how) in heard.items():
        assert how == own[key][2]
        assert abs((end - start) - (own[key][1] - own[key][0])) <= latency, (key, heard[key], own[key])

    run = read_managed(out_b)
    busy = sum(h.busy for h in histories(run).values())
    assert busy >= sum(end - start for start, end, _ in heard.values()) > 0  # orders still open at the end count too
    report = out_b.parent / "report"
    assert main(["report", str(out_b), "--out", str(report)]) == 0
    kpi = (report / "kpi.md").read_text()
    rows = dict(tuple(c.strip() for c in row.strip("|").split("|")) for row in kpi.splitlines()
                if row.startswith("| ") and "job KPI" not in row)
    share = busy / (run.sim_time * len(run.robot_ids))
    assert rows["fleet utilisation"] == f"{share:.1%}" and share > 0.0, rows


def test_sigterm_ends_manage_normally_with_its_folder(broker, tmp_path):
    """No vehicle answers (nothing serves the fleet): the jobs arrive and stay open, the master's orders go
    out to nobody (QoS 0). SIGTERM is the normal end: exit 0, the folder complete with its summary."""
    out_b = tmp_path / "manage"
    process = manage("vda5050-warehouse", "--mqtt", broker.url, "--factor", "20", "--jobs", "2", "--out", str(out_b))
    try:
        assert process.stdout is not None
        announced = process.stdout.readline()
        assert announced.startswith("manage: vcran.managers.vda5050:MasterControl on 10 VDA 5050 vehicle(s)"), announced
        process.send_signal(signal.SIGTERM)  # the run has started: the master is connected, its on_start ran
        out, err = process.communicate(timeout=60)
    finally:
        if process.poll() is None:
            process.kill()
            process.communicate()
    assert process.returncode == 0, err
    assert out.startswith("manage ended at ") and " failed, " in out, out
    summary = json.loads((out_b / "summary.json").read_text())
    assert summary["jobs"]["completed"] == 0 and summary["jobs"]["open"] == summary["jobs"]["arrived"]
