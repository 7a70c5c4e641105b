"""Shared test helpers (run a scenario written inline as TOML, read its outputs back) and suite settings.

Hypothesis runs without a per-example deadline and without the too_slow health check: CI tests a fresh
clone (no .hypothesis cache, so the first text draw builds Unicode tables) on a shared machine whose
load varies, and neither timing says anything about vcran's behaviour.
"""

from __future__ import annotations

import json
import os
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, settings

from transports.scripted import ScriptedTransport
from vcran.core.scenario import Scenario
from vcran.io.scenario_file import parse
from vcran.runner import run_to

settings.register_profile("vcran", deadline=None, suppress_health_check=[HealthCheck.too_slow])
settings.load_profile("vcran")

ROOT = Path(__file__).resolve().parent.parent
DATA = Path(__file__).resolve().parent / "data"


@dataclass
class Outputs:
    dir: Path
    summary: dict[str, Any]
    events: list[dict[str, Any]]

    def robot(self, rid: str = "robot_1") -> dict[str, Any]:
        return self.summary["robots"][rid]

    def of(self, name: str, robot: str | None = None) -> list[dict[str, Any]]:
        return [e for e in self.events if e["event"] == name and (robot is None or e["robot"] == robot)]

    def trace(self) -> list[dict[str, Any]]:
        """The in and out records (without the header and the end record)."""
        lines = (self.dir / "trace.jsonl").read_text().splitlines()
        return [r for r in map(json.loads, lines[1:]) if r["dir"] != "end"]


def run_scenario(scenario: Scenario, out: Path) -> Outputs:
    run_to(scenario, out, ScriptedTransport(scenario.messages()))
    events = [json.loads(line) for line in (out / "events.jsonl").read_text().splitlines()]
    return Outputs(out, json.loads((out / "summary.json").read_text()), events)


@pytest.fixture
def run_toml(tmp_path: Path):
    """``run_toml(text)`` parses a TOML scenario, runs it into a fresh folder and returns its outputs."""
    counter = iter(range(1_000_000))

    def run(text: str) -> Outputs:
        scenario = parse(tomllib.loads(text), "<test>")
        return run_scenario(scenario, tmp_path / f"run{next(counter)}")

    return run


# --- hypothesis profiles (docs/fuzzing.md) ------------------------------------------------------------------
# ``ci`` (the default) keeps the whole fuzz set well under a minute on two cores; ``deep`` is for long
# campaigns: ``pytest --hypothesis-profile=deep`` or ``VCRAN_HYPOTHESIS_PROFILE=deep pytest``; ``nightly``
# is for a scheduled job (about an hour) whose failures must reproduce from the log alone, hence
# print_blob. All build on the ``vcran`` profile above (no deadline). The example database (.hypothesis/)
# replays earlier failures first; it stays out of git.

settings.register_profile("ci", parent=settings.get_profile("vcran"), max_examples=100, stateful_step_count=50)
settings.register_profile("deep", parent=settings.get_profile("vcran"), max_examples=5_000,
                          stateful_step_count=120)
settings.register_profile("nightly", parent=settings.get_profile("vcran"), max_examples=20_000,
                          stateful_step_count=200, print_blob=True)
settings.load_profile(os.environ.get("VCRAN_HYPOTHESIS_PROFILE", "ci"))
