"""``vcran fuzz`` (docs/contract.md §8): clean on the demo, deterministic per seed, and a shrunk failure is a scenario
file that reproduces the violation with ``vcran run``."""

from __future__ import annotations

import tempfile
from pathlib import Path

import pytest

from tests.conftest import ROOT
from vcran.cli import main
from vcran.core.opil.ranlogic import RanLogic
from vcran.testing.checks import run_variant
from vcran.testing.scripts import load_text

DEMO = str(ROOT / "scenarios" / "demo.toml")


@pytest.mark.slow
def test_demo_runs_clean_and_says_how_many_examples(capsys):
    assert main(["fuzz", DEMO, "--examples", "15", "--seed", "3"]) == 0
    out = capsys.readouterr().out
    assert "15 examples of" in out and "ran clean (seed 3)" in out and "examples/min" in out


@pytest.fixture
def r7_bug(monkeypatch):
    """A deliberate R7 bug: the timer only fires after the deadline, so it never cancels anything."""

    def on_timer(self, now, task_id):
        self._begin(now)
        return self._end()

    monkeypatch.setattr(RanLogic, "on_timer", on_timer)


@pytest.mark.slow
def test_violation_is_shrunk_saved_and_reproducible(r7_bug, tmp_path, capsys):
    saved = tmp_path / "fail.toml"
    assert main(["fuzz", DEMO, "--examples", "50", "--seed", "1", "--fast", "--save", str(saved)]) == 1
    text = saved.read_text()
    assert "(R7)" in text and text in capsys.readouterr().out
    with tempfile.TemporaryDirectory() as work:  # the saved file is a scenario that fails the same way
        assert any("(R7)" in p for p in run_variant(load_text(text), Path(work), again=False))
    again = tmp_path / "again.toml"
    assert main(["fuzz", DEMO, "--examples", "50", "--seed", "1", "--fast", "--save", str(again)]) == 1
    assert again.read_text().replace("again.toml", "") == text.replace("fail.toml", "")  # same seed, same result


@pytest.mark.slow
def test_the_failure_s_header_names_every_option_of_its_search(r7_bug, tmp_path, capsys):
    # docs/fuzzing.md, docs/sweeps.md: the header names the one command that finds the failure again; it
    # left out --max-ops, --window and --fast, whose defaults search other examples
    saved, again = tmp_path / "fail.toml", tmp_path / "again.toml"
    options = ["--max-ops", "2", "--window", "1", "--fast"]
    assert main(["fuzz", DEMO, "--examples", "30", "--seed", "4", *options, "--save", str(saved)]) == 1
    header = saved.read_text().splitlines()[0]
    assert header == f"# vcran fuzz {DEMO} --examples 30 --seed 4 --window 1 --max-ops 2 --fast: a minimal failing script"
    command = header.removeprefix("# vcran ").split(": a minimal")[0].split()
    assert main([*command, "--save", str(again)]) == 1
    assert again.read_text() == saved.read_text()


def test_a_save_that_cannot_be_written_is_refused_before_the_search(tmp_path, capsys):
    # a new user's mistake: the finding of a long search lost to a typo in --save (exit 2 at the end)
    assert main(["fuzz", DEMO, "--save", str(tmp_path / "no" / "such" / "x.toml")]) == 2
    assert "its folder does not exist" in capsys.readouterr().err
    assert main(["fuzz", DEMO, "--save", str(tmp_path)]) == 2
    assert "is a folder" in capsys.readouterr().err
    assert main(["fuzz", DEMO, "--max-ops", "0"]) == 2
    assert "--max-ops must be at least 1" in capsys.readouterr().err


@pytest.mark.parametrize("window", ["0", "-3"])
def test_a_window_below_1_is_refused(capsys, window):
    # docs/fuzzing.md: two messages within --window positions swap; 0 and -3 were taken as 1, silently
    assert main(["fuzz", DEMO, "--examples", "1", "--window", window]) == 2
    err = capsys.readouterr().err
    assert err == f"vcran fuzz: --window must be at least 1 (a swap moves a message by 1 to WINDOW positions), got {window}\n"


@pytest.mark.slow
def test_a_finding_that_cannot_be_saved_is_still_printed(r7_bug, tmp_path, capsys):
    unwritable = tmp_path / ("x" * 300 + ".toml")  # its folder exists; the name is too long to create
    assert main(["fuzz", DEMO, "--examples", "50", "--seed", "1", "--fast", "--save", str(unwritable)]) == 1
    out, err = capsys.readouterr()
    assert "(R7)" in out and "re-run: vcran run THIS_FILE" in out
    assert "could not be saved" in err and "copy it from above" in err


def test_bad_scenario_is_a_usage_error(tmp_path, capsys):
    assert main(["fuzz", str(tmp_path / "missing.toml")]) == 2
    assert "no such file" in capsys.readouterr().err


# --- a fleet manager in the loop (docs/contract.md §9) ------------------------------------------------------------------


def test_fuzzing_a_manager_saves_a_shrunk_failing_scenario_that_names_it(tmp_path, capsys):
    from dataclasses import replace

    import vcran
    from vcran.io.scenario_toml import dumps, loop_dict
    from vcran.testing.loop import check_jobs_ended

    warehouse = vcran.load_scenario(ROOT / "scenarios" / "warehouse.toml")
    small = replace(warehouse, robots=warehouse.robots[:2], settings=replace(warehouse.settings, duration=400.0))
    scenario = tmp_path / "small.toml"
    scenario.write_text(dumps(loop_dict(small)))
    assert main(["fuzz", str(scenario), "--examples", "5", "--seed", "1", "--jobs", "3", "--horizon", "30"]) == 0
    assert "vcran.managers:Dispatcher kept the loop properties on 5 examples" in capsys.readouterr().out

    saved = tmp_path / "fail.toml"
    manager = "tests.testing.loop_managers:NeverReplans"
    assert main(["fuzz", str(scenario), "--manager", manager, "--examples", "20", "--seed", "1", "--jobs", "3",
                 "--horizon", "30", "--save", str(saved)]) == 1
    text = saved.read_text()
    assert f'class = "{manager}"' in text and "# violation: job job_1" in text
    failing = vcran.load_scenario(saved)
    assert len(failing.jobs) == 1 and failing.manager.path == manager
    assert check_jobs_ended(vcran.simulate(failing)) and not check_jobs_ended(
        vcran.simulate(failing, manager=vcran.managers.Dispatcher))
    assert main(["fuzz", str(scenario), "--manager", "no.such:Manager"]) == 2
    assert "cannot import no.such" in capsys.readouterr().err


@pytest.mark.parametrize(("option", "value"), [("--horizon", "inf"), ("--horizon", "0"), ("--idle-bound", "nan"),
                                               ("--idle-bound", "inf"), ("--jobs", "0")])
def test_a_campaign_option_that_is_not_a_positive_number_is_a_usage_error(option, value, tmp_path, capsys):
    """``--horizon inf`` on a manager scenario without a duration was an internal error (exit 70): the job
    strategy draws arrival tenths up to ``int(horizon * 10)``."""
    from dataclasses import replace

    import vcran
    from vcran.io.scenario_toml import dumps, loop_dict

    warehouse = vcran.load_scenario(ROOT / "scenarios" / "warehouse.toml")
    open_ended = replace(warehouse, robots=warehouse.robots[:2], settings=replace(warehouse.settings, duration=None))
    scenario = tmp_path / "open.toml"
    scenario.write_text(dumps(loop_dict(open_ended)))
    assert main(["fuzz", str(scenario), "--examples", "1", option, value]) == 2
    assert f"{option} must be a finite number above 0, got {value}" in capsys.readouterr().err


def test_a_horizon_too_large_to_count_in_tenths_is_a_usage_error(tmp_path, capsys):
    """``--horizon 1e308`` passed the positive-and-finite check, then ``int(horizon * 10)`` overflowed in the
    job strategy: 'internal error', exit 70, as ``--horizon inf`` did (docs/contract.md §9, §8)."""
    from dataclasses import replace

    import vcran
    from vcran.io.scenario_toml import dumps, loop_dict

    warehouse = vcran.load_scenario(ROOT / "scenarios" / "warehouse.toml")
    open_ended = replace(warehouse, robots=warehouse.robots[:2], settings=replace(warehouse.settings, duration=None))
    scenario = tmp_path / "open.toml"
    scenario.write_text(dumps(loop_dict(open_ended)))
    assert main(["fuzz", str(scenario), "--examples", "1", "--horizon", "1e308"]) == 2
    assert "--horizon 1e+308 is too large: instants are drawn at tenths of a second up to it" in capsys.readouterr().err


def test_a_fleet_manager_s_search_options_in_its_header():
    # a campaign of `--jobs 3 --horizon 60` named `--examples 10 --seed 1` alone, which searched 8 jobs over
    # 300 s and shrank to another scenario (duration 900, not 660)
    import argparse

    from vcran.commands.fuzz import _search_options

    given = argparse.Namespace(jobs=3, horizon=60.0, idle_bound=60.0, fast=True, window=3, max_ops=8)
    assert _search_options(given, loop=True) == " --jobs 3 --horizon 60.0"
    assert _search_options(given, loop=False) == " --fast"
