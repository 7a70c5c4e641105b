"""Sweep files (docs/contract.md §10): seeds, grid × variants in a fixed order, dotted paths into the scenario, and strict
errors that name the file, the variant and the field."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

import pytest

from tests.conftest import ROOT
from vcran.sweep.overrides import OverrideError, apply
from vcran.sweep.spec import SweepError, load

DEMO = ROOT / "scenarios" / "demo.toml"


def write(tmp_path: Path, text: str, scenario: Path = DEMO) -> Path:
    (tmp_path / "sub").mkdir(exist_ok=True)
    (tmp_path / "sub" / "base.toml").write_text(scenario.read_text())
    path = tmp_path / "s.toml"
    path.write_text('scenario = "sub/base.toml"\n' + text)
    return path


def test_grid_times_variants_times_seeds_in_variant_major_order(tmp_path):
    sweep = load(write(tmp_path, """
seeds = {from = 5, count = 2}
[grid]
"simulation.task_timeout" = [10.0, 20.0]
robots.robot_1.capacity = [1, 2]       # unquoted: nested tables are dotted paths too
[[variants]]
name = "base"
[[variants]]
name = "far"
"robots.0.pose" = [1.0, 0.0, 0.0]
"""))
    assert sweep.seeds == (5, 6)
    assert sweep.scenario_path == tmp_path / "sub" / "base.toml"  # relative to the sweep file
    assert sweep.parameters == ("robots.0.pose", "simulation.task_timeout", "robots.robot_1.capacity")
    runs = sweep.runs()
    assert len(runs) == 2 * 2 * 2 * 2
    assert [r.index for r in runs] == list(range(16))
    first, second, last = runs[0], runs[1], runs[-1]
    assert (first.variant.label, first.seed, first.variant.params) == (
        "base", 5, (("simulation.task_timeout", 10.0), ("robots.robot_1.capacity", 1)))
    assert second.variant is first.variant and second.seed == 6
    assert runs[2].variant.params[-1] == ("robots.robot_1.capacity", 2)  # the last grid key turns fastest
    assert (last.variant.label, last.seed, last.variant.params) == (
        "far", 6, (("robots.0.pose", [1.0, 0.0, 0.0]), ("simulation.task_timeout", 20.0),
                   ("robots.robot_1.capacity", 2)))
    assert last.overrides[-1] == ("simulation.seed", 6)


def test_seed_list_and_no_grid_is_one_variant(tmp_path):
    sweep = load(write(tmp_path, "seeds = [3, 1]\n"))
    assert [(r.seed, r.variant.params) for r in sweep.runs()] == [(3, ()), (1, ())]


def test_paths_select_by_wildcard_index_and_id_and_create_missing_tables():
    data = {"simulation": {}, "robots": [{"id": "a", "v": 1}, {"id": "b", "v": 1}]}
    assert apply(data, [("robots.*.v", 2)])["robots"] == [{"id": "a", "v": 2}, {"id": "b", "v": 2}]
    assert apply(data, [("robots.1.v", 3)])["robots"][1] == {"id": "b", "v": 3}
    assert apply(data, [("robots.a.v", 4)])["robots"][0] == {"id": "a", "v": 4}
    assert apply(data, [("job_stream.rate", 5.0)])["job_stream"] == {"rate": 5.0}
    assert apply(data, [("manager", "pkg:Mine")])["manager"] == {"class": "pkg:Mine"}  # the alias
    assert data == {"simulation": {}, "robots": [{"id": "a", "v": 1}, {"id": "b", "v": 1}]}  # not touched


@pytest.mark.parametrize(("path", "message"), [
    ("robots.c.v", "has no entry with id 'c'"),
    ("robots.2.v", "has 2 entries; index 2 is past its end"),
    ("robots.*", "name a field inside it"),
    ("simulation.seed.x", "is a value (1), not a table"),
    ("simulation..x", "an empty key"),
])
def test_paths_that_lead_nowhere_say_where_they_stopped(path, message):
    data = {"simulation": {"seed": 1}, "robots": [{"id": "a"}, {"id": "b"}]}
    with pytest.raises(OverrideError, match=re.escape(message)):
        apply(data, [(path, 0)])


@pytest.mark.parametrize(("text", "message"), [
    ("seeds = [1]\ncolour = 1\n", r"s\.toml: field 'colour': unknown key"),
    ("seeds = []\n", r"field 'seeds': expected a non-empty list"),
    ("seeds = [1, 1]\n", r"field 'seeds': \[1, 1\] repeats a seed"),
    ("seeds = {from = 1}\n", r"seeds: field 'count': missing"),
    ("seeds = {from = 1, count = 0}\n", r"seeds: field 'count': must be at least 1"),
    ("seeds = [1, 9223372036854775808]\n", r"field 'seeds': 9223372036854775808 is outside TOML's 64-bit integer"),
    ("seeds = {from = 9223372036854775807, count = 2}\n", r"the last seed, 9223372036854775808, is outside TOML's"),
    ("seeds = [1]\n[grid]\n\"simulation.task_timeout\" = []\n", r"grid: field 'simulation.task_timeout': expected a non-empty list"),
    ("seeds = [1]\n[grid]\n\"simulation.task_timeout\" = 3.0\n", "expected a non-empty list of values"),
    ("seeds = [1]\n[grid]\n\"simulation.seed\" = [1, 2]\n", "the seed is swept by 'seeds'"),
    ("seeds = [1]\n[grid]\n\"simulation.task_timeout\" = [1.0]\n[[variants]]\n\"simulation.task_timeout\" = 2.0\n",
     "also in \\[grid\\]"),
    ("seeds = [1]\n[grid]\nmanager = [\"a:B\"]\n\"manager.class\" = [\"c:D\"]\n", "names the same field as 'manager'"),
    ("seeds = [1]\n[[variants]]\nname = \"a\"\n[[variants]]\nname = \"a\"\n", "two are named 'a'"),
])
def test_bad_sweep_files_fail_before_running(tmp_path, text, message):
    with pytest.raises(SweepError, match=message):
        load(write(tmp_path, text))


def test_a_value_the_scenario_refuses_names_the_variant_and_the_scenario_field(tmp_path):
    path = write(tmp_path, '''seeds = [1]
[grid]
"simulation.task_timeout" = [10.0, -1.0]
''')
    with pytest.raises(SweepError) as info:
        load(path)
    message = str(info.value)
    assert message.startswith(f"{path}: variant 1 (simulation.task_timeout = -1.0): ")
    assert message.endswith("sub/base.toml: simulation: field 'task_timeout': must be positive, got -1.0")


def test_a_typo_in_a_path_is_the_scenario_loaders_unknown_key(tmp_path):
    path = write(tmp_path, '''seeds = [1]
[grid]
"robots.*.max_velocityy" = [1.0]
''')
    with pytest.raises(SweepError, match=r"robots\[0\]: field 'max_velocityy': unknown key \(a typo\?\)"):
        load(path)


def test_missing_scenario_and_broken_toml(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text('scenario = "nowhere.toml"\nseeds = [1]\n')
    with pytest.raises(SweepError, match=r"field 'scenario': .*nowhere\.toml: no such file"):
        load(bad)
    bad.write_text("scenario = \n")
    with pytest.raises(SweepError, match="not valid TOML"):
        load(bad)
    with pytest.raises(SweepError, match="no such file"):
        load(tmp_path / "absent.toml")


def test_the_demo_sweep_is_what_its_comment_says():
    sweep = load(ROOT / "scenarios" / "sweeps" / "demo-sweep.toml")
    assert len(sweep.runs()) == 2 * 2 * 3
    assert tomllib.loads(sweep.scenario_text) == tomllib.loads(DEMO.read_text())


def test_the_fleet_size_sweep_is_what_its_comment_says():
    """issue 29 items 10 and 11: the bundled warehouse by name, four fleet sizes, one seed."""
    sweep = load(ROOT / "scenarios" / "sweeps" / "fleet-size.toml")
    assert sweep.scenario_text == (ROOT / "scenarios" / "warehouse.toml").read_text()
    assert [r.variant.params for r in sweep.runs()] == [(("robots.count", n),) for n in (4, 7, 10, 14)]


def test_a_broken_scenario_is_the_scenario_loaders_message_behind_the_sweep_file(tmp_path):
    broken = tmp_path / "broken.toml"
    broken.write_text(DEMO.read_text().replace("task_timeout = 30.0", "task_timeout = 0.0"))
    path = write(tmp_path, "seeds = [1]\n", scenario=broken)
    with pytest.raises(SweepError, match=r"s\.toml: field 'scenario': .*base\.toml: simulation: field 'task_timeout': "
                                         r"must be positive"):
        load(path)


def test_an_empty_table_clears_what_the_scenario_had_there(tmp_path):
    # docs/contract.md §10, docs/sweeps.md: the warehouse's [manager] options are the Dispatcher's; a variant comparing a
    # class that takes none must be able to clear them ({} used to flatten into no path at all)
    sweep = load(write(tmp_path, """
seeds = [1]
[[variants]]
name = "mine"
manager = "mypkg.fleet:Mine"
"manager.options" = {}
""", ROOT / "scenarios" / "warehouse.toml"))
    (run,) = sweep.runs()
    assert run.variant.params == (("manager", "mypkg.fleet:Mine"), ("manager.options", {}))
    data = tomllib.loads((ROOT / "scenarios" / "warehouse.toml").read_text())
    assert data["manager"]["options"] == {"max_tries": 3}
    assert apply(data, run.variant.params)["manager"] == {"class": "mypkg.fleet:Mine", "options": {}}


def test_a_bundled_scenario_by_name(tmp_path, capsys):
    """issue 29 item 10: ``scenario = "warehouse"`` names the bundled scenario, as ``vcran run warehouse``
    does, when no file of that name is beside the sweep file; a file there wins, as in the current folder
    for ``vcran run``; a name that is neither says which names are bundled."""
    from vcran.cli import main
    from vcran.io.scenario_file import bundled

    path = tmp_path / "s.toml"
    path.write_text('scenario = "demo"\nseeds = [1]\n[grid]\n"simulation.task_timeout" = [1.5, 30.0]\n')
    sweep = load(path)
    assert sweep.scenario_path == bundled()["demo"] and sweep.scenario_text == DEMO.read_text()
    out = tmp_path / "out"
    assert main(["sweep", str(path), "--out", str(out), "--workers", "1", "--quiet"]) == 0
    rows = (out / "runs.csv").read_text().splitlines()
    assert len(rows) == 3  # the header and the two variants, run on the demo
    (tmp_path / "demo").write_text(DEMO.read_text().replace("task_timeout = 30.0", "task_timeout = 20.0"))
    assert load(path).scenario_path == tmp_path / "demo"
    path.write_text('scenario = "nosuch"\nseeds = [1]\n')
    with pytest.raises(SweepError, match=r"^.*s\.toml: field 'scenario': .*nosuch: no such file \(and no bundled "
                                         r"scenario of that name; bundled: .*demo.*warehouse"):
        load(path)
