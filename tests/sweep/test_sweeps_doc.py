"""docs/sweeps.md's blocks that tests/test_docs.py leaves to this file (its 'tested by' markers): the sweep
file shown is scenarios/sweeps/demo-sweep.toml, and the ```sh lines run verbatim, with run 3 of the sweep
byte-identical to the same run alone (docs/contract.md §10). tests/test_docs.py runs the ```python blocks; the indented
commands (a real cluster, a fuzz campaign) run nowhere verbatim: tests/sweep/test_sweep_command.py and
test_fuzz_campaign.py run the same paths on a LocalCluster."""

from __future__ import annotations

import re
import shlex

import pytest

from tests.conftest import ROOT
from vcran.cli import main

TEXT = (ROOT / "docs" / "sweeps.md").read_text(encoding="utf-8")


def blocks(language: str) -> list[str]:
    return re.findall(rf"^```{language}\n(.*?)^```", TEXT, re.S | re.M)


@pytest.mark.slow
def test_shell_lines_run_verbatim_and_run_3_alone_is_byte_identical(monkeypatch, tmp_path):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "scenarios").symlink_to(ROOT / "scenarios")
    lines = [line for block in blocks("sh") for line in block.splitlines() if line.strip()]
    assert len(lines) == 4
    for line in lines:
        argv = shlex.split(line)
        assert argv[0] == "vcran"
        assert main(argv[1:] + ["--quiet"]) in (0, 1), line
    for name in ("trace.jsonl.zst", "legs.npy", "events.jsonl.zst", "summary.json"):
        assert (tmp_path / "out/demo-sweep/runs/0003" / name).read_bytes() == \
            (tmp_path / "out/demo-run-3" / name).read_bytes(), name
    assert (tmp_path / "out/warehouse-sweep/runs.csv").read_text().count("\n") == 1 + 8
    assert (tmp_path / "out/fleet-size/runs.csv").read_text().count("\n") == 1 + 4  # issue 29 item 11


def test_the_example_files_are_what_the_doc_says():
    """The sweep files shown (no scenario: the generic docs test leaves them to this test) are the ones in
    scenarios/ (tests/sweep/test_sweep_file.py loads them)."""
    assert blocks("toml") == [(ROOT / "scenarios" / "sweeps" / name).read_text()
                              for name in ("demo-sweep.toml", "fleet-size.toml")]
