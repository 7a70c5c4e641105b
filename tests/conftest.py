"""Shared test helpers (run a scenario written inline as TOML, read its outputs back) and suite settings.

Hypothesis runs with the ``vcran`` profile of vcran's own pytest plugin (:mod:`vcran.testing.pytest_plugin`,
the one users opt into): no per-example deadline, no too_slow health check. ``pytest
--hypothesis-profile=vcran-deep`` (or ``vcran-nightly``) overrides it for a long campaign (hypothesis loads a
profile given on the command line after this file).
"""

from __future__ import annotations

import json
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest
from hypothesis import settings

from transports.scripted import ScriptedTransport
from vcran.core.scenario import Scenario
from vcran.io.scenario_file import parse
from vcran.io.trace import EVENTS_FILE, event_records, open_input, open_output, records, trace_in
from vcran.runner import run_to

settings.load_profile("vcran")  # registered by the plugin, which pytest loaded before this file

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
        return [r for _, r in records(trace_in(self.dir)) if r["dir"] != "end"]


class HandClock:
    """A clock moved by hand (``clock.now += 0.25``): what code given a clock function reads, in wall-clock
    or monotonic seconds, without waiting."""

    def __init__(self, now: float = 0.0) -> None:
        self.now = now

    def __call__(self) -> float:
        return self.now


def read_lines(path: Path) -> list[str]:
    """The lines of a run file, compressed (``.zst``) or not."""
    with open_input(path) as f:
        return f.read().decode("utf-8").splitlines()


def write_lines(path: Path, lines: list[str]) -> None:
    """Write a run file back, compressed when its name ends in ``.zst`` (tests that tamper with one)."""
    with open_output(path) as f:
        f.write(("\n".join(lines) + "\n").encode("utf-8"))


def run_scenario(scenario: Scenario, out: Path) -> Outputs:
    run_to(scenario, out, ScriptedTransport(scenario.messages()))
    events = list(event_records(out / EVENTS_FILE))
    return Outputs(out, json.loads((out / "summary.json").read_text()), events)


@pytest.fixture
def run_toml(tmp_path: Path):
    """``run_toml(text)`` parses a TOML scenario, runs it into a fresh folder and returns its outputs."""
    counter = iter(range(1_000_000))

    def run(text: str) -> Outputs:
        scenario = parse(tomllib.loads(text), "<test>")
        return run_scenario(scenario, tmp_path / f"run{next(counter)}")

    return run


# --- test lanes (README "Development") ----------------------------------------------------------------------

#: Fixtures that make every test using them slow: a real headless browser (tests/view), and ``vcran broker``
#: as a process of its own, with vcran's commands around it as a user starts them (live and manage end to end).
SLOW_FIXTURES = frozenset({"browser", "broker_process"})


@pytest.hookimpl(tryfirst=True)  # before ``-m`` deselects by marker
def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Mark ``slow`` every test that uses a :data:`SLOW_FIXTURES` fixture; other slow tests say so
    themselves (``@pytest.mark.slow``). ``pytest -m "not slow"`` is the inner loop; CI runs everything."""
    for item in items:
        if SLOW_FIXTURES.intersection(getattr(item, "fixturenames", ())):
            item.add_marker(pytest.mark.slow)
