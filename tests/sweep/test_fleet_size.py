"""Sweeping the fleet's size, and readable labels for list- and table-valued parameters (issue 29 item 11;
docs/sweeps.md): ``robots.count = [2, 5, 10]`` instead of spelling out the robots array, which the runs
table and the figures' axis showed as ``[{"id": "robot_1", ...``.

The expected poses are derived by hand from scenarios/warehouse.toml's layout (docs/sweeps.md's rule):
robots 1-5 at x = -8, -4, 0, 4, 8 on y = 2, robots 6-10 the same on y = -2; extent along y 4 m, closest
two robots 4 m apart (more than the default footprint's width, 2 x hypot(0.87, 0.35) = 1.88 m), so each
copy of the layout stands 4 + 4 = 8 m further along +y: copies of robots 1-5 on y = 10, of 6-10 on y = 6.
"""

from __future__ import annotations

import csv
import tomllib

import pytest

from tests.conftest import ROOT
from vcran.cli import main
from vcran.sweep.labels import Labels, label
from vcran.sweep.overrides import OverrideError, apply
from vcran.sweep.spec import SweepError, load

WAREHOUSE = ROOT / "scenarios" / "warehouse.toml"
DEMO = ROOT / "scenarios" / "demo.toml"


def robots(path, *overrides):
    data = apply(tomllib.loads(path.read_text()), list(overrides))
    return [(r["id"], r["pose"]) for r in data["robots"]], data


def test_fewer_robots_are_the_scenarios_first_ones():
    fleet, _ = robots(WAREHOUSE, ("robots.count", 2))
    assert fleet == [("robot_1", [-8.0, 2.0, 0.0]), ("robot_2", [-4.0, 2.0, 0.0])]
    assert len(robots(WAREHOUSE, ("robots.count", 10))[0]) == 10


def test_more_robots_copy_the_layout_8_m_further_along_y():
    fleet, data = robots(WAREHOUSE, ("robots.count", 21))
    assert fleet[10:] == [
        ("robot_11", [-8.0, 10.0, 0.0]), ("robot_12", [-4.0, 10.0, 0.0]), ("robot_13", [0.0, 10.0, 0.0]),
        ("robot_14", [4.0, 10.0, 0.0]), ("robot_15", [8.0, 10.0, 0.0]),
        ("robot_16", [-8.0, 6.0, 0.0]), ("robot_17", [-4.0, 6.0, 0.0]), ("robot_18", [0.0, 6.0, 0.0]),
        ("robot_19", [4.0, 6.0, 0.0]), ("robot_20", [8.0, 6.0, 0.0]),
        ("robot_21", [-8.0, 18.0, 0.0]),  # the second copy: 16 m along
    ]
    original = data["robots"][0]  # every other setting is the original's
    assert {k: v for k, v in data["robots"][10].items() if k not in ("id", "pose")} == \
        {k: v for k, v in original.items() if k not in ("id", "pose")}


def test_one_robot_is_copied_a_footprints_width_apart():
    """The demo's one robot at the origin, default footprint: its farthest corner hypot(0.87, 0.35) =
    0.938 m from the pose, so copies stand 1.876 m apart, rounded up to 1.9 m."""
    fleet, _ = robots(DEMO, ("robots.count", 3))
    assert fleet == [("robot_1", [0.0, 0.0, 0.0]), ("robot_2", [0.0, 1.9, 0.0]), ("robot_3", [0.0, 3.8, 0.0])]


def test_the_count_comes_first_so_other_paths_reach_the_copies():
    _, data = robots(WAREHOUSE, ("robots.*.max_velocity", 0.5), ("robots.robot_12.pose", [0.0, 20.0, 1.0]),
                     ("robots.count", 12))
    assert [r["max_velocity"] for r in data["robots"]] == [0.5] * 12
    assert data["robots"][11]["pose"] == [0.0, 20.0, 1.0]


def test_a_copys_id_skips_ids_in_use():
    data = {"robots": [{"id": "robot_3"}, {"id": "a"}]}
    assert [r["id"] for r in apply(data, [("robots.count", 4)])["robots"]] == ["robot_3", "a", "robot_4", "robot_5"]


@pytest.mark.parametrize("value", [0, -1, 2.5, True, "3", [2]])
def test_a_count_that_is_no_count(value):
    with pytest.raises(OverrideError, match=r"^'robots.count': the number of robots: an integer of at least 1, got "):
        apply(tomllib.loads(DEMO.read_text()), [("robots.count", value)])


def test_bad_counts_in_a_sweep_file_name_the_variant(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(f'scenario = "{DEMO.as_posix()}"\nseeds = [1]\n[grid]\n"robots.count" = [2, 0]\n')
    with pytest.raises(SweepError, match=r"variant 1 \(robots.count = 0\): 'robots.count': the number of robots"):
        load(path)
    # fewer robots than the script names: the loader's own words, for the variant that has too few
    faults = ROOT / "scenarios" / "faults.toml"
    path.write_text(f'scenario = "{faults.as_posix()}"\nseeds = [1]\n[grid]\nrobots.count = [4, 3]\n')
    with pytest.raises(SweepError, match=r"variant 1 \(robots.count = 3\): .*robot_4"):
        load(path)


def test_labels_of_lists_and_tables():
    three = [{"id": f"robot_{i}", "pose": [float(i), 0.0, 0.0]} for i in (1, 2, 3)]
    assert label("robots", three) == "3 robots: robot_1, robot_2, robot_3"
    assert label("robots", [{"id": f"r{i}"} for i in range(1, 11)]) == "10 robots: r1, r2, …, r10"
    assert label("stations.0.area", [{"x": 1}]) == "1 area"
    assert label("robots.0.pose", [1.0, 0.0, 0.5]) == "[1.0, 0.0, 0.5]"
    assert label("manager.options", {"max_tries": 2, "name": "x", "on": True}) == '{max_tries = 2, name = "x", on = true}'
    assert label("manager.options", {}) == "{}"
    moved = [dict(r, pose=[9.0, 9.0, 0.0]) for r in three]
    labels = Labels("robots", [three, moved, three])  # the same ids, other poses: numbered apart
    assert (labels(three), labels(moved)) == ("3 robots: robot_1, robot_2, robot_3 #1",
                                              "3 robots: robot_1, robot_2, robot_3 #2")


@pytest.mark.slow
def test_a_fleet_size_sweep_runs_and_its_table_and_figure_read_well(tmp_path):
    """The warehouse's first 300 s of jobs with 2, 3 and 12 robots, and a variant that spells its two
    robots out: the runs table says ``2 robots: robot_1, robot_2`` for it, never the array's JSON."""
    pytest.importorskip("matplotlib")
    spelled = tomllib.loads(WAREHOUSE.read_text())["robots"][:2]
    inline = ", ".join("{" + ", ".join(f"{k} = {v!r}".replace("'", '"') for k, v in r.items()) + "}" for r in spelled)
    path = tmp_path / "s.toml"
    path.write_text(f'scenario = "warehouse"\nseeds = [1]\n'
                    f'[grid]\n"job_stream.until" = [240.0]\n'
                    f'[[variants]]\nrobots.count = 2\n[[variants]]\nrobots.count = 3\n[[variants]]\nrobots.count = 12\n'
                    f'[[variants]]\nname = "spelled"\nrobots = [{inline}]\n')
    out = tmp_path / "out"
    assert main(["sweep", str(path), "--out", str(out), "--workers", "1", "--quiet"]) == 0
    table = list(csv.DictReader((out / "runs.csv").open()))
    assert [r["robots.count"] for r in table] == ["2", "3", "12", ""]
    assert table[3]["robots"] == "2 robots: robot_1, robot_2"
    assert all(int(r["jobs_arrived"]) > 0 and r["jobs_completed"] == r["jobs_arrived"] for r in table)
    assert (out / "kpi-by-robots.count.png").is_file() and (out / "kpi-by-robots.png").is_file()

    from vcran.sweep.figures import figure

    sweep = load(path)
    rows = [{"robots": spelled, "seed": 1, "error": None, "distance": 1.0}]
    (ax,) = figure(sweep, rows, "robots", [], ["distance"]).axes
    assert [t.get_text() for t in ax.get_xticklabels()] == ["2 robots: robot_1,\nrobot_2"]
