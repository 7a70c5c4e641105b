"""Run folders for the view's tests, made once per test module: every kind vcran writes (docs/contract.md §13)."""

from __future__ import annotations

import json
import shutil
import tomllib
from pathlib import Path

from tests.conftest import ROOT, read_lines, write_lines
from vcran.api import simulate
from vcran.io.gen import generate
from vcran.io.scenario_file import parse
from vcran.io.trace import EVENTS_FILE, LEGS_FILE, TRACE_FILE
from vcran.io.trace.writers import _npy_header


def bundled(name: str, out: Path) -> Path:
    """``vcran run scenarios/NAME.toml --out out``: the scenario's script, or its fleet manager."""
    simulate(ROOT / "scenarios" / f"{name}.toml", out=out)
    return out


def generated(robots: int, hours: float, out: Path, seed: int = 1) -> Path:
    """A generated fleet (``vcran gen``), run with its script."""
    simulate(parse(tomllib.loads(generate(robots, hours, seed)), str(out.with_suffix(".toml"))), out=out)
    return out


def managed(run: Path, out: Path) -> Path:
    """What ``vcran manage --out`` leaves (docs/live.md): the job events and a summary with ``jobs``, no trace,
    here taken from a closed-loop run's folder."""
    out.mkdir(parents=True)
    lines = [line for line in read_lines(run / EVENTS_FILE) if '"event":"job_' in line]
    write_lines(out / EVENTS_FILE, lines)
    summary = json.loads((run / "summary.json").read_text())
    (out / "summary.json").write_text(json.dumps({"scenario": summary["scenario"], "manager": "dispatcher",
                                                  "sim_time": summary["sim_time"], "jobs": summary["jobs"]}))
    return out


def still_running(run: Path, out: Path, cut: int) -> Path:
    """A live run's folder while it runs (``<out>.incomplete``): no summary, no end record, and the leg
    log's header not yet counting its rows; the trace and events end after ``cut`` of their lines."""
    shutil.copytree(run, out)
    (out / "summary.json").unlink()
    trace = read_lines(out / TRACE_FILE)
    write_lines(out / TRACE_FILE, trace[:cut])
    write_lines(out / EVENTS_FILE, read_lines(out / EVENTS_FILE)[:cut])
    legs = out / LEGS_FILE
    legs.write_bytes(_npy_header(0) + legs.read_bytes()[len(_npy_header(0)):])
    return out
