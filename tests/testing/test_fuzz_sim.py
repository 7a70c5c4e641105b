"""Whole-simulation properties over generated, perturbed scenarios (docs/contract.md §3–§6).

Each example is a small generated fleet (vcran.testing.scripts.fleets) whose message script is
perturbed (reordered, duplicated, delayed, dropped, cancels injected), written as a scenario file and
run. The rules are checked on the run's outputs (vcran.testing.checks); the run must go idle (every task
ended), run byte-identically twice (docs/contract.md §5) and pass replay verification against its own trace (docs/contract.md §6). A
failing example is printed as the scenario file that reproduces it (``vcran run`` it).
"""

from __future__ import annotations

import json
import tempfile
from pathlib import Path

import pytest
from hypothesis import event, given, note
from hypothesis import strategies as st

from vcran.io.scenario_file import parse
from vcran.io.trace import EVENTS_FILE, event_records
from vcran.testing.checks import run_variant
from vcran.testing.scripts import fleets, load_text, perturbations, perturbed_toml

pytestmark = pytest.mark.slow  # fuzz campaigns: whole runs of perturbed scenarios


@st.composite
def perturbed_fleets(draw: st.DrawFn, malformed: bool) -> str:
    base = parse(draw(fleets()), "<generated>")
    ops = draw(perturbations(base.script, [r.id for r in base.robots], malformed=malformed))
    text = perturbed_toml(base, ops)
    note(f"scenario file:\n{text}")
    note(f"perturbations: {ops!r}")
    return text


def run_and_check(text: str, work: Path) -> None:
    scenario = load_text(text)
    assert run_variant(scenario, work) == []
    for e in event_records(work / "a" / EVENTS_FILE):  # --hypothesis-show-statistics
        if e["event"] in ("task_completed", "task_cancelled", "rejected", "failed"):
            event(f"{e['event']} {e.get('reason', e.get('code', ''))}".strip())
    # generated fleets are small and the duration generous: the run must have gone idle
    summary = json.loads((work / "a" / "summary.json").read_text())
    assert summary["sim_time"] < scenario.settings.duration, "the run hit its duration before going idle"


@given(perturbed_fleets(malformed=False))
def test_rules_determinism_and_replay_under_perturbed_scripts(text):
    with tempfile.TemporaryDirectory() as work:
        run_and_check(text, Path(work))


@given(perturbed_fleets(malformed=True))
def test_malformed_payloads_are_rejected_and_change_nothing_else(text):
    with tempfile.TemporaryDirectory() as work:
        run_and_check(text, Path(work))
