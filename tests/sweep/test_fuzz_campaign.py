"""Fuzz campaigns across workers (docs/contract.md §10): consecutive search seeds in chunks, clean runs count every example,
the first failure stops the campaign and names the one search that finds it again alone."""

from __future__ import annotations

import tempfile
import threading
from pathlib import Path

import pytest

from tests.conftest import ROOT
from vcran.cli import main
from vcran.core.opil.ranlogic import RanLogic
from vcran.testing.campaign import chunks
from vcran.testing.checks import run_variant
from vcran.testing.scripts import load_text

DEMO = str(ROOT / "scenarios" / "demo.toml")


def test_chunks_are_consecutive_seeds_of_at_most_25_examples():
    assert chunks(100, 2, 7) == [(7, 25), (8, 25), (9, 25), (10, 25)]
    assert chunks(10, 4, 0) == [(0, 3), (1, 3), (2, 3), (3, 1)]
    assert chunks(3, 8, 5) == [(5, 1), (6, 1), (7, 1)]
    assert chunks(1, 1, 0) == [(0, 1)]
    assert sum(n for _, n in chunks(100_000, 16, 0)) == 100_000


@pytest.mark.slow
def test_a_clean_campaign_on_local_processes_counts_every_example(capsys):
    """On the bundled demo by name: the workers get its text, not a path they would have to find."""
    assert main(["fuzz", "demo", "--examples", "12", "--seed", "3", "--workers", "2", "--fast"]) == 0
    captured = capsys.readouterr()
    assert "12 examples of demo ran clean (seed 3)" in captured.out
    assert "as 2 searches (seeds 3..4) on 2 local processes" in captured.err


@pytest.fixture
def r7_bug(monkeypatch):
    """A deliberate R7 bug: the timer never cancels anything. Dask workers in threads of this process
    (LocalCluster(processes=False)) run the patched class."""

    def on_timer(self, now, task_id):
        self._begin(now)
        return self._end()

    monkeypatch.setattr(RanLogic, "on_timer", on_timer)


@pytest.mark.slow
def test_a_campaign_on_dask_stops_at_the_first_failure_which_its_seed_reproduces_alone(r7_bug, tmp_path, capsys):
    distributed = pytest.importorskip("distributed")
    saved = tmp_path / "fail.toml"
    # one worker thread: hypothesis is not thread-safe (docs/sweeps.md: run fuzz workers with --nthreads 1)
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False, protocol="tcp",
                                  host="127.0.0.1", scheduler_port=0, dashboard_address=None) as cluster:
        assert main(["fuzz", DEMO, "--examples", "26", "--seed", "1", "--fast", "--max-ops", "3", "--save", str(saved),
                     "--cluster", cluster.scheduler_address]) == 1
    err = capsys.readouterr().err
    assert "as 2 searches (seeds 1..2)" in err  # 25 + 1: the second is cheap to finish after the cancel
    tried = int(err.split("rule violated after ")[1].split(" ")[0])
    assert tried <= 25  # the first search failed and stopped the others
    text = saved.read_text()
    first = text.splitlines()[0]
    assert first.startswith(f"# vcran fuzz {DEMO} --examples 25 --seed ") and "(R7)" in text
    with tempfile.TemporaryDirectory() as work:
        assert any("(R7)" in p for p in run_variant(load_text(text), Path(work), again=False))
    command = first.removeprefix("# vcran ").split(": a minimal")[0].split()  # the header's command, as it is
    assert command[-3:] == ["--max-ops", "3", "--fast"]
    alone = tmp_path / "alone.toml"
    assert main([*command, "--save", str(alone)]) == 1
    assert alone.read_text().replace("alone.toml", "") == text.replace("fail.toml", "")
    alone_err = capsys.readouterr().err
    assert f"rule violated after {tried} examples" in alone_err  # the campaign counted nothing past that search


@pytest.mark.slow
def test_a_fleet_managers_campaign_runs_on_local_processes_and_saves_a_scenario_naming_its_search(tmp_path, capsys):
    """A manager that never replans a failed task (tests/testing/loop_managers.py) leaves a job open
    (docs/contract.md §9's loop property); the worker processes import it by name, as a Dask worker would. Each
    search shrinks its failure (~130 runs), so the campaign is two searches of one example."""
    from dataclasses import replace

    import vcran
    from vcran.io.scenario_toml import dumps, loop_dict
    from vcran.testing.loop import check_jobs_ended

    warehouse = vcran.load_scenario(ROOT / "scenarios" / "warehouse.toml")
    small = replace(warehouse, robots=warehouse.robots[:1], settings=replace(warehouse.settings, duration=120.0))
    scenario = tmp_path / "small.toml"
    scenario.write_text(dumps(loop_dict(small)))
    manager = "tests.testing.loop_managers:NeverReplans"
    saved = tmp_path / "fail.toml"
    assert main(["fuzz", str(scenario), "--manager", manager, "--jobs", "3", "--horizon", "30", "--examples", "2",
                 "--seed", "1", "--workers", "2", "--save", str(saved)]) == 1
    err = capsys.readouterr().err
    assert "as 2 searches (seeds 1..2) on 2 local processes" in err and f"{manager} broke a loop property" in err
    text = saved.read_text()
    first = text.splitlines()[0]
    assert first.startswith(f"# vcran fuzz {scenario} --manager {manager} --examples 1 --seed ")
    assert "# violation: job" in text
    failing = vcran.load_scenario(saved)
    assert failing.manager.path == manager
    assert check_jobs_ended(vcran.simulate(failing)) and not check_jobs_ended(
        vcran.simulate(failing, manager=vcran.managers.Dispatcher))


@pytest.mark.parametrize(("argv", "message"), [
    (["--workers", "0"], "--workers must be at least 1"),
    (["--workers", "2", "--cluster", "tcp://127.0.0.1:9"], "--workers and --cluster exclude each other"),
])
def test_bad_campaign_options(capsys, argv, message):
    assert main(["fuzz", DEMO, *argv]) == 2
    assert capsys.readouterr().err.startswith(f"vcran fuzz: {message}")


@pytest.mark.slow
def test_a_campaign_that_loses_its_scheduler_is_exit_2_never_ran_clean(tmp_path, monkeypatch, capsys):
    # docs/contract.md §10: the searches Dask cancelled when it lost its scheduler did not run clean; the command says it lost
    # the cluster (exit 2) instead of reporting the examples of the searches that finished as the campaign
    distributed = pytest.importorskip("distributed")
    from tests.sweep.lost_scheduler import LostScheduler
    from vcran.testing import campaign

    lost, real = LostScheduler(monkeypatch), campaign.check

    def check(base, ops, options):
        if threading.current_thread().name != "MainThread" and not lost.release.is_set() and ops:
            lost.now()
        return real(base, ops, options)

    monkeypatch.setattr(campaign, "check", check)
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False, protocol="tcp",
                                  host="127.0.0.1", scheduler_port=0, dashboard_address=None) as cluster:
        try:
            code = main(["fuzz", DEMO, "--examples", "50", "--fast", "--save", str(tmp_path / "f.toml"),
                         "--cluster", cluster.scheduler_address])
        finally:
            lost.end()
    captured = capsys.readouterr()
    assert code == 2 and "ran clean" not in captured.out
    last = captured.err.splitlines()[-1]
    assert last.startswith(f"vcran fuzz: lost the Dask scheduler at {cluster.scheduler_address}: ")
    assert last.endswith("of 50 examples ran, all clean")
