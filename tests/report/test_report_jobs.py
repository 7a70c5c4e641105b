"""`vcran report` of a closed-loop run (docs/contract.md §9, issue 10 item 8): the job KPIs next to the robots' table."""

from __future__ import annotations

import json

import pytest

import vcran
from tests.conftest import ROOT
from vcran.cli import main


@pytest.mark.slow
def test_report_of_the_warehouse_shows_the_job_kpis(tmp_path, capsys):
    vcran.simulate(ROOT / "scenarios" / "warehouse.toml", out=tmp_path / "run")
    summary = json.loads((tmp_path / "run" / "summary.json").read_text())
    assert main(["report", str(tmp_path / "run"), "--out", str(tmp_path / "report")]) == 0
    printed = capsys.readouterr().out
    md = (tmp_path / "report" / "kpi.md").read_text()
    jobs = summary["jobs"]
    for text in (md, printed):
        assert f"| jobs arrived       |   {jobs['arrived']} |" in text
        assert f"| lead time p95 (s)  |  {jobs['lead_time']['p95']:.1f} |" in text
    assert "## Jobs" in md
    # the summary's utilisation (the model's state changes) and the report's busy share (the events'
    # state spans) are computed independently: they agree
    fleet_row = next(line for line in md.splitlines() if line.startswith("| **fleet**"))
    assert f"**{summary['utilisation']['fleet']:.1%}**" in fleet_row
    assert f"| fleet utilisation  | {summary['utilisation']['fleet']:.1%} |" in md


def test_report_of_a_scripted_run_has_no_job_section(tmp_path, capsys):
    vcran.simulate(ROOT / "scenarios" / "demo.toml", out=tmp_path / "run")
    assert main(["report", str(tmp_path / "run"), "--out", str(tmp_path / "report")]) == 0
    assert "Jobs" not in (tmp_path / "report" / "kpi.md").read_text()


def test_the_fleet_figure_counts_jobs_waiting_done_and_robots_busy_over_time(tmp_path):
    from tests.sim.test_dispatcher import job, scenario
    from vcran.managers import Dispatcher
    from vcran.report import read_run, write_report
    from vcran.report.fleet import fleet_series
    from vcran.report.spans import histories

    # one robot, jobs at t = 0 and t = 1: the second waits for the robot until the first is done
    result = vcran.simulate(scenario(job(0, "first") + job(1, "second")), manager=Dispatcher(),
                            out=tmp_path / "run")
    run = read_run(tmp_path / "run")
    s = fleet_series(run, histories(run))
    at = lambda t, curve: curve[max(i for i, x in enumerate(s.t) if x <= t)]  # noqa: E731 - value at t
    first, second = result.job("first"), result.job("second")
    assert at(0.5, s.waiting) == 0 and at(1.5, s.waiting) == 1  # first went at once, second waits
    assert at(first.ended - 0.01, s.waiting) == 1 and at(first.ended + 0.01, s.waiting) == 0
    assert at(first.ended - 0.01, s.done) == 0 and at(first.ended, s.done) == 1
    assert at(second.ended - 0.01, s.done) == 1 and at(second.ended, s.done) == 2 == s.done[-1]
    assert max(s.busy) == 1 and s.busy[-1] == 0 and s.failed[-1] == 0 and s.t[0] == 0.0
    # the busy area is the model's utilisation (computed in the simulation, not from these events)
    assert abs(s.busy_seconds() / run.sim_time - result.summary["utilisation"]["fleet"]) < 1e-9
    report = write_report(tmp_path / "run", tmp_path / "report")
    assert tmp_path / "report" / "fleet.png" in report.files
    assert (tmp_path / "report" / "fleet.png").read_bytes()[:4] == b"\x89PNG"


def test_a_scripted_run_gets_no_fleet_figure(tmp_path):
    from vcran.report import write_report

    vcran.simulate(ROOT / "scenarios" / "demo.toml", out=tmp_path / "run")
    report = write_report(tmp_path / "run", tmp_path / "report")
    assert not any(f.name.startswith("fleet.") for f in report.files)
