"""Run a scenario to its output folder: ``trace.jsonl.zst``, ``legs.npy``, ``events.jsonl.zst``, ``summary.json``.

The one function every command uses (run, replay, live, fuzz), so the files are always produced the
same way. Only simulated quantities go into them (SPEC §5); wall-clock figures are returned for printing.
:func:`run_model` is the part that does not care where the records go: :func:`vcran.simulate` uses it
with in-memory sinks when no folder is given.
"""

from __future__ import annotations

import gc
import json
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from itertools import islice
from pathlib import Path
from typing import Any, Protocol

import simpy

from transports.record import RecordingTransport, TraceSink
from vcran.core.scenario import Scenario
from vcran.core.wire import Transport
from vcran.io.runfolder import publish, staging
from vcran.io.trace import EVENTS_FILE, SUMMARY_FILE, EventWriter, TraceWriter
from vcran.sim.model import EventSink, Model

#: ``events.jsonl.zst`` of a run folder (the name main's callers use).
EventLog = EventWriter

#: Allocations between young-generation collections while a run is under way (CPython's default: 700).
GC_THRESHOLD = 50_000
#: Growth of the heap (objects the collector tracks), since the last full collection, that makes
#: :func:`_quiet_collector` collect in full before a run; and that heap's size then (one entry).
GC_GROWTH = 20_000
_HEAP: list[int] = []


@contextmanager
def _quiet_collector() -> Iterator[None]:
    """Freeze what exists once the model is built and collect the young generation rarely.

    A run allocates millions of short-lived objects that reference counting frees, and keeps a large,
    long-lived model that the cyclic collector would otherwise walk again and again (3% of a 100-robot
    run, 14% of a 1000-robot one). The collector's state is the process's: it is restored afterwards.
    Freezing is a constant-time move, but it hides the process's garbage from the collector's own rule
    for full collections: ``unfreeze`` puts everything back in the oldest generation without counting it
    as new there, so a process running run after run (a sweep's worker, a fuzzing campaign, a test
    suite, ``vcran.simulate`` in a loop) never collected the cycles of earlier runs' models: 0.3 MB a
    demo run, gigabytes over a nightly fuzz. So before freezing, the process is collected in full when
    what is about to be frozen has grown by a quarter since the last full collection here (and by
    :data:`GC_GROWTH` objects at least): amortised, as CPython's own rule is, and never in the single
    run of ``vcran run``.
    """
    threshold = gc.get_threshold()
    tracked = gc.get_freeze_count()  # frozen by someone else before (an application, before forking): not ours
    gc.freeze()
    now = gc.get_freeze_count() - tracked
    if not _HEAP:
        _HEAP.append(now)
    elif now > max(_HEAP[0] * 5 // 4, _HEAP[0] + GC_GROWTH):
        gc.unfreeze()
        gc.collect()
        gc.freeze()
        _HEAP[0] = gc.get_freeze_count() - tracked
    gc.set_threshold(GC_THRESHOLD, threshold[1], threshold[2])
    try:
        yield
    finally:
        # What the run left alive joins the old generation with the rest (frozen, then all unfrozen there)
        # rather than staying young: left young, the first allocations after the run (the summary's) made
        # the collector walk it, about 0.12 s after a 1000-robot hour (issue 30); in the oldest generation
        # it waits for a full collection, which the growth rule above still makes before a later run.
        gc.freeze()
        gc.set_threshold(*threshold)
        gc.unfreeze()


class ClosingEventSink(EventSink, Protocol):
    def close(self) -> None: ...


@dataclass(frozen=True, slots=True)
class RunResult:
    """What :func:`run_to` returns: the summary (as written to summary.json), how many events were
    written, the wall-clock seconds the run took, and the model as it ended."""

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

    The files are written into ``<out>.incomplete`` and renamed to ``out`` when the run has ended
    (:mod:`vcran.io.runfolder`); an existing ``out`` that is not a run folder raises RunFolderError.
    ``progress`` is called with (simulated time, tasks completed) every telemetry period while it runs
    (:class:`vcran.io.progress.ProgressBar` is one); it observes and cannot change the outputs.
    ``flush_every_tick`` (live mode) hands the trace, legs and events to the operating system at
    every telemetry tick, so that a run killed outright keeps its recording up to its last tick.
    """
    work = staging(out)
    events = EventWriter(work / EVENTS_FILE)
    writer = trace_writer(scenario, work, options)

    def flush() -> None:
        writer.flush()
        events.flush()

    model, wall = run_model(scenario, transport, writer, events, env=env, on_start=on_start, progress=progress,
                            after_frame=flush if flush_every_tick else None)
    summary = model.summary()
    write_summary(work, summary)
    publish(work, out)
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
    """summary.json: ``json.dumps(summary, indent=2, ensure_ascii=False)`` and a newline, encoded as it is written.

    At fleet scale the summary lists every task id a run ended (320,000 in a 1000-robot, 4-hour run). Built
    as one text, the encoder's pieces and the joined text cost about 150 bytes per task at once, and that
    was the run's peak memory (issue 14); written a few thousand pieces at a time, it costs a constant.
    """
    pieces = json.JSONEncoder(indent=2, ensure_ascii=False).iterencode(summary)
    with (out / SUMMARY_FILE).open("w", encoding="utf-8") as f:
        while batch := list(islice(pieces, 4096)):
            f.write("".join(batch))
        f.write("\n")


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
    """Build the model, run it to its end with every message recorded into ``trace`` (legs too) and every
    event into ``events``, close both; return the model and the wall-clock seconds it took.
    ``after_frame`` runs after each telemetry frame is recorded."""
    recording = RecordingTransport(transport, trace, after_frame=after_frame)
    start = time.perf_counter()
    try:
        model = Model(scenario, recording, events, env=env, progress=progress)
        model.fleet.observer = trace
        if on_start is not None:
            on_start(model)
        with _quiet_collector():
            model.run()
        trace.end(model.env.now)
    finally:
        recording.close()
        events.close()
    return model, time.perf_counter() - start
