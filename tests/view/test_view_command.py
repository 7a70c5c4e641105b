"""``vcran view RUN [--out PAGE.html] [--open]`` and ``vcran run --view`` (docs/contract.md §13, issue 33 items 1 and 6):
where the page goes, and every refusal as one line with exit status 2."""

from __future__ import annotations

import stat
import time
from pathlib import Path

import pytest

from tests.conftest import ROOT
from tests.view.runs import bundled
from vcran.cli import main

DEMO = str(ROOT / "scenarios" / "demo.toml")


@pytest.fixture(scope="module")
def demo(tmp_path_factory) -> Path:
    return bundled("demo", tmp_path_factory.mktemp("view") / "demo")


def one_line(err: str, start: str) -> None:
    assert err.startswith(start) and err.count("\n") == 1 and "Traceback" not in err, err


def test_the_page_goes_into_the_run_folder_by_default(demo, capsys):
    assert main(["view", str(demo)]) == 0
    page = demo / "view.html"
    assert page.is_file() and page.read_text().startswith("<!DOCTYPE html>")
    assert capsys.readouterr().out == f"page in {page} ({page.stat().st_size / 1e6:.1f} MB): open it in a web browser\n"
    # the folder stays a run folder: the next run into it replaces it whole (vcran/io/runfolder.py)
    assert main(["run", DEMO, "--out", str(demo), "--quiet"]) == 0
    assert not page.exists()


def test_run_with_view_writes_the_page_beside_the_run(tmp_path, capsys):
    """docs/view.md: ``vcran run ... --view`` writes DIR/view.html after the run."""
    assert main(["run", DEMO, "--out", str(tmp_path / "run"), "--view", "--quiet"]) == 0
    assert sorted(p.name for p in (tmp_path / "run").iterdir()) == [
        "events.jsonl.zst", "legs.npy", "summary.json", "trace.jsonl.zst", "view.html"]
    assert capsys.readouterr().out == ""


def test_out_names_the_page_and_open_hands_it_to_the_browser(demo, tmp_path, monkeypatch, capsys):
    """--open uses Python's webbrowser, which honours $BROWSER: here a script that records what it was given."""
    opened = tmp_path / "opened"
    script = tmp_path / "browser.sh"
    script.write_text(f'#!/bin/sh\necho "$1" > {opened}\n')
    script.chmod(script.stat().st_mode | stat.S_IEXEC)
    monkeypatch.setenv("BROWSER", str(script))
    page = tmp_path / "pages" / "demo.html"
    assert main(["view", str(demo), "--out", str(page), "--open", "--quiet"]) == 0
    assert page.is_file() and capsys.readouterr().out == ""
    for _ in range(200):  # webbrowser starts the script in the background: wait for it (at most 10 s)
        if opened.exists() and opened.read_text():
            break
        time.sleep(0.05)
    assert opened.read_text().strip() == page.resolve().as_uri()


@pytest.mark.parametrize(("args", "message"), [
    (["missing"], "vcran view: {tmp}/missing: no such folder"),
    (["empty"], "vcran view: {tmp}/empty: not a run folder (no trace.jsonl.zst and no events.jsonl.zst)"),
    (["run.incomplete"], "vcran view: {tmp}/run.incomplete: a run still being written (or killed): give the "
                         "page's path with --out"),
    (["DEMO", "--out", "empty"], "vcran view: {tmp}/empty: is a folder; --out names the page's file"),
])
def test_refusals_are_one_line_and_exit_2(demo, tmp_path, capsys, args, message):
    (tmp_path / "empty").mkdir()
    (tmp_path / "run.incomplete").mkdir()
    argv = [str(demo) if a == "DEMO" else a if a.startswith("--") else str(tmp_path / a) for a in args]
    assert main(["view", *argv]) == 2
    one_line(capsys.readouterr().err, message.format(tmp=tmp_path))
