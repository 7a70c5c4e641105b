"""vcran's pytest plugin (issue 16; docs/fuzzing.md "Profiles"): installed with vcran, it registers the
``vcran`` and ``vcran-deep`` hypothesis profiles and changes nothing until a run opts in."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

#: A user's test file that reports the settings its run got.
USER_TEST = """
from hypothesis import settings

def test_report():
    s = settings.default
    print(f"SETTINGS {s.max_examples} {s.stateful_step_count} {s.deadline} {[h.name for h in s.suppress_health_check]} {s.print_blob}")
"""


def settings_of_a_user_run(tmp_path: Path, *options: str) -> str:
    (tmp_path / "test_user.py").write_text(USER_TEST, encoding="utf-8")
    result = subprocess.run([sys.executable, "-m", "pytest", "-q", "-s", "-p", "no:cacheprovider", "--rootdir",
                             str(tmp_path), *options, "test_user.py"], cwd=tmp_path, capture_output=True, text=True,
                            timeout=120)
    assert result.returncode == 0, result.stdout + result.stderr
    return next(line for line in result.stdout.splitlines() if "SETTINGS" in line).split("SETTINGS ", 1)[1]


@pytest.mark.parametrize(("profile", "expected"), [
    ("vcran", "100 50 None ['too_slow'] False"),
    ("vcran-deep", "5000 120 None ['too_slow'] False"),
    ("vcran-nightly", "20000 200 None ['too_slow'] True"),
])
def test_a_run_that_opts_in_gets_the_profile(tmp_path: Path, profile: str, expected: str) -> None:
    assert settings_of_a_user_run(tmp_path, f"--hypothesis-profile={profile}") == expected


@pytest.mark.slow
def test_a_run_that_does_not_opt_in_keeps_hypothesis_defaults(tmp_path: Path) -> None:
    # hypothesis' own choice, not vcran's: a run without the plugin at all. That choice depends on where the
    # run is (a CI server gets hypothesis' "ci" profile, no deadline), so it is measured, not written down.
    without = settings_of_a_user_run(tmp_path, "-p", "no:vcran")
    assert settings_of_a_user_run(tmp_path) == without
    assert without not in {"100 50 None ['too_slow'] False", "5000 120 None ['too_slow'] False"}  # not ours
    assert without.split()[:2] == ["100", "50"]  # hypothesis' default or ci profile, not vcran-deep's

