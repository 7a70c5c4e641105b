"""Trace files (SPEC §6): JSON Lines of every inbound and outbound message, plus a columnar telemetry file.

``trace.jsonl`` starts with a header (format, version, scenario name, seed, options, the fleet as
:meth:`Scenario.fleet_dict` so that a replay needs nothing else, and the telemetry layout), then one record
per message: ``{"t", "dir": "in"|"out", "robot", "attr", "value"}`` with the plain decoded value, or
``"raw"`` for an inbound payload kept undecoded (it is decoded, and may be rejected, on replay exactly as
it was live).

``current_motion`` of the whole fleet is written every telemetry tick into ``telemetry.bin`` beside the
trace: little-endian float64 rows ``[t, x0, y0, theta0, v0, w0, x1, ...]``, one row per tick, robots in
header order. At 1 Hz for a thousand robots that is 40 kB a tick instead of a few MB of JSON, and replay
verification compares it bit for bit. ``assignment_status`` and ``ran_status`` are records in the JSONL,
written when they change (docs/outputs.md).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import IO, Any, Iterator

import numpy as np

from vcran.plain import to_plain
from vcran.wire import Frame, Inbound, Publish

FORMAT = "vcran-trace"
VERSION = 1
TELEMETRY_FILE = "telemetry.bin"


def dumps(value: Any) -> str:
    """The one JSON rendering of every output file: compact, key order as built, non-ASCII kept."""
    return json.dumps(value, separators=(",", ":"), ensure_ascii=False, allow_nan=False)


class TraceWriter:
    def __init__(self, directory: Path, header: dict[str, Any], robots: tuple[str, ...]) -> None:
        directory.mkdir(parents=True, exist_ok=True)
        self._jsonl: IO[str] = (directory / "trace.jsonl").open("w", encoding="utf-8", buffering=1 << 20)
        self._bin: IO[bytes] = (directory / TELEMETRY_FILE).open("wb", buffering=1 << 20)
        telemetry = {"file": TELEMETRY_FILE, "dtype": "<f8", "fields": ["t", *Frame.FIELDS], "robots": list(robots)}
        self._jsonl.write(dumps({"format": FORMAT, "version": VERSION, **header, "telemetry": telemetry}) + "\n")
        self._width = len(robots) * len(Frame.FIELDS)

    def inbound(self, t: float, inbound: Inbound) -> None:
        record: dict[str, Any] = {"t": t, "dir": "in", "robot": inbound.entity, "attr": inbound.attribute}
        if inbound.message is not None:
            record["value"] = to_plain(inbound.message)
        else:
            record["raw"] = inbound.raw
        self._jsonl.write(dumps(record) + "\n")

    def publish(self, out: Publish) -> None:
        record = {"t": out.t, "dir": "out", "robot": out.robot, "attr": out.attribute, "value": to_plain(out.message)}
        self._jsonl.write(dumps(record) + "\n")

    def frame(self, frame: Frame) -> None:
        row = np.empty(1 + self._width, dtype="<f8")
        row[0] = frame.t
        row[1:] = frame.columns().ravel()
        self._bin.write(row.tobytes())

    def close(self) -> None:
        self._jsonl.close()
        self._bin.close()


def read_header(path: Path) -> dict[str, Any]:
    with path.open(encoding="utf-8") as f:
        header = json.loads(f.readline())
    if header.get("format") != FORMAT:
        raise ValueError(f"{path}: not a vcran trace (format {header.get('format')!r})")
    if header.get("version") != VERSION:
        raise ValueError(f"{path}: trace version {header.get('version')!r}, this vcran reads {VERSION}")
    return header


def records(path: Path) -> Iterator[dict[str, Any]]:
    """The records after the header, one dict per line."""
    with path.open(encoding="utf-8") as f:
        f.readline()
        for n, line in enumerate(f, start=2):
            try:
                yield json.loads(line)
            except json.JSONDecodeError as exc:
                raise ValueError(f"{path}:{n}: not JSON: {exc}") from None


def telemetry(directory: Path, robots: int) -> np.ndarray:
    """The telemetry file as a (ticks, 1 + robots * 5) float64 array."""
    data = np.fromfile(directory / TELEMETRY_FILE, dtype="<f8")
    width = 1 + robots * len(Frame.FIELDS)
    if data.size % width:
        raise ValueError(f"{directory / TELEMETRY_FILE}: size is not a whole number of {width}-column rows")
    return data.reshape(-1, width)
