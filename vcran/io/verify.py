"""Replay a recorded trace and verify it (docs/contract.md §6): ``vcran replay TRACE --out DIR [--verify]``.

The trace header carries the fleet (the scenario without its script) and the last line when the run
stopped, so the trace alone is enough: the replay runs the same fleet, feeds the recorded inbound messages
at their recorded times, and stops at the recorded end. Verification then walks the recorded and the
replayed outputs side by side: every outbound record of the trace, every leg (format 2; the telemetry of
every tick follows from them) or telemetry row (format 1) and, when the recording has one beside it,
every state transition and event; it stops at the first difference and names it. Recordings of either
format verify against a replay (which writes format 2).

A field added to a published message after a recording was made (``ran_status.carrying``, docs/contract.md §2) is
not in that recording: such a recording verifies with the field left out of the replay's records (and
compared as format 1 recordings are, record by record in one canonical form).

A closed-loop run (docs/contract.md §9) replays the same way: its inbound records are what the fleet manager wrote,
as they reached the RAN. The replay does not run the manager again, so the manager's own events
(``job_*``) are left out of the comparison; everything the simulation did is compared.

A live run killed outright (SIGKILL, power loss) leaves a recording without its end record, cut off
after its last flush (every tick), maybe in the middle of a line or a telemetry row. Such a recording is
*incomplete*: the replay runs to its last recorded instant, and verification checks that everything
recorded is a prefix of what the replay wrote (what the run did after its last flush is unknown).
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from dataclasses import dataclass
from itertools import zip_longest
from pathlib import Path
from typing import Any

import numpy as np
import orjson

from vcran.core.scenario import Scenario
from vcran.core.wire import Frame
from vcran.io.scenario_file import ScenarioError, parse
from vcran.io.trace import (
    LEGS_FILE,
    TELEMETRY_FILE,
    event_records,
    events_beside,
    leg_dtype,
    legs,
    lines,
    open_input,
    read_header,
    robots_of,
    samples,
    telemetry,
    trace_in,
    whole_lines,
)

#: Fields added to published messages since recordings were first made, by attribute: a recording whose
#: first record of the attribute lacks one was made before it existed (:func:`_added_since`).
ADDED_FIELDS: dict[str, str] = {"ran_status": "carrying"}


@dataclass(frozen=True, slots=True)
class Difference:
    """The first place where a replay disagrees with its recording."""

    file: str
    t: float | None
    robot: str | None
    attribute: str | None  # for the events file: the event's name
    path: str
    expected: Any
    got: Any

    def __str__(self) -> str:
        where = " ".join(
            part for part in (
                f"t={self.t!r}" if self.t is not None else "",
                f"robot={self.robot}" if self.robot else "",
                f"{'event' if self.file.startswith('events') else 'attribute'}={self.attribute}" if self.attribute else "",
            ) if part
        )
        field = f" field {self.path}" if self.path else ""
        return (f"{self.file}: first difference at {where}{field}: "
                f"expected {_short(self.expected)}, got {_short(self.got)}")


def scenario_from_trace(trace: Path) -> Scenario:
    """The fleet of a recorded run, set to stop exactly when the recording stopped (an incomplete
    recording: at its last recorded instant)."""
    trace = trace_in(trace)
    header = read_header(trace)
    end, _ = recorded_end(trace, header)
    fleet = header.get("fleet")
    if not isinstance(fleet, dict) or not isinstance(fleet.get("simulation", {}), dict):
        raise ValueError(f"{trace}: the header does not describe a fleet")
    # The recording's end decides; a live run of a scenario without a duration has none of its own.
    fleet = {**fleet, "simulation": {**fleet.get("simulation", {}), "duration": end, "until_idle": False}}
    try:
        return parse(fleet, f"{trace} (header)")
    except ScenarioError as exc:
        raise ValueError(f"{trace}: the header does not describe a fleet: {exc}") from None


def recorded_end(trace: Path, header: dict[str, Any] | None = None) -> tuple[float, bool]:
    """When the recording stopped, and whether it is complete (ends with its end record). An incomplete
    one ends at the latest time it holds: of its last whole record or (format 1) of its last whole
    telemetry row. A compressed trace is read through to its end."""
    tail = b""
    with open_input(trace) as f:
        try:
            if trace.suffix != ".zst":
                f.seek(0, 2)
                f.seek(max(0, f.tell() - 65536))
            while chunk := f.read(1 << 20):
                tail = (tail + chunk)[-65536:]
        except Exception as exc:  # zstandard.ZstdError: cut off mid-block; what was decoded stands
            if type(exc).__name__ != "ZstdError":
                raise
    last: Any = None
    for line in reversed(tail[: tail.rfind(b"\n") + 1].splitlines()):  # a cut-off last line is no record
        try:
            last = json.loads(line)
            break
        except ValueError:  # the first of the tail's lines is usually a fragment
            continue
    if isinstance(last, dict) and last.get("dir") == "end" and isinstance(last.get("t"), (int, float)):
        return float(last["t"]), True
    header = read_header(trace) if header is None else header
    times = [float(last["t"])] if isinstance(last, dict) and isinstance(last.get("t"), (int, float)) else []
    rows = _telemetry_v1(header, trace, cut_off=True)
    if rows is not None and len(rows):
        times.append(float(rows[-1, 0]))
    return max(times, default=0.0), False


def end_time(trace: Path) -> float:
    """When a complete recording stopped; a ValueError for one that did not finish."""
    end, complete = recorded_end(trace)
    if not complete:
        raise ValueError(f"{trace}: no end record; the recording did not finish (was it interrupted?)")
    return end


def _telemetry_v1(header: dict[str, Any], trace: Path, *, cut_off: bool) -> np.ndarray | None:
    info = header.get("telemetry")
    if not isinstance(info, dict) or not isinstance(info.get("robots"), list):
        return None
    path = trace.parent / str(info.get("file", TELEMETRY_FILE))
    return telemetry(path, len(info["robots"]), cut_off=cut_off) if path.exists() else None


def verify(recorded: Path, replayed: Path) -> Difference | None:
    """Compare a recorded trace (its path; leg log or telemetry, and events, beside it) with a replay's
    folder; None when the replay reproduced every record. Raises ValueError/OSError naming a missing file.

    A recording of the same format is compared line by line as written. A format 1 recording is compared
    with the replay's records brought to format 1's form (full values, plain ids, periodic re-sends of an
    unchanged value left out on both sides) and with its telemetry evaluated from the replay's leg log.
    """
    recorded = trace_in(recorded)
    header = read_header(recorded)
    got = trace_in(replayed)
    if header["version"] == 1:
        telemetry_file = recorded.parent / str(header.get("telemetry", {}).get("file", TELEMETRY_FILE))
        if not telemetry_file.exists():
            raise ValueError(f"{telemetry_file}: missing; it holds the recording's current_motion rows (docs/contract.md §6)")
    elif not (recorded.parent / LEGS_FILE).exists():
        raise ValueError(f"{recorded.parent / LEGS_FILE}: missing; it holds the recording's legs (docs/contract.md §6)")
    _, complete = recorded_end(recorded, header)
    same = header["version"] == read_header(got)["version"]
    return (
        _compare_records(recorded, got, same, complete)
        or (_compare_legs(header, recorded.parent, got.parent, complete) if same
            else _compare_samples(recorded, got, complete))
        or _compare_events(events_beside(recorded), events_beside(got), same, complete)
    )


def _added_since(trace: Path) -> dict[str, str]:
    """The :data:`ADDED_FIELDS` that ``trace`` was recorded without (its first record of the attribute
    does not have the field)."""
    missing = {}
    for attribute, name in ADDED_FIELDS.items():
        for _, _, r in lines(trace, ("out",), (attribute,)):
            if isinstance(r.get("value"), dict) and name not in r["value"]:
                missing[attribute] = name
            break
    return missing


def _outbound(trace: Path, as_written: bool, leave_out: dict[str, str] | None = None) -> Iterator[tuple[bytes, dict[str, Any]]]:
    last: dict[tuple[Any, Any], Any] = {}
    for _, line, r in lines(trace, ("out", "end")):
        if r.get("dir") == "end":
            yield line.rstrip(b"\n"), r
        elif r.get("dir") == "out":
            if as_written:
                yield line.rstrip(b"\n"), r
                continue
            field = leave_out.get(r.get("attr")) if leave_out else None  # type: ignore[arg-type]
            if field is not None and isinstance(r.get("value"), dict):
                r = {**r, "value": {k: v for k, v in r["value"].items() if k != field}}
            key = (r.get("robot"), r.get("attr"))
            if last.get(key) == r.get("value"):
                continue  # a re-send of an unchanged value, which format 2 does not write
            last[key] = r.get("value")
            yield orjson.dumps(r), r


def _compare_records(expected: Path, got: Path, as_written: bool, complete: bool = True) -> Difference | None:
    """Record by record: text, not Python values (where 1 == 1.0 == True). Of an incomplete recording,
    every record must be the replay's; the replay's end record and what follows are not compared. A
    recording made before a field was added (:data:`ADDED_FIELDS`) is compared without it."""
    leave_out = _added_since(expected)
    if leave_out:
        as_written = False
    pairs = zip_longest(_outbound(expected, as_written, leave_out), _outbound(got, as_written, leave_out),
                        fillvalue=(b"", None))
    for (line_a, a), (line_b, b) in pairs:
        if not complete and a is None:
            return None
        if line_a == line_b:
            continue
        ref = a or b
        assert ref is not None
        path, x, y = first_mismatch(a, b)
        return Difference(expected.name, ref.get("t"), ref.get("robot"), ref.get("attr"), path, x, y)
    return None


def _compare_legs(header: dict[str, Any], expected_dir: Path, got_dir: Path, complete: bool = True) -> Difference | None:
    """Every leg bit for bit: the telemetry at every tick is a function of them (vcran.io.trace)."""
    a, b = legs(expected_dir, cut_off=not complete), legs(got_dir)
    rows = min(len(a), len(b))
    robots = robots_of(header)
    ka = a[:rows].view(np.uint8).reshape(rows, leg_dtype().itemsize)
    kb = b[:rows].view(np.uint8).reshape(rows, leg_dtype().itemsize)
    differ = np.flatnonzero(np.any(ka != kb, axis=1))
    if differ.size:
        row = int(differ[0])
        for name in leg_dtype().names or ():
            x, y = a[row][name], b[row][name]
            if np.asarray(x).tobytes() != np.asarray(y).tobytes():
                robot = robots[int(a[row]["robot"])] if int(a[row]["robot"]) < len(robots) else None
                return Difference(LEGS_FILE, float(a[row]["t"]), robot, "current_motion", f"leg {row}.{name}",
                                  x.item(), y.item())
    if len(a) > len(b) or (complete and len(a) != len(b)):
        return Difference(LEGS_FILE, None, None, "current_motion", "rows", len(a), len(b))
    return None


def _compare_samples(expected: Path, got: Path, complete: bool = True) -> Difference | None:
    """A format 1 recording's telemetry rows against the replay's, evaluated from its legs, bit for bit."""
    header = read_header(expected)
    robots = robots_of(header)
    recorded = _telemetry_v1(header, expected, cut_off=not complete)
    a, b = (recorded if recorded is not None else samples(expected)), samples(got)
    rows = min(len(a), len(b))
    bad = np.flatnonzero(np.any(a[:rows].view(np.uint64) != b[:rows].view(np.uint64), axis=1))
    if bad.size:
        row = int(bad[0])
        col = int(np.flatnonzero(a[row].view(np.uint64) != b[row].view(np.uint64))[0])
        if col == 0:
            return Difference(TELEMETRY_FILE, float(a[row, 0]), None, "current_motion", "t", a[row, 0], b[row, 0])
        robot, field = divmod(col - 1, len(Frame.FIELDS))
        return Difference(TELEMETRY_FILE, float(a[row, 0]), robots[robot], "current_motion",
                          Frame.FIELDS[field], float(a[row, col]), float(b[row, col]))
    if len(a) > len(b) or (complete and len(a) != len(b)):
        return Difference(TELEMETRY_FILE, None, None, "current_motion", "rows", len(a), len(b))
    return None


def _event_lines(path: Path, as_written: bool) -> Iterator[tuple[bytes, dict[str, Any]]]:
    """The events the simulation wrote: all but a fleet manager's ``job_*`` events (docs/contract.md §9: the replay
    does not run the manager again), as written or (formats differ) in one canonical form."""
    if as_written:
        with open_input(path) as f:
            for line in whole_lines(f):
                event = json.loads(line)
                if not str(event.get("event", "")).startswith("job_"):
                    yield line, event
        return
    for event in event_records(path, cut_off=True):  # either format, in one canonical form
        if not str(event.get("event", "")).startswith("job_"):
            yield orjson.dumps(event, option=orjson.OPT_SORT_KEYS), event


def _compare_events(expected: Path, got: Path, as_written: bool, complete: bool = True) -> Difference | None:
    if not expected.exists():
        return None
    pairs = zip_longest(_event_lines(expected, as_written), _event_lines(got, as_written), fillvalue=(b"", None))
    for (line_a, a), (line_b, b) in pairs:
        if not complete and a is None:
            return None  # the recording's end (a cut-off last line is no event)
        if line_a == line_b:
            continue
        ref = a or b or {}
        path, x, y = first_mismatch(a, b)
        return Difference(expected.name, ref.get("t"), ref.get("robot"), ref.get("event"), path, x, y)
    return None


def first_mismatch(a: Any, b: Any, path: str = "") -> tuple[str, Any, Any]:
    """The dotted path of the first place two JSON values differ, and the values there."""
    if isinstance(a, dict) and isinstance(b, dict):
        for key in list(a) + [k for k in b if k not in a]:
            if a.get(key, _MISSING) != b.get(key, _MISSING):
                return first_mismatch(a.get(key, _MISSING), b.get(key, _MISSING), f"{path}.{key}" if path else key)
    if isinstance(a, list) and isinstance(b, list):
        for i, (x, y) in enumerate(zip_longest(a, b, fillvalue=_MISSING)):
            if x != y:
                return first_mismatch(x, y, f"{path}[{i}]")
    return path, a, b


class _Missing:
    def __repr__(self) -> str:
        return "<missing>"


_MISSING = _Missing()


def _short(value: Any, limit: int = 200) -> str:
    text = "<missing>" if value is _MISSING or value is None else json.dumps(value, default=repr)
    return text if len(text) <= limit else text[:limit] + "..."
