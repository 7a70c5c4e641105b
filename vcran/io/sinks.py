"""Where a run's records go: a run folder, or memory (docs/contract.md §8; docs/outputs.md).

Every entry point that runs something (``vcran run``, ``replay``, ``live``, ``manage``, :func:`vcran.simulate`,
sweeps, fuzzing) hands its records to one of these, and only to these, so that a folder is always staged,
written and published the same way (:mod:`vcran.io.runfolder`): :class:`FolderSinks` writes
``events.jsonl.zst``, the trace (``trace.jsonl.zst`` + ``legs.npy``; ``vcran manage``, which runs no model,
has none) and, at :meth:`FolderSinks.finish`, ``summary.json``, into ``<out>.incomplete``, renamed to
``out`` then. :class:`MemorySinks` keeps the events and telemetry of a run without a folder: OPIL's
telemetry frames as they are published, or, for vehicles that publish none (VDA 5050), the leg log a folder's
``legs.npy`` holds, from which the telemetry is evaluated as a folder run's is.
"""

from __future__ import annotations

import json
import shutil
from collections.abc import Callable
from itertools import islice
from pathlib import Path
from typing import TYPE_CHECKING, Any

from vcran.core.motion import Leg
from vcran.core.scenario import VDA5050, Scenario
from vcran.core.wire import Frame, Inbound, Publish
from vcran.io.runfolder import publish, staging
from vcran.io.trace import EVENTS_FILE, SUMMARY_FILE, EventWriter, TraceWriter
from vcran.io.trace.files import leg_dtype
from vcran.io.trace.reconstruct import from_legs
from vcran.io.trace.writers import HALT, abandon_columns, leg_columns

if TYPE_CHECKING:
    import numpy as np


class FolderSinks:
    """A run folder ``out``, staged as ``<out>.incomplete`` from the start (an ``out`` that cannot receive a
    run raises :class:`~vcran.io.runfolder.RunFolderError` here, before anything runs).

    With a ``scenario`` the trace is opened too, its header carrying the fleet and ``options`` (so that a
    replay needs nothing else); without, the folder holds events and a summary (``vcran manage``).
    ``flush_every_tick`` (live mode) hands the files to the operating system after every telemetry
    frame, so that a run killed outright keeps its recording up to its last tick.
    """

    def __init__(self, out: Path, scenario: Scenario | None = None, options: dict[str, Any] | None = None, *,
                 flush_every_tick: bool = False) -> None:
        self.out = out
        self.work = staging(out)
        self.events = EventWriter(self.work / EVENTS_FILE)
        self.trace = trace_writer(scenario, self.work, options) if scenario is not None else None
        self.after_frame: Callable[[], None] | None = self._flush if flush_every_tick else None

    def _flush(self) -> None:
        assert self.trace is not None
        self.trace.flush()
        self.events.flush()

    def finish(self, summary: dict[str, Any]) -> None:
        """Write ``summary.json`` and put the folder in place of ``out``. Called only for a run that ended:
        one that raised leaves ``<out>.incomplete`` behind, never a folder that looks finished."""
        write_summary(self.work, summary)
        publish(self.work, self.out)

    def discard(self) -> None:
        """Nothing ran (it could not start): close the files and leave no folder behind."""
        self.events.close()
        if self.trace is not None:
            self.trace.close()
        shutil.rmtree(self.work, ignore_errors=True)


class MemorySinks:
    """A run without a folder: its events as dicts, and of its trace only what its telemetry needs: the
    frames (:class:`Frames`), or with a VDA 5050 ``scenario``, whose vehicles publish no frame, the leg log
    (:class:`LegRows`)."""

    out: Path | None = None
    after_frame: Callable[[], None] | None = None

    def __init__(self, scenario: Scenario | None = None) -> None:
        self.events = EventList()
        self.trace: Frames | LegRows = (LegRows(scenario.fleet_dict())
                                        if scenario is not None and scenario.settings.protocol == VDA5050 else Frames())

    def finish(self, summary: dict[str, Any]) -> None:
        pass

    def discard(self) -> None:
        pass


#: Where a run's records go (what :func:`vcran.runner.execute` and ``vcran manage`` take).
Sinks = FolderSinks | MemorySinks


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


class EventList:
    """The events of an in-memory run: the dicts :func:`vcran.io.trace.event_records` reads back from a
    run folder's events file, one per event (fields without a value left out, as there)."""

    def __init__(self) -> None:
        self.events: list[dict[str, Any]] = []

    @property
    def count(self) -> int:
        return len(self.events)

    def write(self, t: float, robot: str, name: str, fields: dict[str, Any]) -> None:
        self.events.append({"t": t, "robot": robot, "event": name, **{k: v for k, v in fields.items() if v is not None}})

    def close(self) -> None:
        pass


class _MemoryTrace:
    """The trace of an in-memory run: only what its telemetry needs is kept (a trace without a file cannot
    be replayed, and the summary and events hold the rest); the rest of a trace's calls do nothing."""

    wants_frames = False

    def inbound(self, t: float, inbound: Inbound) -> None:
        pass

    def publish(self, out: Publish) -> None:
        pass

    def frame(self, frame: Frame) -> None:
        pass

    def leg(self, robot: int, leg: Leg, t: float) -> None:
        pass

    def halt(self, robot: int, t: float) -> None:
        pass

    def abandon(self, robot: int, t: float, pose: tuple[float, float, float]) -> None:
        pass

    def end(self, t: float) -> None:
        pass

    def close(self) -> None:
        pass

    def samples(self, robots: int) -> np.ndarray:
        """The telemetry of the run of ``robots`` robots as :func:`vcran.io.trace.samples` gives a folder's."""
        raise NotImplementedError


class Frames(_MemoryTrace):
    """The telemetry frames, as they are published (OPIL)."""

    wants_frames = True

    def __init__(self) -> None:
        self.frames: list[tuple[float, np.ndarray]] = []

    def frame(self, frame: Frame) -> None:
        self.frames.append((frame.t, frame.columns))

    def samples(self, robots: int) -> np.ndarray:
        import numpy as np

        return np.array([[t, *columns.ravel()] for t, columns in self.frames], dtype="<f8").reshape(
            -1, 1 + robots * len(Frame.FIELDS))


class LegRows(_MemoryTrace):
    """The leg log, row for row as a folder's ``legs.npy`` holds it, and the run's end: the telemetry of
    vehicles that publish no frame (VDA 5050), evaluated as a folder run's is (:func:`from_legs`), bit for bit.
    ``fleet``: the fleet as a trace header holds it (:meth:`Scenario.fleet_dict`)."""

    def __init__(self, fleet: dict[str, Any]) -> None:
        self.fleet = fleet
        self.rows: list[tuple[float, ...]] = []
        self.ended = 0.0

    def leg(self, robot: int, leg: Leg, t: float) -> None:
        self.rows.append((t, robot, *leg_columns(leg)))

    def halt(self, robot: int, t: float) -> None:
        self.rows.append((t, robot, *HALT))

    def abandon(self, robot: int, t: float, pose: tuple[float, float, float]) -> None:
        self.rows.append((t, robot, *abandon_columns(pose)))

    def end(self, t: float) -> None:
        self.ended = t

    def samples(self, robots: int) -> np.ndarray:
        import numpy as np

        return from_legs(self.fleet, np.array(self.rows, dtype=leg_dtype()), self.ended)
