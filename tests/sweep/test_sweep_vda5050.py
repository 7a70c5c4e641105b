"""``vcran sweep`` over a VDA 5050 scenario (issue 31 item 8, docs/contract.md §10, §11, docs/sweeps.md): the KPI
columns are filled with orders, counted as ``vcran report`` counts them (vcran.core.vda5050.outcomes).

Derived by hand from scenarios/vda5050.toml (orders at t = 1, 20, 45; 0.5 m/s^2 up and down; turns at
1 rad/s; pick and drop 5 s) with the AGV's top speed swept:

- 1.0 m/s: the demo (tests/sim/test_vda5050_glue.py): three orders completed, the last at 61.71, the run
  over at the tick 62; 2 + 2√2 + 8 + 6 m; one part; no error.
- 0.5 m/s: a leg of d m from rest to rest takes 1 s and 0.25 m each way plus (d - 0.5) / 0.5 s: order 100
  reaches n1 at 1 + 5 = 6, dock_1 at 6 + π/4 + 6.66 + π/4 = 14.23, picks until 19.23; order 200 starts at
  20 with a π/2 turn, two 4 m legs (9 s each) and a π/2 turn, on dock_2 at 41.14, drops until 46.14. Order
  300 arrives at 45 while 200 still executes: a new orderId then is rejected (§6.6.2, Figure 8 (3)), one
  orderError warning. The run ends at the first tick the vehicle is idle, 47: two orders completed, one
  rejected, 2 + 2√2 + 8 m, the part moved.
"""

from __future__ import annotations

import csv
import io
import math

import pytest

import vcran
from vcran.cli import main

SWEEP = """
scenario = "vda5050"
seeds = [1]
[grid]
"robots.*.max_velocity" = [0.5, 1.0]
"""


def test_a_sweep_of_the_vda5050_scenario_counts_its_orders(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "vda.toml").write_text(SWEEP)
    result = vcran.run_sweep("vda.toml", workers=1)
    assert result.failed == 0
    rows = {row["robots.*.max_velocity"]: row for row in result.rows}
    slow, demo = rows[0.5], rows[1.0]
    assert (slow["tasks_completed"], slow["rejected"], slow["tasks_cancelled"], slow["errors"]) == (2, 1, 0, 1)
    assert (demo["tasks_completed"], demo["rejected"], demo["tasks_cancelled"], demo["errors"]) == (3, 0, 0, 0)
    assert (slow["sim_time"], demo["sim_time"]) == (47.0, 62.0)
    assert slow["distance"] == pytest.approx(2 + 2 * math.sqrt(2) + 8)
    assert demo["distance"] == pytest.approx(2 + 2 * math.sqrt(2) + 8 + 6)
    assert slow["parts_moved"] == demo["parts_moved"] == 1
    assert slow["cancelled_timeout"] is None and demo["cancelled_timeout"] is None  # a vehicle has no task timeout


def test_vcran_sweep_writes_the_vda_columns_into_runs_csv(tmp_path, monkeypatch):
    """The command's table: ``rejected`` after the KPIs every run has, ``cancelled_timeout`` left empty; the
    comparison figure is drawn."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "vda.toml").write_text(SWEEP)
    assert main(["sweep", "vda.toml", "--out", "out", "--workers", "1", "--quiet"]) == 0
    table = list(csv.DictReader(io.StringIO((tmp_path / "out" / "runs.csv").read_text())))
    assert [(r["robots.*.max_velocity"], r["tasks_completed"], r["rejected"], r["cancelled_timeout"]) for r in table] \
        == [("0.5", "2", "1", ""), ("1.0", "3", "0", "")]
    pytest.importorskip("matplotlib")
    assert (tmp_path / "out" / "kpi-by-robots.each.max_velocity.png").is_file()
