"""One way to wire a run: :func:`execute` builds the model for a scenario and a transport, runs it with
every record going to the run's sinks, and publishes the summary (docs/contract.md §5, §8).

Every entry point calls it with its transport and sinks (:mod:`vcran.io.sinks`: a run folder, or memory):
``vcran run`` and :func:`vcran.simulate` (through :func:`vcran.api.run`: the script, or a fleet manager in
a closed loop), ``vcran replay``, ``vcran live``, sweeps and fuzzing; :func:`run_to` is the short form for a
folder. ``vcran manage`` runs no model (a fleet manager against Orion): it shares the sinks and the summary's
publication. Only simulated quantities go into the files; wall-clock figures are returned for printing.
"""

from __future__ import annotations

import gc
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import simpy

from transports.record import RecordingTransport
from vcran.core.scenario import OPIL, VDA5050, Scenario
from vcran.core.wire import Transport
from vcran.io.sinks import FolderSinks, Sinks
from vcran.io.toml_table import ScenarioError
from vcran.sim.model import Model

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


@dataclass(frozen=True, slots=True)
class RunResult:
    """What :func:`execute` returns: the summary (as published: summary.json), how many events were
    written, the wall-clock seconds the run took, and the model as it ended."""

    summary: dict[str, Any]
    events: int
    wall_seconds: float
    model: Model

    @property
    def speed(self) -> float:
        """Simulated seconds per wall second."""
        return self.summary["sim_time"] / self.wall_seconds if self.wall_seconds > 0 else float("inf")


#: The mode a run with a fleet manager is (:func:`check_protocol`): both protocols' closed loops are hosted.
CLOSED_LOOP = "a closed loop"
#: The edge to a real broker each protocol is hosted on: ``vcran live`` and ``vcran manage`` with this option
#: (the ``mode`` :func:`check_protocol` is given: ``"vcran live --mqtt"`` ...).
EDGES = {OPIL: "--orion", VDA5050: "--mqtt"}


def check_protocol(scenario: Scenario, mode: str | None = None) -> None:
    """A scenario whose robots speak a protocol the simulation does not host in ``mode`` is refused before
    anything runs (or any folder is made, or anything is connected to). ``mode`` None: a scripted run or a
    replay, which host every protocol of :mod:`vcran.sim.protocols`; :data:`CLOSED_LOOP`, which hosts both
    (OPIL's fleet manager, VDA 5050's master); ``vcran live`` and ``vcran manage`` host each protocol on its own
    edge (:data:`EDGES`); else what the caller runs, which hosts OPIL only: VDA 5050 vehicles would be driven
    as OPIL robots, deaf to their orders."""
    protocol = scenario.settings.protocol
    command, _, given = (mode or "").rpartition(" ")
    if command in ("vcran live", "vcran manage") and given in EDGES.values():  # docs/contract.md §11: each protocol's edge
        if given != EDGES[protocol]:
            verb = "go live" if command == "vcran live" else "are managed"
            raise ScenarioError(f"{scenario.source}: [simulation] protocol = {protocol!r}: its robots {verb} with "
                                f"{EDGES[protocol]} URL, not {given}")
        return
    if protocol != OPIL and mode not in (None, CLOSED_LOOP):
        raise ScenarioError(f"{scenario.source}: [simulation] protocol = {protocol!r}: the simulation does not host "
                            f"VDA 5050 vehicles yet in {mode} (it runs their script and their master in a closed "
                            "loop: vcran run, vcran.simulate, vcran replay; live: vcran live --mqtt, vcran manage --mqtt)")


def execute(
    scenario: Scenario,
    transport: Transport,
    sinks: Sinks,
    *,
    env: simpy.Environment | None = None,
    on_start: Callable[[Model], None] | None = None,
    progress: Callable[[float, int], None] | None = None,
    summarize: Callable[[Model], dict[str, Any]] = Model.summary,
) -> RunResult:
    """Simulate ``scenario`` with ``transport``, every message recorded into ``sinks.trace`` (legs too) and
    every event into ``sinks.events``; then publish ``summarize(model)`` (summary.json) through ``sinks``.

    ``env`` is the environment to run in (live mode: a :class:`vcran.sim.live.LiveEnvironment`; else a
    fresh one); ``on_start`` is called with the model before it runs (the commands keep it to stop it on a
    signal); ``progress`` with (simulated time, tasks completed) every telemetry period, an observer that
    cannot change the outputs (:class:`vcran.io.progress.ProgressBar` is one). A run that raises closes
    the files and publishes nothing: a folder stays ``<out>.incomplete``.
    """
    trace, events = sinks.trace, sinks.events
    assert trace is not None, "a run's sinks have a trace (only vcran manage's folder has none)"
    recording = RecordingTransport(transport, trace, after_frame=sinks.after_frame)
    start = time.perf_counter()
    try:
        model = Model(scenario, recording, events, env=env, progress=progress, protocol=scenario.settings.protocol)
        model.fleet.observer = trace
        if on_start is not None:
            on_start(model)
        with _quiet_collector():
            model.run()
        trace.end(model.env.now)
    finally:
        recording.close()
        events.close()
    wall = time.perf_counter() - start
    summary = summarize(model)
    sinks.finish(summary)
    return RunResult(summary, events.count, wall, model)


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
    """:func:`execute` into the run folder ``out`` (``trace.jsonl.zst``, ``legs.npy``, ``events.jsonl.zst``,
    ``summary.json``), ``options`` in the trace's header: what ``vcran replay`` and ``vcran live`` run, and
    a transport of one's own (docs/outputs.md). The files are written into ``<out>.incomplete`` and
    renamed to ``out`` when the run has ended (:mod:`vcran.io.runfolder`); an existing ``out`` that is not
    a run folder raises RunFolderError. ``flush_every_tick``: see :class:`vcran.io.sinks.FolderSinks`.
    """
    sinks = FolderSinks(out, scenario, options, flush_every_tick=flush_every_tick)
    return execute(scenario, transport, sinks, env=env, on_start=on_start, progress=progress)
