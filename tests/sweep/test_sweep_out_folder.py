"""``vcran sweep --out DIR`` is written like a run folder (docs/contract.md §6, §10; vcran.io.runfolder): into
``DIR.incomplete``, renamed to ``DIR`` when the sweep has ended. An earlier sweep's folder is replaced as a
whole (never its figures and kept runs beside new rows), a folder that is no vcran output is refused before
anything runs, and a sweep that fails or is interrupted leaves ``DIR.incomplete`` and any earlier ``DIR``
untouched."""

from __future__ import annotations

import csv
import io
from pathlib import Path

import pytest

from tests.conftest import ROOT
from tests.sweep.test_sweep_command import interrupt_run
from vcran.cli import main
from vcran.sweep import worker

DEMO = ROOT / "scenarios" / "demo.toml"

#: The new user's repro: a wide sweep with --keep-runs, then a narrow one with another grid into the same --out.
WIDE = """scenario = "{scenario}"
seeds = [1, 2]
[grid]
"simulation.task_timeout" = [1.5, 30.0]
"robots.*.max_velocity" = [0.5, 1.0]
"""
NARROW = """scenario = "{scenario}"
seeds = [1, 2]
[grid]
"robots.*.max_velocity" = [1.0]
"""


def sweep_file(tmp_path: Path, name: str, text: str) -> Path:
    path = tmp_path / f"{name}.toml"
    path.write_text(text.format(scenario=DEMO.as_posix()))
    return path


def snapshot(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def run_numbers(folder: Path) -> list[str]:
    return [r["run"] for r in csv.DictReader(io.StringIO((folder / "runs.csv").read_text()))]


@pytest.mark.slow
def test_a_second_sweep_replaces_the_first_as_a_whole(tmp_path):
    out = tmp_path / "o"
    wide, narrow = sweep_file(tmp_path, "wide", WIDE), sweep_file(tmp_path, "narrow", NARROW)
    assert main(["sweep", str(wide), "--out", str(out), "--keep-runs", "--workers", "1", "--quiet"]) == 0
    assert sorted(p.name for p in (out / "runs").iterdir()) == [f"{i:04d}" for i in range(8)]
    assert (out / "kpi-by-simulation.task_timeout.png").exists()

    assert main(["sweep", str(narrow), "--out", str(out), "--workers", "1", "--quiet"]) == 0
    assert run_numbers(out) == ["0", "1"]
    # nothing of the first sweep is left: its figure of a parameter the second does not sweep, its kept runs
    assert sorted(p.name for p in out.iterdir()) == ["kpi-by-robots.each.max_velocity.png", "runs.csv",
                                                      "runs.parquet"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["narrow.toml", "o", "wide.toml"]


def test_a_folder_that_is_no_vcran_output_is_refused_before_anything_runs(tmp_path, monkeypatch, capsys):
    calls = []
    monkeypatch.setattr(worker, "simulate", lambda *a, **k: calls.append(1))
    out = tmp_path / "mydir"
    out.mkdir()
    (out / "notes.txt").write_text("keep me")
    wide = sweep_file(tmp_path, "wide", WIDE)
    assert main(["sweep", str(wide), "--out", str(out), "--keep-runs", "--workers", "1"]) == 2
    err = capsys.readouterr().err
    assert err == (f"vcran sweep: {out}: exists and is not a vcran output folder (a sweep's or a run's); "
                   "refusing to write a sweep into it (choose a new output folder, or remove it)\n")
    assert calls == []
    assert snapshot(out) == {"notes.txt": b"keep me"}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["mydir", "wide.toml"]


@pytest.mark.slow
def test_a_run_folder_or_an_empty_folder_may_receive_a_sweep(tmp_path):
    run = tmp_path / "run"
    assert main(["run", str(DEMO), "--out", str(run), "--quiet"]) == 0
    empty = tmp_path / "empty"
    empty.mkdir()
    narrow = sweep_file(tmp_path, "narrow", NARROW)
    for out in (run, empty):
        assert main(["sweep", str(narrow), "--out", str(out), "--workers", "1", "--quiet"]) == 0
        assert sorted(p.name for p in out.iterdir()) == ["kpi-by-robots.each.max_velocity.png", "runs.csv",
                                                          "runs.parquet"]


@pytest.mark.slow
def test_an_interrupted_sweep_leaves_dir_incomplete_and_the_earlier_sweep_intact(tmp_path, monkeypatch, capsys):
    out = tmp_path / "o"
    wide = sweep_file(tmp_path, "wide", WIDE)
    assert main(["sweep", str(wide), "--out", str(out), "--keep-runs", "--workers", "1", "--quiet"]) == 0
    before = snapshot(out)
    interrupt_run(monkeypatch, 4)
    narrow = sweep_file(tmp_path, "narrow3", NARROW.replace("[1, 2]", "[1, 2, 3, 4]"))
    assert main(["sweep", str(narrow), "--out", str(out), "--keep-runs", "--workers", "1", "--quiet"]) == 130
    assert snapshot(out) == before  # the earlier sweep, whole: no new rows beside its figures
    partial = tmp_path / "o.incomplete"
    assert run_numbers(partial) == ["0", "1", "2"]  # the rows done, where they say they are
    assert sorted(p.name for p in (partial / "runs").iterdir()) == ["0000", "0001", "0002"]
    assert not list(partial.glob("kpi-by-*"))
    assert f"their rows are in {partial / 'runs.csv'}" in capsys.readouterr().err

    monkeypatch.undo()  # the runs run again
    assert main(["sweep", str(narrow), "--out", str(out), "--workers", "1", "--quiet"]) == 0
    assert not partial.exists()  # the next sweep into o clears the leftover
    assert run_numbers(out) == ["0", "1", "2", "3"] and not (out / "runs").exists()


@pytest.mark.slow
def test_a_sweep_that_fails_leaves_dir_incomplete_and_the_earlier_sweep_intact(tmp_path, monkeypatch, capsys):
    out = tmp_path / "o"
    wide, narrow = sweep_file(tmp_path, "wide", WIDE), sweep_file(tmp_path, "narrow", NARROW)
    assert main(["sweep", str(wide), "--out", str(out), "--workers", "1", "--quiet"]) == 0
    before = snapshot(out)

    def draw(*args, **kwargs):
        raise RuntimeError("the figures broke")

    monkeypatch.setattr("vcran.sweep.figures.draw", draw)
    code = main(["sweep", str(narrow), "--out", str(out), "--workers", "1", "--quiet"])
    assert code not in (0, 1) and "the figures broke" in capsys.readouterr().err
    assert snapshot(out) == before
    assert run_numbers(tmp_path / "o.incomplete") == ["0", "1"]


@pytest.mark.slow
def test_workers_write_kept_runs_under_the_staging_folder(tmp_path, monkeypatch):
    """The jobs a pool ships (to local processes or Dask workers, the same tuples) name folders under
    ``DIR.incomplete``; nothing appears at ``DIR`` until the sweep has ended."""
    from vcran.commands import sweep as command
    from vcran.sweep.pool import InProcess

    out = tmp_path / "o"
    seen: list[str] = []

    class Spy(InProcess):
        def run(self, fn, jobs):
            for job in jobs:
                seen.append(job[-1])
                assert not out.exists()
            return super().run(fn, jobs)

    monkeypatch.setattr(command, "pool_for", lambda args, runs: Spy())
    narrow = sweep_file(tmp_path, "narrow", NARROW)
    assert main(["sweep", str(narrow), "--out", str(out), "--keep-runs", "--quiet"]) == 0
    staged = (tmp_path / "o.incomplete").resolve()
    assert seen == [str(staged / "runs" / f"{i:04d}") for i in range(2)]
    assert sorted(p.name for p in (out / "runs").iterdir()) == ["0000", "0001"]


@pytest.mark.parametrize(("names", "sweep"), [
    ({"runs.csv"}, True),
    ({"runs.csv", "runs.parquet", "kpi-by-label.png", "kpi-by-simulation.seed.svg", "runs/0000", "runs/0001"}, True),
    ({"runs.csv", "runs/0003.incomplete"}, True),  # a kept run that failed part way
    ({"runs.parquet"}, False),  # no runs.csv: a sweep always writes it
    ({"runs.csv", "notes.txt"}, False),
    ({"runs.csv", "runs/notes"}, False),
    ({"runs.csv", "kpi-by-x.pdf"}, False),
])
def test_what_counts_as_a_sweep_folder(tmp_path, names, sweep):
    from vcran.io.runfolder import is_output_folder, is_sweep_folder

    for name in names:
        path = tmp_path / name
        if name.startswith("runs/"):
            path.mkdir(parents=True)
        else:
            path.write_bytes(b"")
    assert is_sweep_folder(tmp_path) is sweep
    assert is_output_folder(tmp_path) is sweep


def test_a_pool_that_cannot_start_leaves_no_folder(tmp_path, monkeypatch, capsys):
    from vcran.commands import CommandError
    from vcran.commands import sweep as command

    def unreachable(args, runs):
        raise CommandError("cannot reach the Dask scheduler at tcp://127.0.0.1:9: refused")

    monkeypatch.setattr(command, "pool_for", unreachable)
    narrow = sweep_file(tmp_path, "narrow", NARROW)
    assert main(["sweep", str(narrow), "--out", str(tmp_path / "o"), "--quiet"]) == 2
    assert capsys.readouterr().err.startswith("vcran sweep: cannot reach the Dask scheduler")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["narrow.toml"]
