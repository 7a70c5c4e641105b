"""`vcran report` and docs/contract.md §4: battery curves, incidents on the figures, energy per job, downtime and
collisions in the KPI tables; figures from docs/robots.md's hand derivations."""

from __future__ import annotations

import csv
import io

import pytest

from tests.conftest import ROOT, run_scenario
from vcran.io.scenario_file import load
from vcran.report import read_run, write_report
from vcran.report.incidents import downtime, incidents
from vcran.report.kpi import kpis
from vcran.report.spans import histories
from vcran.report.tables import csv_text, markdown

pytest.importorskip("matplotlib")


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    base = tmp_path_factory.mktemp("s4")
    return {name: run_scenario(load(ROOT / "scenarios" / f"{name}.toml"), base / name).dir
            for name in ("battery", "faults", "crossing", "demo")}


def rows_of(path):
    run = read_run(path)
    return run, {k.robot: k for k in kpis(run, histories(run))}


def test_s4_energy_per_job_and_downtime_of_the_battery_run(runs):
    run, rows = rows_of(runs["battery"])
    # drawn: 0.5 Ah to empty, 0.01 Ah idle after the swap, 0.1 Ah for 10 m; one completed task
    assert rows["robot_1"].energy_per_job == pytest.approx(0.61)
    assert rows["robot_1"].downtime == pytest.approx(30.0)  # empty at 50, swapped at 80
    assert rows["robot_1"].cancelled["battery_empty"] == 1
    assert run.batteries["robot_1"][0] == (0.0, 0.5) and run.batteries["robot_1"][-1][1] == 1.0


def test_s4_downtime_of_the_faults_run(runs):
    run, rows = rows_of(runs["faults"])
    # breakdown 7.5 s (robot_1), paused 3 -> 6 (robot_3); a motion failure and a link down hold nothing
    assert downtime(run) == {"robot_1": 7.5, "robot_2": 0.0, "robot_3": 3.0, "robot_4": 0.0}
    assert rows["fleet"].downtime == 10.5
    assert rows["robot_2"].cancelled["motion_failed"] == 1


def test_s4_collisions_counted_once_for_the_fleet(runs):
    run, rows = rows_of(runs["crossing"])
    assert rows["robot_1"].collisions == rows["robot_2"].collisions == 1
    assert rows["fleet"].collisions == 1
    (hit,) = [i for i in incidents(run) if i.kind == "collision"]
    assert hit.place == (pytest.approx(-0.5, abs=1e-6), pytest.approx(-0.5, abs=1e-6))


def test_s4_columns_appear_only_when_a_run_has_them(runs):
    _, plain = rows_of(runs["demo"])
    header = next(csv.reader(io.StringIO(csv_text(list(plain.values())))))
    assert "downtime_s" not in header and "collisions" not in header
    _, rows = rows_of(runs["battery"])
    header = next(csv.reader(io.StringIO(csv_text(list(rows.values())))))
    assert header[-6:] == ["cancelled_battery_empty", "cancelled_motion_failed", "cancelled_collision",
                           "energy_per_job_ah", "downtime_s", "collisions"]
    assert "| energy per job (Ah) |" in markdown(list(rows.values())).splitlines()[0].replace("  ", " ")


@pytest.mark.slow
def test_s4_report_draws_the_battery_figure_only_for_runs_with_batteries(runs, tmp_path):
    with_battery = write_report(runs["battery"], tmp_path / "b")
    assert "battery.png" in [f.name for f in with_battery.files]
    for name in ("faults", "crossing"):
        report = write_report(runs[name], tmp_path / name, fmt="svg")
        assert "battery.svg" not in [f.name for f in report.files]
    svg = (tmp_path / "crossing" / "layout.svg").read_text()
    assert "collision" in svg  # the legend names the incident drawn at its place
