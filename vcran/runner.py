"""Run a scenario to its output folder: ``trace.jsonl`` (+ ``telemetry.bin``), ``events.jsonl``, ``summary.json``.

The one function every command uses (run, replay, live, fuzz), so the three files are always produced the
same way. Only simulated quantities go into them (SPEC §5); wall-clock figures are returned for printing.
:func:`run_model` is the part that does not care where the records go: :func:`vcran.simulate` uses it
with in-memory sinks when no folder is given.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any, Protocol

import simpy

from transports.record import RecordingTransport, TraceSink
from vcran.core.scenario import Scenario
from vcran.core.wire import Transport
from vcran.io.trace import TraceWriter, dumps
from vcran.sim.model import EventSink, Model


class EventLog:
    """``events.jsonl``: one object per line, ``t``, ``robot``, ``event`` and the event's fields."""

    def __init__(self, path: Path) -> None:
        self._f: IO[bytes] = path.open("wb", buffering=1 << 20)
        self.count = 0

    def write(self, t: float, robot: str, name: str, fields: dict[str, Any]) -> None:
        self._f.write(dumps({"t": t, "robot": robot, "event": name, **fields}) + b"\n")
        self.count += 1

    def flush(self) -> None:
        self._f.flush()

    def close(self) -> None:
        self._f.close()


class ClosingEventSink(EventSink, Protocol):
    def close(self) -> None: ...


@dataclass(frozen=True, slots=True)
class RunResult:
    summary: dict[str, Any]
    events: int
    wall_seconds: float
    model: Model

    @property
    def speed(self) -> float:
        """Simulated seconds per wall second."""
        return self.summary["sim_time"] / self.wall_seconds if self.wall_seconds > 0 else float("inf")


def run_to(
    scenario: Scenario,
    out: Path,
    transport: Transport,
    *,
    options: dict[str, Any] | None = None,
    env: simpy.Environment | None = None,
    on_start: Callable[[Model], None] | None = None,
    progress: Callable[[float, int], None] | None = None,
    flush_every_tick: bool = False,
) -> RunResult:
    """Simulate ``scenario`` with ``transport``, recording everything into the folder ``out``.

    ``progress`` is called with (simulated time, tasks completed) every telemetry period while it runs
    (:class:`vcran.io.progress.ProgressBar` is one); it observes and cannot change the outputs.
    ``flush_every_tick`` (live mode) hands the trace, telemetry and events to the operating system at
    every telemetry tick, so that a run killed outright keeps its recording up to its last tick.
    """
    out.mkdir(parents=True, exist_ok=True)
    events = EventLog(out / "events.jsonl")
    writer = trace_writer(scenario, out, options)

    def flush() -> None:
        writer.flush()
        events.flush()

    model, wall = run_model(scenario, transport, writer, events, env=env, on_start=on_start, progress=progress,
                            after_frame=flush if flush_every_tick else None)
    summary = model.summary()
    write_summary(out, summary)
    return RunResult(summary, events.count, wall, model)


def trace_writer(scenario: Scenario, out: Path, options: dict[str, Any] | None) -> TraceWriter:
    """The trace of a run of ``scenario`` in ``out``; its header carries the fleet, so a replay needs nothing else."""
    header = {
        "scenario": scenario.settings.name,
        "seed": scenario.settings.seed,
        "options": options or {},
        "fleet": scenario.fleet_dict(),
    }
    return TraceWriter(out, header, tuple(r.id for r in scenario.robots))


def write_summary(out: Path, summary: dict[str, Any]) -> None:
    (out / "summary.json").write_text(json.dumps(summary, indent=2, ensure_ascii=False) + "\n", encoding="utf-8")


def run_model(
    scenario: Scenario,
    transport: Transport,
    trace: TraceSink,
    events: ClosingEventSink,
    *,
    env: simpy.Environment | None = None,
    on_start: Callable[[Model], None] | None = None,
    progress: Callable[[float, int], None] | None = None,
    after_frame: Callable[[], None] | None = None,
) -> tuple[Model, float]:
    """Build the model, run it to its end with every message recorded into ``trace`` and every event into
    ``events``, close both; return the model and the wall-clock seconds it took. ``after_frame`` runs
    after each telemetry frame is recorded."""
    recording = RecordingTransport(transport, trace, after_frame=after_frame)
    start = time.perf_counter()
    try:
        model = Model(scenario, recording, events, env=env, progress=progress)
        if on_start is not None:
            on_start(model)
        model.run()
        trace.end(model.env.now)
    finally:
        recording.close()
        events.close()
    return model, time.perf_counter() - start
