"""`vcran report` of a closed-loop run (SPEC §9, issue 10 item 8): the job KPIs next to the robots' table."""

from __future__ import annotations

import json

import vcran
from tests.conftest import ROOT
from vcran.cli import main


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
