"""``vcran run SCENARIO --out DIR [--manager module:Class]`` (docs/contract.md §8, §9): the closed loop from the CLI."""

from __future__ import annotations

import json

import pytest

from tests.conftest import ROOT
from vcran.cli import main

DEMO = str(ROOT / "scenarios" / "demo.toml")
WAREHOUSE = str(ROOT / "scenarios" / "warehouse.toml")


@pytest.mark.slow
def test_warehouse_runs_with_its_own_manager_and_prints_the_kpis(tmp_path, capsys):
    assert main(["run", WAREHOUSE, "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    summary = json.loads((tmp_path / "summary.json").read_text())
    jobs = summary["jobs"]
    assert f"jobs arrived {jobs['arrived']}, completed {jobs['arrived']}, failed 0, open 0" in out
    assert "lead time p50" in out and "utilisation" in out


def test_manager_option_overrides_the_scenarios(tmp_path, capsys):
    code = main(["run", WAREHOUSE, "--out", str(tmp_path), "--quiet", "--manager", "vcran.core.opil.manager:FleetManager"])
    assert code == 0  # the do-nothing base class: jobs arrive and stay open
    jobs = json.loads((tmp_path / "summary.json").read_text())["jobs"]
    assert jobs["completed"] == 0 and jobs["open"] == jobs["arrived"] > 0


@pytest.mark.parametrize("args, message", [
    (["--manager", "no_such_module:X"], "vcran run: fleet manager 'no_such_module:X': cannot import no_such_module"),
    (["--manager", "vcran.managers:Dispatcher"], "vcran run: "),
])
def test_bad_manager_or_scripted_scenario_with_a_manager_is_one_line_and_exit_2(tmp_path, capsys, args, message):
    scenario = WAREHOUSE if "no_such" in args[1] else DEMO
    assert main(["run", scenario, "--out", str(tmp_path), "--quiet", *args]) == 2
    err = capsys.readouterr().err
    assert err.startswith(message) and err.count("\n") == 1 and "Traceback" not in err


def test_manager_options_the_class_refuses_are_exit_2_and_write_nothing(tmp_path, capsys):
    """``[manager] options = { max_tries = 0 }``: the Dispatcher's ValueError is the user's mistake, one line
    and exit 2 before any folder exists, not "a bug in vcran" (exit 70)."""
    scenario = tmp_path / "w.toml"
    scenario.write_text((ROOT / "scenarios" / "warehouse.toml").read_text().replace(
        "options = { max_tries = 3 }", "options = { max_tries = 0 }"))
    out = tmp_path / "out"
    assert main(["run", str(scenario), "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("vcran run: cannot build fleet manager vcran.managers.dispatcher:Dispatcher")
    assert "ValueError: max_tries must be at least 1" in err and err.count("\n") == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["w.toml"]


def test_a_manager_module_in_the_current_folder_imports_as_docs_library_shows(tmp_path, capsys, monkeypatch):
    """``vcran run scenarios/warehouse.toml --out DIR --manager my_module:FirstIdle`` (docs/library.md) with
    my_module.py in the current folder: the console script, unlike ``python -m``, has no current folder
    on sys.path, so it said "No module named 'my_module'"."""
    import sys

    (tmp_path / "vcran_review_here.py").write_text(
        "import vcran\n\nclass Idle(vcran.FleetManager):\n    '''Takes no job.'''\n")
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(sys, "path", [p for p in sys.path if p not in ("", ".", str(tmp_path))])
    monkeypatch.delitem(sys.modules, "vcran_review_here", raising=False)
    out = tmp_path / "out"
    assert main(["run", WAREHOUSE, "--out", str(out), "--quiet", "--manager", "vcran_review_here:Idle"]) == 0
    jobs = json.loads((out / "summary.json").read_text())["jobs"]
    assert jobs["completed"] == 0 and jobs["open"] == jobs["arrived"] > 0
    assert main(["run", WAREHOUSE, "--out", str(out), "--quiet", "--manager", "not_here_either:Idle"]) == 2
    assert "cannot import not_here_either: No module named 'not_here_either'" in capsys.readouterr().err


@pytest.mark.slow  # whole runs of the warehouse are (README, "Development")
def test_vda5050_warehouse_runs_its_master_in_the_closed_loop_deterministically_and_its_replay_verifies(tmp_path, capsys):
    """issue 31 item 5, docs/contract.md §9, §11: ``vcran run vda5050-warehouse`` runs the scenario's reference master
    (MasterControl, max_tries = 3) against the simulated vehicles. Every job of the seeded stream arrives and is
    completed (none failed, none open: the count is the stream's own, ``Scenario.workload``); two runs write
    byte-identical folders (docs/contract.md §5); ``vcran replay --verify`` re-runs the orders as recorded (raw,
    decoded and validated by the vehicles again) to the same records, legs and events (docs/contract.md §6)."""
    from vcran.io.scenario_file import load

    first, second = tmp_path / "first", tmp_path / "second"
    assert main(["run", "vda5050-warehouse", "--out", str(first)]) == 0
    arrived = len(list(load(ROOT / "scenarios" / "vda5050-warehouse.toml").workload()))
    assert f"jobs arrived {arrived}, completed {arrived}, failed 0, open 0" in capsys.readouterr().out
    assert main(["run", "vda5050-warehouse", "--out", str(second), "--quiet"]) == 0
    for name in ("summary.json", "trace.jsonl.zst", "events.jsonl.zst", "legs.npy"):
        assert (first / name).read_bytes() == (second / name).read_bytes(), name
    assert main(["replay", str(first), "--verify", "--quiet"]) == 0


@pytest.mark.parametrize("argv", [
    ["send", "vda5050", "--orion", "http://127.0.0.1:9"],
    ["orion", "init", "vda5050", "--orion", "http://127.0.0.1:9"],
])
def test_every_scenario_command_refuses_a_vda5050_scenario_before_it_connects(tmp_path, capsys, monkeypatch, argv):
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "[simulation] protocol = 'vda5050': the simulation does not host VDA 5050 vehicles yet" in err
    assert err.startswith(f"vcran {argv[0]}: ") and err.count("\n") == 1
    assert list(tmp_path.iterdir()) == []
