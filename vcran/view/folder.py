"""A run folder read for the page (docs/contract.md §13): whatever it holds, and a note for each thing it lacks.

Every kind of folder vcran writes is read: ``vcran run`` (scripted or a closed loop), ``vcran replay``,
``vcran live`` (finished, or still running in ``<out>.incomplete``, read up to its last whole line and
leg row), and ``vcran manage --out``, which holds a fleet manager's job events and summary but no trace:
there is then no fleet to draw, and :attr:`RunFiles.notes` says so in the page rather than refusing it.
Only vcran's own readers (:mod:`vcran.io.trace`) touch the files.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from functools import cache
from pathlib import Path
from typing import Any

import numpy as np

from vcran.io.runfolder import INCOMPLETE
from vcran.io.trace import (
    EVENTS_FILE,
    EVENTS_FILE_V1,
    LEGS_FILE,
    SUMMARY_FILE,
    event_records,
    events_beside,
    legs,
    read_header,
    records,
    robots_of,
    trace_in,
    zst_cut_off,
)

Point = tuple[float, float]


class ViewError(Exception):
    """The folder cannot be shown at all (no such folder, no run files, a file that does not read); the
    message names the file and why."""


@dataclass
class RunFiles:
    """What one run folder holds, checked; absent parts are None or empty, and ``notes`` says why."""

    path: Path
    #: The trace header (``fleet``: robots, stations, settings), or None without a trace.
    header: dict[str, Any] | None
    summary: dict[str, Any] | None
    #: The events in file order, fields without a value left out.
    events: list[dict[str, Any]]
    #: ``legs.npy`` as a structured array (:data:`vcran.io.trace.LEG_COLUMNS`), or None.
    legs: np.ndarray | None
    robots: list[str]
    #: When the run stopped (or, still running, its latest recorded instant).
    end: float
    #: False while the run is still being written (or was killed): files read up to their last whole line.
    complete: bool
    #: robot -> (t, percentage) of each published ``battery_state``.
    batteries: dict[str, list[tuple[float, float]]] = field(default_factory=dict)
    #: (robot, action label) -> what the action does (``load``, ``unload``, ...), from the assignments.
    actions: dict[tuple[str, str], str] = field(default_factory=dict)
    #: (robot, polygon) of every non-empty motion area sent, first time each.
    areas: list[tuple[str, tuple[Point, ...]]] = field(default_factory=list)
    #: One sentence per thing the page cannot draw, and why.
    notes: list[str] = field(default_factory=list)

    @property
    def source(self) -> str:
        """Which command wrote the folder: ``scripted``, ``replay``, ``loop``, ``live`` or ``manage``."""
        if self.header is None:
            return "manage"
        return str(self.header.get("options", {}).get("transport", "scripted"))


def read_folder(path: Path) -> RunFiles:
    """Read the run folder ``path`` (module docstring); :class:`ViewError` when nothing in it can be shown."""
    if not path.is_dir():
        raise ViewError(f"{path}: no such folder (expected a run folder: the --out of vcran run, replay, live or manage)")
    running = path.name.endswith(INCOMPLETE)
    try:
        trace: Path | None = trace_in(path)
    except ValueError:
        trace = None
    events_path = events_beside(trace) if trace is not None else path / EVENTS_FILE
    if not events_path.is_file() and (path / EVENTS_FILE_V1).is_file():
        events_path = path / EVENTS_FILE_V1
    if trace is None and not events_path.is_file():
        raise ViewError(f"{path}: not a run folder (no trace.jsonl.zst and no {EVENTS_FILE})")
    notes: list[str] = []
    header, robots, end, complete, leg_rows = None, [], 0.0, not running, None
    if trace is not None:
        with _reading(trace):
            header = read_header(trace)
            robots = robots_of(header)
            from vcran.io.verify import recorded_end

            end, complete = recorded_end(trace, header)
            if header["version"] == 1:
                notes.append("a format 1 recording (telemetry.bin, no leg log): robots cannot be drawn moving; "
                             "replay it with a current vcran to get its legs")
            else:
                leg_path = trace.parent / str(header["legs"]["file"])
                if leg_path.is_file():
                    with _reading(leg_path):
                        leg_rows = legs(leg_path, cut_off=not complete)
                else:
                    notes.append(f"no {LEGS_FILE}: robots are drawn where they started, not moving")
    else:
        notes.append("no trace.jsonl.zst: the layout and the robots cannot be drawn (a vcran manage --out folder "
                     "holds the fleet manager's job events and summary only); jobs and incidents are shown")
    summary = _summary(path / SUMMARY_FILE)
    if summary is None and complete and trace is not None:
        notes.append(f"no {SUMMARY_FILE}: the run's totals are not shown")
    events = _events(events_path, cut_off=not complete) if events_path.is_file() else []
    if not events_path.is_file():
        notes.append(f"no {events_path.name}: states, tasks, loads, jobs and incidents cannot be shown")
    if summary is not None and complete:
        end = float(summary.get("sim_time", end))
    end = max(end, max((float(e["t"]) for e in events), default=0.0))
    if not robots:  # no trace: the robots the events name (a fleet-level event names "")
        robots = sorted({str(e["robot"]) for e in events if e.get("robot")})
    files = RunFiles(path, header, summary, events, leg_rows, robots, end, complete, notes=notes)
    if trace is not None:
        _assignments(trace, files)
    return files


@contextmanager
def _reading(path: Path) -> Iterator[None]:
    """Whatever goes wrong reading ``path`` becomes one :class:`ViewError` that names it."""
    try:
        yield
    except (OSError, ValueError, KeyError, TypeError, IndexError) as exc:
        reason = f"missing field {exc}" if isinstance(exc, KeyError) else str(exc) or type(exc).__name__
        raise ViewError(f"{path}: unreadable ({reason})") from None


def _summary(path: Path) -> dict[str, Any] | None:
    if not path.is_file():
        return None
    with _reading(path):
        summary = json.loads(path.read_text(encoding="utf-8"))
    if not isinstance(summary, dict):
        raise ViewError(f"{path}: unreadable (not a JSON object)")
    return summary


def _events(path: Path, cut_off: bool) -> list[dict[str, Any]]:
    """The events, each an object with a numeric ``t``, a string ``robot`` and ``event``. A finished run's
    file cut off is refused (it would pass for a shorter run); a running one's is read to its last line."""
    out = []
    with _reading(path):
        if not cut_off and path.suffix == ".zst" and zst_cut_off(path):
            raise ValueError("cut off: the zstd stream ends before its end")
        for n, event in enumerate(event_records(path, cut_off=cut_off), start=1):
            if not (isinstance(event, dict) and isinstance(event.get("t"), int | float) and math.isfinite(event["t"])
                    and isinstance(event.get("robot"), str) and isinstance(event.get("event"), str)):
                raise ViewError(f"{path}:{n}: not an event (an object with t, robot and event expected)")
            out.append(event)
    return out


NIL_UUID = "00000000-0000-0000-0000-000000000000"


def label(ident: Any) -> str:
    """An id as events and summary name it (docs/outputs.md): its description, else its canonical uuid;
    given in full (``{"uuid", "description"}``) or compact as a format 2 trace writes it (the name, null
    for the nil id, ``[uuid, description]``; vcran.io.render)."""
    if isinstance(ident, dict):
        return str(ident.get("description") or ident.get("uuid", ""))
    if isinstance(ident, list) and len(ident) == 2:
        return str(ident[1] or ident[0])
    return NIL_UUID if ident is None else str(ident)


def _assignments(trace: Path, files: RunFiles) -> None:
    """Battery levels, what each action does and the motion areas, from the trace in one pass. A live
    run records inbound payloads raw, as Orion delivered them: they are decoded as the RAN decoded them,
    and one that does not decode (the RAN rejected it) is skipped."""
    seen: set[tuple[str, tuple[Point, ...]]] = set()
    with _reading(trace):
        for _, record in records(trace, attrs=("battery_state", "action_assignment", "motion_assignment"),
                                 expanded=False):
            attr, robot, t = record.get("attr"), str(record.get("robot")), float(record["t"])
            if attr == "battery_state":
                if record.get("dir") == "out":
                    files.batteries.setdefault(robot, []).append((t, float(record["value"]["percentage"])))
                continue
            if record.get("dir") != "in":
                continue
            value = record["value"] if "value" in record else _decoded(str(attr), record.get("raw"))
            if value is None:
                continue
            if attr == "action_assignment":
                kind = _action_kind(value)
                if kind is not None:
                    files.actions[robot, label(value["action_id"])] = kind
                continue
            points = tuple((float(p["x"]), float(p["y"])) for p in value["motion_area"]["polygon"]["points"])
            if points and (robot, points) not in seen:
                seen.add((robot, points))
                files.areas.append((robot, points))


def _decoded(attr: str, raw: Any) -> dict[str, Any] | None:
    from vcran.core.opil.codec import decode_attribute
    from vcran.core.opil.plain import to_plain

    try:
        return to_plain(decode_attribute(attr, raw))
    except ValueError:
        return None


def _action_kind(value: dict[str, Any]) -> str | None:
    """What an assigned action does (its category or code, docs/contract.md §2), None for a code the RAN rejected."""
    action = value.get("robot_action") or {}
    try:
        return _kind(int(action.get("category", 0)), int(action.get("action", 0)))
    except (ValueError, TypeError):
        return None


@cache
def _kind(category: int, code: int) -> str | None:
    from vcran.core.opil.messages import RobotAction

    try:
        return RobotAction(category=category, action=code).kind.value
    except ValueError:  # MessageError: a code the RAN rejected
        return None
