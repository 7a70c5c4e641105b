"""Replay a recorded trace and verify it (SPEC §6): ``vcran replay TRACE --out DIR [--verify]``.

The trace header carries the fleet (the scenario without its script) and the last line when the run
stopped, so the trace alone is enough: the replay runs the same fleet, feeds the recorded inbound messages
at their recorded times, and stops at the recorded end. Verification then walks the recorded and the
replayed outputs side by side: every outbound record in ``trace.jsonl``, every telemetry row in
``telemetry.bin`` and, when the recording has one beside it, every state transition and event in
``events.jsonl``; it stops at the first difference and names it.

A closed-loop run (SPEC §9) replays the same way: its inbound records are what the fleet manager wrote,
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

from vcran.core.scenario import Scenario
from vcran.core.wire import Frame
from vcran.io.scenario_file import ScenarioError, parse
from vcran.io.trace import TELEMETRY_FILE, lines, read_header, telemetry


@dataclass(frozen=True, slots=True)
class Difference:
    """The first place where a replay disagrees with its recording."""

    file: str
    t: float | None
    robot: str | None
    attribute: str | None
    path: str
    expected: Any
    got: Any

    def __str__(self) -> str:
        where = " ".join(
            part for part in (
                f"t={self.t!r}" if self.t is not None else "",
                f"robot={self.robot}" if self.robot else "",
                f"attribute={self.attribute}" if self.attribute else "",
            ) if part
        )
        field = f" field {self.path}" if self.path else ""
        return (f"{self.file}: first difference at {where}{field}: "
                f"expected {_short(self.expected)}, got {_short(self.got)}")


def scenario_from_trace(trace: Path) -> Scenario:
    """The fleet of a recorded run, set to stop exactly when the recording stopped (an incomplete
    recording: at its last recorded instant)."""
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
    one ends at the latest time it holds: of its last whole record or of its last whole telemetry row."""
    last: Any = None
    with trace.open("rb") as f:
        f.seek(0, 2)
        size = f.tell()
        f.seek(max(0, size - 65536))
        tail = f.read()
    whole = tail[: tail.rfind(b"\n") + 1].splitlines()  # a cut-off last line is no record
    for line in reversed(whole):
        try:
            last = json.loads(line)
            break
        except ValueError:  # the first of the tail's lines is usually a fragment
            continue
    if isinstance(last, dict) and last.get("dir") == "end" and isinstance(last.get("t"), (int, float)):
        return float(last["t"]), True
    header = read_header(trace) if header is None else header
    times = [float(last["t"])] if isinstance(last, dict) and isinstance(last.get("t"), (int, float)) else []
    rows = _telemetry(header, trace, cut_off=True)
    if rows is not None and len(rows):
        times.append(float(rows[-1, 0]))
    return max(times, default=0.0), False


def _telemetry(header: dict[str, Any], trace: Path, *, cut_off: bool) -> np.ndarray | None:
    info = header.get("telemetry")
    if not isinstance(info, dict) or not isinstance(info.get("robots"), list):
        return None
    path = trace.parent / str(info.get("file", TELEMETRY_FILE))
    return telemetry(path, len(info["robots"]), cut_off=cut_off) if path.exists() else None


def verify(recorded: Path, replayed: Path) -> Difference | None:
    """Compare a recorded trace (its path; telemetry and events beside it) with a replay's folder;
    None when the replay reproduced every record. Raises ValueError/OSError naming a missing file."""
    header = read_header(recorded)
    telemetry_file = recorded.parent / str(header.get("telemetry", {}).get("file", "telemetry.bin"))
    if not telemetry_file.exists():
        raise ValueError(f"{telemetry_file}: missing; it holds the recording's current_motion rows (SPEC §6)")
    _, complete = recorded_end(recorded, header)
    return (
        _compare_records(recorded, replayed / "trace.jsonl", complete)
        or _compare_telemetry(header, telemetry_file, replayed, complete)
        or _compare_events(recorded.parent / "events.jsonl", replayed / "events.jsonl", complete)
    )


def _outbound(trace: Path) -> Iterator[tuple[str, dict[str, Any]]]:
    return ((line, r) for line, r in lines(trace) if r.get("dir") in ("out", "end"))


def _compare_records(expected: Path, got: Path, complete: bool = True) -> Difference | None:
    """Record by record, as written: text, not Python values (where 1 == 1.0 == True). Of an incomplete
    recording, every record must be the replay's; the replay's end record and what follows are not."""
    for (line_a, a), (line_b, b) in zip_longest(_outbound(expected), _outbound(got), fillvalue=("", None)):
        if not complete and a is None:
            return None
        if line_a == line_b:
            continue
        ref = a or b
        assert ref is not None
        path, x, y = first_mismatch(a, b)
        return Difference("trace.jsonl", ref.get("t"), ref.get("robot"), ref.get("attr"), path, x, y)
    return None


def _compare_telemetry(header: dict[str, Any], expected: Path, got_dir: Path, complete: bool = True) -> Difference | None:
    robots = header["telemetry"]["robots"]
    a, b = telemetry(expected, len(robots), cut_off=not complete), telemetry(got_dir / TELEMETRY_FILE, len(robots))
    rows = min(len(a), len(b))
    bad = np.flatnonzero(np.any(a[:rows].view(np.uint64) != b[:rows].view(np.uint64), axis=1))
    if bad.size:
        row = int(bad[0])
        col = int(np.flatnonzero(a[row].view(np.uint64) != b[row].view(np.uint64))[0])
        if col == 0:
            return Difference("telemetry.bin", float(a[row, 0]), None, "current_motion", "t", a[row, 0], b[row, 0])
        robot, field = divmod(col - 1, len(Frame.FIELDS))
        return Difference("telemetry.bin", float(a[row, 0]), robots[robot], "current_motion",
                          Frame.FIELDS[field], float(a[row, col]), float(b[row, col]))
    if len(a) > len(b) or (complete and len(a) != len(b)):
        return Difference("telemetry.bin", None, None, "current_motion", "rows", len(a), len(b))
    return None


#: How a fleet manager's event starts, as written (orjson; keys t, robot, event in this order; a quote
#: inside a string value is escaped, so this cannot match within one).
_JOB_EVENT = '"event":"job_'


def _simulated(lines: Iterator[str]) -> Iterator[str]:
    """The lines of events.jsonl that the simulation wrote: all but the fleet manager's ``job_*`` events."""
    return (line for line in lines if _JOB_EVENT not in line)


def _compare_events(expected: Path, got: Path, complete: bool = True) -> Difference | None:
    if not expected.exists():
        return None
    with expected.open(encoding="utf-8") as fa, got.open(encoding="utf-8") as fb:
        for line_a, line_b in zip_longest(_simulated(fa), _simulated(fb)):
            if not complete and (line_a is None or not line_a.endswith("\n")):
                return None  # the recording's end (a cut-off last line is no event)
            if line_a == line_b:
                continue
            a = json.loads(line_a) if line_a else None
            b = json.loads(line_b) if line_b else None
            ref = a or b or {}
            path, x, y = first_mismatch(a, b)
            return Difference("events.jsonl", ref.get("t"), ref.get("robot"), ref.get("event"), path, x, y)
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
