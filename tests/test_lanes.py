"""Test lanes (issue 30 item 8; README "Development"): the inner loop, ``pytest -m "not slow"``, leaves out
the kinds of tests the README says it leaves out and keeps the rest; CI runs everything."""

from __future__ import annotations

import shlex
import subprocess
import sys

import pytest

from tests.conftest import ROOT
from tests.test_docs import blocks

#: A file of each kind the README names, with a test of it that stays in the inner loop (None: none does).
KINDS = {
    "tests/view/test_view_page.py": None,  # the page in a headless browser
    "tests/transports/test_manage.py": "test_a_manager_on_every_attribute_is_told_each_poll_that_finds_a_change",
    "tests/transports/test_live.py": "test_a_failure_success_failure_within_one_second_still_reads_as_a_failure",
    "tests/testing/test_fuzz_sim.py": None,  # fuzz campaigns
    "tests/sweep/test_sweep_out_folder.py": "test_what_counts_as_a_sweep_folder",
    "tests/test_docs.py": "test_every_block_says_what_it_is",
    "tests/commands/test_packaging.py": "test_bundled_scenarios_are_the_repository_scenarios",
}
#: ... and one each that the inner loop leaves out.
SLOW = {
    "tests/view/test_view_page.py": "test_a_large_fleet_opens_and_draws_every_robot",
    "tests/transports/test_manage.py": "test_the_dispatcher_completes_the_warehouses_first_jobs_through_the_broker",
    "tests/transports/test_live.py": "test_broker_restart_mid_run",
    "tests/testing/test_fuzz_sim.py": "test_rules_determinism_and_replay_under_perturbed_scripts",
    "tests/sweep/test_sweep_out_folder.py": "test_a_second_sweep_replaces_the_first_as_a_whole",
    "tests/test_docs.py": "test_sh_blocks_run",
    "tests/commands/test_packaging.py": "test_the_wheel_installs_and_runs_outside_the_repository",
}


def collected(*args: str) -> set[str]:
    """The test ids pytest collects with ``args``, without running any."""
    done = subprocess.run([sys.executable, "-m", "pytest", "--collect-only", "-q", "-p", "no:cacheprovider", *args],
                          cwd=ROOT, capture_output=True, text=True)
    assert done.returncode == 0, done.stdout + done.stderr
    return {line for line in done.stdout.splitlines() if "::" in line}


def function(test_id: str) -> str:
    return test_id.split("::")[-1].split("[")[0]


@pytest.mark.slow  # it runs pytest's collection of seven files twice
def test_the_inner_loop_leaves_out_what_the_readme_says():
    readme = ROOT / "README.md"
    (inner,) = [b for b in blocks(readme) if b.tested_by and b.tested_by.endswith(
        "test_lanes.py::test_the_inner_loop_leaves_out_what_the_readme_says")]
    command = shlex.split(inner.code)
    assert command[:5] == [".venv/bin/python", "-m", "pytest", "-n", "auto"]
    selection = command[5:]
    assert selection == ["-m", "not slow"]
    everything = collected(*KINDS)
    kept = collected(*selection, *KINDS)
    assert kept < everything
    for path, fast in KINDS.items():
        left_out = {function(t) for t in everything - kept if t.startswith(path)}
        assert SLOW[path] in left_out, path
        assert (fast is None) == (not any(t.startswith(path) for t in kept)), path
        if fast is not None:
            assert fast in {function(t) for t in kept if t.startswith(path)}, path
    # CI runs everything: the quick start's test command, which .ci/run runs, selects nothing by marker
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8").strip().splitlines()[-1]
    assert "slow" not in ci
