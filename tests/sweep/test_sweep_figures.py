"""Comparison figures (docs/contract.md §10): each KPI against a swept parameter, the mean over seeds with its min-max range
and the single runs, one line per value of the other parameters. Rows are made up by hand, so the
expected points are plain arithmetic."""

from __future__ import annotations

import pytest

from tests.conftest import ROOT
from vcran.sweep.spec import load

pytest.importorskip("matplotlib")

#: tasks_completed of the demo sweep's runs, by (max_velocity, task_timeout), over seeds 1, 2, 3.
MADE_UP = {(0.5, 1.5): [0, 1, 2], (0.5, 30.0): [3, 3, 3], (1.0, 1.5): [1, 1, 4], (1.0, 30.0): [2, 3, 4]}


def made_up_rows():
    sweep = load(ROOT / "scenarios" / "sweeps" / "demo-sweep.toml")  # grid: task_timeout [1.5, 30.0] x max_velocity [0.5, 1.0]
    rows = []
    for spec in sweep.runs():
        params = dict(spec.variant.params)
        timeout, velocity = params["simulation.task_timeout"], params["robots.*.max_velocity"]
        rows.append({**params, "seed": spec.seed, "error": None,
                     "tasks_completed": MADE_UP[(velocity, timeout)][spec.seed - 1]})
    return sweep, rows


def rounded(points):
    return [tuple(round(float(v), 6) for v in p) for p in points]


def test_a_kpi_against_a_parameter_is_mean_range_and_runs_per_value_of_the_others():
    from matplotlib.collections import PathCollection

    from vcran.sweep.figures import figure

    sweep, rows = made_up_rows()
    fig = figure(sweep, rows, "simulation.task_timeout", ["robots.*.max_velocity"], ["tasks_completed"])
    (ax,) = fig.axes
    assert ax.get_title() == "tasks_completed"
    assert [t.get_text() for t in ax.get_xticklabels()] == ["1.5", "30.0"]
    # two lines, velocity 0.5 left of each tick and 1.0 right of it (0.04 either side)
    points, ranges = [], []
    for bars in ax.containers:
        line, _, (vertical,) = bars.lines
        points.append(rounded(line.get_xydata()))
        ranges.append(rounded([(x0, low, high) for (x0, low), (_, high) in vertical.get_segments()]))
    assert points == [[(-0.04, 1), (0.96, 3)], [(0.04, 2), (1.04, 3)]]
    assert ranges == [[(-0.04, 0, 2), (0.96, 3, 3)], [(0.04, 1, 4), (1.04, 2, 4)]]
    dots = [sorted(rounded(c.get_offsets())) for c in ax.collections if isinstance(c, PathCollection)]
    assert dots == [sorted([(-0.04, 0), (-0.04, 1), (-0.04, 2), (0.96, 3), (0.96, 3), (0.96, 3)]),
                    sorted([(0.04, 1), (0.04, 1), (0.04, 4), (1.04, 2), (1.04, 3), (1.04, 4)])]
    assert [t.get_text() for t in fig.legends[0].get_texts()] == [
        "robots.*.max_velocity = 0.5", "robots.*.max_velocity = 1.0"]


def test_failed_runs_are_left_out_and_a_figure_per_parameter_is_written(tmp_path):
    from vcran.sweep.figures import draw

    sweep, rows = made_up_rows()
    rows[0] = {**rows[0], "error": "RuntimeError: boom", "tasks_completed": None}
    files = draw(sweep, rows, tmp_path, "svg")
    assert [f.name for f in files] == ["kpi-by-simulation.task_timeout.svg", "kpi-by-robots.each.max_velocity.svg"]
    assert all(f.stat().st_size > 0 for f in files)
    assert draw(sweep, [{**r, "error": "x"} for r in rows], tmp_path, "svg") == []


def test_a_panel_per_kpi_the_runs_have_and_collisions_only_when_some_run_had_one():
    from vcran.sweep.figures import drawn

    plain = {"sim_time": 9.0, "tasks_completed": 3, "tasks_cancelled": 0, "distance": 4.0, "errors": 0,
             "collisions": 0}
    assert drawn([plain, plain]) == ["sim_time", "tasks_completed", "tasks_cancelled", "distance", "errors"]
    loop = {**plain, "collisions": 1, "battery_used": 0.5, "jobs_done_per_hour": 120.0}
    assert drawn([plain, loop]) == ["sim_time", "tasks_completed", "tasks_cancelled", "distance", "errors",
                                    "collisions", "battery_used", "jobs_done_per_hour"]
