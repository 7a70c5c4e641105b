"""``vcran.run_sweep(keep_runs=DIR)`` and ``SweepResult.write(DIR)`` write their folder as ``vcran sweep --out
DIR`` does (docs/contract.md §6, §10; vcran.sweep.folder, the code they share): into ``DIR.incomplete``, renamed to
``DIR`` when it is complete; an earlier sweep's folder is replaced whole, a folder vcran did not write (or
the one you are in) refused before anything runs; an interrupted or failed sweep leaves ``DIR.incomplete``
and any earlier ``DIR`` untouched. ``result.write(DIR)`` over the folder ``run_sweep(keep_runs=DIR)`` wrote
keeps its runs: the two calls give the folder of ``vcran sweep --out DIR --keep-runs``."""

from __future__ import annotations

import csv
import io
from pathlib import Path

import pytest

import vcran
from tests.sweep.test_sweep_command import interrupt_run
from tests.sweep.test_sweep_out_folder import NARROW, WIDE, run_numbers, snapshot, sweep_file
from vcran.cli import main
from vcran.sweep import worker

FIGURE = "kpi-by-robots.each.max_velocity.png"


def no_runs(monkeypatch) -> list[int]:
    """Every run a sweep starts, recorded instead of run."""
    calls: list[int] = []
    monkeypatch.setattr(worker, "simulate", lambda *a, **k: calls.append(1))
    return calls


def foreign(tmp_path: Path) -> Path:
    out = tmp_path / "mydir"
    out.mkdir()
    (out / "notes.txt").write_text("keep me")
    return out


def without_wall(text: str) -> list[dict[str, str]]:
    return [{k: v for k, v in r.items() if k != "wall_seconds"} for r in csv.DictReader(io.StringIO(text))]


def same_sweep_folder(a: Path, b: Path) -> None:
    """``a`` and ``b`` hold the same sweep: the same files, byte for byte but the wall times of the tables."""
    left, right = snapshot(a), snapshot(b)
    assert sorted(left) == sorted(right)
    for name in left:
        if name == "runs.csv":
            assert without_wall(left[name].decode()) == without_wall(right[name].decode())
        elif name != "runs.parquet":  # the wall times again (tests/sweep/test_sweep_command.py reads it)
            assert left[name] == right[name], name


# --- refused before anything runs -------------------------------------------------------------------------


def test_run_sweep_refuses_a_folder_vcran_did_not_write_before_anything_runs(tmp_path, monkeypatch):
    calls = no_runs(monkeypatch)
    out = foreign(tmp_path)
    wide = sweep_file(tmp_path, "wide", WIDE)
    with pytest.raises(vcran.RunFolderError, match="exists and is not a vcran output folder"):
        vcran.run_sweep(wide, workers=1, keep_runs=out)
    assert calls == []
    assert snapshot(out) == {"notes.txt": b"keep me"}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["mydir", "wide.toml"]


@pytest.mark.parametrize("where", [".", ".."])
def test_run_sweep_refuses_the_folder_you_are_in_or_one_that_holds_it(tmp_path, monkeypatch, where):
    calls = no_runs(monkeypatch)
    narrow = sweep_file(tmp_path, "narrow", NARROW)
    inside = tmp_path / "here"
    inside.mkdir()
    monkeypatch.chdir(inside)
    with pytest.raises(vcran.RunFolderError, match="is the folder you are in, or holds it"):
        vcran.run_sweep(narrow, workers=1, keep_runs=where)
    assert calls == []
    assert sorted(p.name for p in tmp_path.iterdir()) == ["here", "narrow.toml"]
    assert list(inside.iterdir()) == []


def test_write_refuses_a_folder_vcran_did_not_write(tmp_path):
    result = vcran.run_sweep(sweep_file(tmp_path, "narrow", NARROW), workers=1)
    out = foreign(tmp_path)
    with pytest.raises(vcran.RunFolderError, match="exists and is not a vcran output folder"):
        result.write(out)
    assert snapshot(out) == {"notes.txt": b"keep me"}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["mydir", "narrow.toml"]


def test_write_refuses_the_folder_you_are_in(tmp_path, monkeypatch):
    result = vcran.run_sweep(sweep_file(tmp_path, "narrow", NARROW), workers=1)
    monkeypatch.chdir(tmp_path)
    with pytest.raises(vcran.RunFolderError, match="is the folder you are in, or holds it"):
        result.write(".")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["narrow.toml"]


# --- staged, replaced whole -------------------------------------------------------------------------------


@pytest.mark.slow
def test_run_sweep_stages_its_folder_and_replaces_an_earlier_sweep_whole(tmp_path):
    out = tmp_path / "o"
    wide, narrow = sweep_file(tmp_path, "wide", WIDE), sweep_file(tmp_path, "narrow", NARROW)
    first = vcran.run_sweep(wide, workers=1, keep_runs=out)
    assert first.folder == out.resolve()
    assert sorted(p.name for p in (out / "runs").iterdir()) == [f"{i:04d}" for i in range(8)]
    before = snapshot(out)

    seen: list[tuple[bool, list[str]]] = []

    def on_row(row):  # while the runs run: the earlier sweep whole at o, the new one's runs in o.incomplete
        staged = tmp_path / "o.incomplete" / "runs"
        seen.append((snapshot(out) == before, sorted(p.name for p in staged.iterdir())))

    second = vcran.run_sweep(narrow, workers=1, keep_runs=out, on_row=on_row)
    assert seen == [(True, ["0000"]), (True, ["0000", "0001"])]
    # nothing of the first sweep is left: its figure of a parameter the second does not sweep, its kept runs
    assert sorted(p.name for p in out.iterdir()) == [FIGURE, "runs", "runs.csv", "runs.parquet"]
    assert sorted(p.name for p in (out / "runs").iterdir()) == ["0000", "0001"]
    assert run_numbers(out) == ["0", "1"] and second.folder == out.resolve()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["narrow.toml", "o", "wide.toml"]


@pytest.mark.slow
def test_run_sweep_keep_runs_is_the_folder_of_vcran_sweep_keep_runs(tmp_path):
    narrow = sweep_file(tmp_path, "narrow", NARROW)
    assert main(["sweep", str(narrow), "--out", str(tmp_path / "cli"), "--keep-runs", "--workers", "1",
                 "--quiet"]) == 0
    vcran.run_sweep(narrow, workers=1, keep_runs=tmp_path / "py")
    same_sweep_folder(tmp_path / "py", tmp_path / "cli")


@pytest.mark.slow
def test_write_over_its_own_kept_runs_keeps_them_as_vcran_sweep_keep_runs_does(tmp_path, monkeypatch):
    """The natural script: ``r = run_sweep(s, keep_runs="out"); r.write("out")``."""
    narrow = sweep_file(tmp_path, "narrow", NARROW)
    assert main(["sweep", str(narrow), "--out", str(tmp_path / "cli"), "--keep-runs", "--workers", "1",
                 "--quiet"]) == 0
    monkeypatch.chdir(tmp_path)
    result = vcran.run_sweep("narrow.toml", workers=1, keep_runs="out")
    kept = snapshot(tmp_path / "out")
    files = result.write("out")
    assert files == [Path("out/runs.csv"), Path("out/runs.parquet"), Path("out", FIGURE)]
    assert snapshot(tmp_path / "out") == kept  # the same folder again, its kept runs still there
    same_sweep_folder(tmp_path / "out", tmp_path / "cli")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cli", "narrow.toml", "out"]


@pytest.mark.slow
def test_write_elsewhere_is_the_folder_of_vcran_sweep_without_keep_runs(tmp_path):
    narrow = sweep_file(tmp_path, "narrow", NARROW)
    assert main(["sweep", str(narrow), "--out", str(tmp_path / "cli"), "--workers", "1", "--quiet"]) == 0
    result = vcran.run_sweep(narrow, workers=1, keep_runs=tmp_path / "kept")
    kept = snapshot(tmp_path / "kept")
    result.write(tmp_path / "tables")
    same_sweep_folder(tmp_path / "tables", tmp_path / "cli")
    assert snapshot(tmp_path / "kept") == kept


@pytest.mark.slow
def test_write_replaces_an_earlier_sweep_whole_and_a_later_sweep_s_runs_are_not_its_own(tmp_path):
    """A result writes its kept runs back only into the folder that still holds them: after another sweep
    into the same folder, writing the old result replaces that sweep whole, as ``vcran sweep --out`` would."""
    out = tmp_path / "o"
    wide, narrow = sweep_file(tmp_path, "wide", WIDE), sweep_file(tmp_path, "narrow", NARROW)
    old = vcran.run_sweep(narrow, workers=1, keep_runs=out)
    vcran.run_sweep(wide, workers=1, keep_runs=out)
    old.write(out)
    assert sorted(p.name for p in out.iterdir()) == [FIGURE, "runs.csv", "runs.parquet"]
    assert run_numbers(out) == ["0", "1"]


# --- interrupted or failed: DIR.incomplete, never a folder that looks finished ---------------------------


@pytest.mark.slow
def test_an_interrupted_run_sweep_leaves_dir_incomplete_and_the_earlier_sweep_intact(tmp_path, monkeypatch):
    out = tmp_path / "o"
    vcran.run_sweep(sweep_file(tmp_path, "wide", WIDE), workers=1, keep_runs=out)
    before = snapshot(out)
    interrupt_run(monkeypatch, 4)
    longer = sweep_file(tmp_path, "narrow4", NARROW.replace("[1, 2]", "[1, 2, 3, 4]"))
    result = vcran.run_sweep(longer, workers=1, keep_runs=out)
    assert result.interrupted and len(result.rows) == 3
    assert snapshot(out) == before  # the earlier sweep, whole: no new rows or runs beside its figures
    partial = tmp_path / "o.incomplete"
    assert result.folder == partial.resolve()
    assert run_numbers(partial) == ["0", "1", "2"]  # the rows done, beside their runs
    assert sorted(p.name for p in (partial / "runs").iterdir()) == ["0000", "0001", "0002"]
    assert not list(partial.glob("kpi-by-*"))

    # writing it over its own folder leaves it where it is, unfinished, its runs there
    staged = snapshot(partial)
    assert result.write(out) == [partial / "runs.csv", partial / "runs.parquet"]
    assert snapshot(partial) == staged and snapshot(out) == before


def test_an_interrupted_result_is_written_as_dir_incomplete(tmp_path, monkeypatch):
    interrupt_run(monkeypatch, 2)
    result = vcran.run_sweep(sweep_file(tmp_path, "narrow", NARROW), workers=1)
    assert result.interrupted and result.folder is None
    out = tmp_path / "o"
    assert result.write(out) == [tmp_path / "o.incomplete" / "runs.csv", tmp_path / "o.incomplete" / "runs.parquet"]
    assert not out.exists() and run_numbers(tmp_path / "o.incomplete") == ["0"]


@pytest.mark.slow
def test_a_run_sweep_that_fails_leaves_dir_incomplete_and_the_earlier_sweep_intact(tmp_path, monkeypatch):
    out = tmp_path / "o"
    narrow = sweep_file(tmp_path, "narrow", NARROW)
    vcran.run_sweep(sweep_file(tmp_path, "wide", WIDE), workers=1, keep_runs=out)
    before = snapshot(out)

    def draw(*args, **kwargs):
        raise RuntimeError("the figures broke")

    monkeypatch.setattr("vcran.sweep.figures.draw", draw)
    with pytest.raises(RuntimeError, match="the figures broke"):
        vcran.run_sweep(narrow, workers=1, keep_runs=out)
    assert snapshot(out) == before
    assert run_numbers(tmp_path / "o.incomplete") == ["0", "1"]
    with pytest.raises(RuntimeError, match="the figures broke"):
        vcran.run_sweep(narrow, workers=1).write(tmp_path / "tables")
    assert not (tmp_path / "tables").exists() and run_numbers(tmp_path / "tables.incomplete") == ["0", "1"]


def test_a_pool_that_cannot_start_leaves_no_folder(tmp_path, monkeypatch):
    from vcran.sweep import runs

    def unreachable(*args, **kwargs):
        raise OSError("cannot reach the Dask scheduler at tcp://127.0.0.1:9: refused")

    monkeypatch.setattr(runs, "open_pool", unreachable)
    narrow = sweep_file(tmp_path, "narrow", NARROW)
    with pytest.raises(OSError, match="cannot reach"):
        vcran.run_sweep(narrow, keep_runs=tmp_path / "o")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["narrow.toml"]


@pytest.mark.parametrize(("options", "message"), [
    ({"workers": 0}, r"^workers must be a whole number of at least 1, got 0$"),
    ({"workers": -2}, r"^workers must be a whole number of at least 1, got -2$"),
    ({"workers": 1.5}, r"^workers must be a whole number of at least 1, got 1\.5$"),
    ({"workers": "2"}, r"^workers must be a whole number of at least 1, got '2'$"),
    ({"workers": 2, "cluster": "tcp://127.0.0.1:9"}, r"^workers and cluster exclude each other"),
])
def test_workers_the_command_refuses_are_refused_before_anything_runs(tmp_path, monkeypatch, options, message):
    # vcran sweep --workers 0 is exit 2; run_sweep(workers=0) ran in this process, and workers= beside a
    # cluster was ignored, silently
    calls = no_runs(monkeypatch)
    with pytest.raises(ValueError, match=message):
        vcran.run_sweep(sweep_file(tmp_path, "narrow", NARROW), keep_runs=tmp_path / "o", **options)
    assert calls == [] and sorted(p.name for p in tmp_path.iterdir()) == ["narrow.toml"]


def test_a_figure_format_a_sweep_folder_cannot_hold_is_refused_before_anything_runs(tmp_path, monkeypatch):
    """A ``kpi-by-*.pdf`` would make the folder no sweep's: the next sweep into it would be refused."""
    narrow = sweep_file(tmp_path, "narrow", NARROW)
    result = vcran.run_sweep(narrow, workers=1)
    calls = no_runs(monkeypatch)
    with pytest.raises(ValueError, match="figure format must be one of png, svg, got 'pdf'"):
        vcran.run_sweep(narrow, workers=1, keep_runs=tmp_path / "o", fmt="pdf")
    with pytest.raises(ValueError, match="figure format must be one of png, svg, got 'pdf'"):
        result.write(tmp_path / "o", fmt="pdf")
    assert calls == [] and sorted(p.name for p in tmp_path.iterdir()) == ["narrow.toml"]


@pytest.mark.slow
def test_svg_figures_as_vcran_sweep_format_svg(tmp_path):
    narrow = sweep_file(tmp_path, "narrow", NARROW)
    assert main(["sweep", str(narrow), "--out", str(tmp_path / "cli"), "--format", "svg", "--keep-runs",
                 "--workers", "1", "--quiet"]) == 0
    vcran.run_sweep(narrow, workers=1, keep_runs=tmp_path / "py", fmt="svg").write(tmp_path / "py", fmt="svg")
    same_sweep_folder(tmp_path / "py", tmp_path / "cli")


@pytest.mark.slow
def test_write_over_its_own_folder_without_kept_runs_there(tmp_path):
    """Dask workers without a file system shared with this machine keep their runs on theirs: the folder
    ``keep_runs`` wrote here holds the tables and figures but no ``runs/``. Writing the result over it again
    was a FileNotFoundError from copying the runs it does not have (docs/contract.md §10)."""
    import shutil

    narrow = sweep_file(tmp_path, "narrow", NARROW)
    result = vcran.run_sweep(narrow, workers=1, keep_runs=tmp_path / "o")
    shutil.rmtree(tmp_path / "o" / "runs")  # where the runs would be, had the workers shared this disk
    assert result.write(tmp_path / "o") == [tmp_path / "o" / name for name in ("runs.csv", "runs.parquet", FIGURE)]
    assert sorted(p.name for p in (tmp_path / "o").iterdir()) == [FIGURE, "runs.csv", "runs.parquet"]


@pytest.mark.slow
def test_a_scheduler_lost_mid_sweep_raises_pool_error_with_the_rows_done(tmp_path, monkeypatch):
    # docs/contract.md §10, §6: run_sweep never returns a part of a sweep as if it were the whole when its cluster went away;
    # the PoolError carries the rows done (result.interrupted) and leaves them in DIR.incomplete
    distributed = pytest.importorskip("distributed")
    from tests.sweep.lost_scheduler import lost_at_seed
    from vcran.sweep.pool import PoolError

    lost = lost_at_seed(monkeypatch, 2)
    out = tmp_path / "kept"
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False, protocol="tcp",
                                  host="127.0.0.1", scheduler_port=0, dashboard_address=None) as cluster:
        try:
            with pytest.raises(PoolError, match=r"^lost the Dask scheduler at tcp://127\.0\.0\.1:[0-9]+: ") as caught:
                vcran.run_sweep(sweep_file(tmp_path, "wide", WIDE), cluster=cluster.scheduler_address, keep_runs=out)
        finally:
            lost.end()
    result = caught.value.result
    assert result.interrupted and len(result.rows) < result.total
    assert result.folder == (tmp_path / "kept.incomplete").resolve() and not out.exists()
    assert f"runs done; their rows are in {result.folder / 'runs.csv'}" in str(caught.value)
    assert len((result.folder / "runs.csv").read_text().splitlines()) == len(result.rows) + 1
