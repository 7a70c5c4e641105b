"""Atomic run folders (issue 14 item 4, docs/contract.md §6): complete or visibly incomplete, never mixed into."""

from __future__ import annotations

import json

import pytest

from tests.conftest import ROOT
from transports.scripted import ScriptedTransport
from vcran.cli import main
from vcran.io.runfolder import RunFolderError, staging
from vcran.io.scenario_file import load
from vcran.runner import run_to

DEMO = ROOT / "scenarios" / "demo.toml"


class Interrupted(Exception):
    pass


def test_interrupted_run_leaves_an_incomplete_folder_and_the_previous_run_intact(tmp_path, capsys):
    scenario = load(DEMO)
    out = tmp_path / "run"
    run_to(scenario, out, ScriptedTransport(scenario.messages()))
    before = {p.name: p.read_bytes() for p in out.iterdir()}

    def stop_at_20(t: float, done: int) -> None:
        if t >= 20:
            raise Interrupted

    with pytest.raises(Interrupted):
        run_to(scenario, out, ScriptedTransport(scenario.messages()), progress=stop_at_20)
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before  # untouched, still complete
    partial = tmp_path / "run.incomplete"
    assert sorted(p.name for p in partial.iterdir()) == ["events.jsonl.zst", "legs.npy", "trace.jsonl.zst"]
    assert not (partial / "summary.json").exists()
    # what was written before the interruption replays as far as it goes, as a killed live run does (docs/contract.md §6)
    assert main(["replay", str(partial), "--out", str(tmp_path / "rep"), "--verify"]) == 0
    assert "has no end record" in capsys.readouterr().err

    run_to(scenario, out, ScriptedTransport(scenario.messages()))  # the next run clears the leftover
    assert not partial.exists()
    assert json.loads((out / "summary.json").read_text())["sim_time"] == 57.0


def test_a_folder_that_is_not_a_run_is_refused_and_left_alone(tmp_path, capsys):
    out = tmp_path / "mine"
    out.mkdir()
    (out / "notes.txt").write_text("keep me")
    assert main(["run", str(DEMO), "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("vcran run: ") and "is not a vcran run folder" in err and err.count("\n") == 1
    assert [p.name for p in out.iterdir()] == ["notes.txt"]
    assert not (tmp_path / "mine.incomplete").exists()
    scenario = load(DEMO)
    with pytest.raises(RunFolderError):
        run_to(scenario, out, ScriptedTransport(scenario.messages()))


@pytest.mark.slow
def test_an_empty_folder_or_an_earlier_run_is_a_valid_out(tmp_path):
    out = tmp_path / "empty"
    out.mkdir()
    assert main(["run", str(DEMO), "--out", str(out), "--quiet"]) == 0
    assert main(["run", str(DEMO), "--out", str(out), "--quiet", "--report"]) in (0, 2)  # report needs matplotlib
    assert main(["run", str(DEMO), "--out", str(out), "--quiet"]) == 0  # a run folder with its report
    assert (out / "summary.json").exists() and not (out / "report").exists()  # replaced as a whole



def test_an_out_that_is_a_symlink_to_an_earlier_run_leaves_nothing_behind(tmp_path):
    """docs/contract.md §6: the earlier --out is renamed aside and removed once the new run is in place. A symlink's rmtree
    fails (ignored), so ``link.replaced-PID`` stayed beside the new folder for good, a new one per run."""
    assert main(["run", str(DEMO), "--out", str(tmp_path / "real"), "--quiet"]) == 0
    (tmp_path / "link").symlink_to("real")
    assert main(["run", str(DEMO), "--out", str(tmp_path / "link"), "--quiet"]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["link", "real"]
    assert (tmp_path / "link" / "summary.json").is_file() and not (tmp_path / "link").is_symlink()
    assert (tmp_path / "real" / "summary.json").is_file()  # where the link led: not written into, not removed

@pytest.mark.parametrize(("names", "vcran_output"), [
    ({"trace.jsonl.zst", "legs.npy", "events.jsonl.zst", "summary.json"}, True),  # a run's
    ({"events.jsonl.zst", "summary.json"}, True),  # vcran manage's (docs/live.md)
    ({"events.jsonl.zst"}, True),  # vcran manage's without its summary (a crash, before outputs were staged)
    ({"summary.json"}, False),  # a summary alone says nothing of who wrote it
    ({"events.jsonl.zst", "notes.txt"}, False),
    ({"trace.jsonl.zst", "notes.txt"}, False),
])
def test_what_counts_as_a_vcran_output_folder(tmp_path, names, vcran_output):
    from vcran.io.runfolder import is_run_folder

    for name in names:
        (tmp_path / name).write_bytes(b"")
    assert is_run_folder(tmp_path) is vcran_output


@pytest.mark.parametrize("out", [".", "..", "./"])
def test_the_folder_you_are_in_is_refused_as_out(tmp_path, monkeypatch, capsys, out):
    # a new user's `--out .`: the folder would be renamed away under the shell (run, sweep: exit 70 on an
    # empty name, or a sweep's folder replaced while the shell sat in it)
    here = tmp_path / "work"
    here.mkdir()
    (here / "notes.txt").write_text("mine")
    monkeypatch.chdir(here)
    assert main(["run", str(ROOT / "scenarios" / "demo.toml"), "--out", out, "--quiet"]) == 2
    assert "is the folder you are in, or holds it" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["work"] and [p.name for p in here.iterdir()] == ["notes.txt"]
    for absolute in (here, tmp_path):  # by any name: the folder itself or one holding it
        with pytest.raises(RunFolderError, match="a sweep replaces its output folder as a whole"):
            staging(absolute, "sweep")
