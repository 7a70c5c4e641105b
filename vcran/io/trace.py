"""Trace files (SPEC §6): JSON Lines of every inbound and outbound message, plus a columnar telemetry file.

``trace.jsonl`` starts with a header (format, version, scenario name, seed, options, the fleet as
:meth:`Scenario.fleet_dict` so that a replay needs nothing else, and the telemetry layout), then one record
per message: ``{"t", "dir": "in"|"out", "robot", "attr", "value"}`` with the plain decoded value, or
``"raw"`` for an inbound payload kept undecoded (it is decoded, and may be rejected, on replay exactly as
it was live). The last line, ``{"t", "dir": "end"}``, says when the run stopped.

``current_motion`` of the whole fleet is written every telemetry tick into ``telemetry.bin`` beside the
trace: little-endian float64 rows ``[t, x0, y0, theta0, v0, w0, x1, ...]``, one row per tick, robots in
header order. At 1 Hz for a thousand robots that is 40 kB a tick instead of a few MB of JSON, and replay
verification compares it bit for bit. ``assignment_status`` and ``ran_status`` are records in the JSONL,
written when they change (docs/outputs.md).
"""

from __future__ import annotations

import json
import struct
from collections.abc import Iterator
from pathlib import Path
from typing import IO, Any

import numpy as np
import orjson

from vcran.core.ids import canonical_uuid
from vcran.core.wire import Frame, Inbound, Publish

FORMAT = "vcran-trace"
VERSION = 1
TELEMETRY_FILE = "telemetry.bin"


_CANONICAL: dict[bytes, str] = {}


def _default(value: Any) -> Any:
    # The only bytes inside messages are Id.uuid: render them as the canonical uuid string, which
    # makes orjson's native dataclass walk produce exactly vcran.core.plain.to_plain (tests/test_trace.py).
    # A run renders the same few ids many times; the memo is bounded so memory stays flat.
    text = _CANONICAL.get(value)  # type: ignore[call-overload]
    if text is not None:
        return text
    if isinstance(value, bytes) and len(value) == 16:
        if len(_CANONICAL) >= 8_192:
            _CANONICAL.clear()
        text = _CANONICAL[value] = canonical_uuid(value)
        return text
    raise TypeError(f"cannot render {type(value).__name__} in an output file")


def dumps(value: Any) -> bytes:
    """The one JSON rendering of every output line: compact, key order as built, messages as plain.

    orjson instead of the standard library: trace writing is the hot path of a large run (millions of
    records), orjson is several times faster, walks dataclasses natively, and its output is as
    deterministic (shortest round-trip floats). Messages are validated finite, so no NaN reaches it.
    """
    return orjson.dumps(value, default=_default)


def raw_json(value: Any) -> bytes:
    """JSON text of an undecoded inbound value, exactly as ``json.loads`` will read it back on replay.

    orjson refuses what a peer may legitimately send and the RAN must reject (R12): nesting deeper than
    254 levels, integers beyond 64 bits; and it turns NaN into null, which would change the payload.
    The standard library writes all of these (NaN as the token Python reads back), and anything that
    came from ``json.loads`` or a scenario checked by the loader can be written.

    Text stays readable (UTF-8) unless it holds a lone UTF-16 surrogate (``"\\udc00"`` is valid JSON,
    but no UTF-8 file can hold it, R12): then the whole value is written with ``\\u`` escapes, which
    ``json.loads`` reads back to the same string.
    """
    text = json.dumps(value, separators=(",", ":"), ensure_ascii=False, allow_nan=True)
    try:
        return text.encode()
    except UnicodeEncodeError:
        return json.dumps(value, separators=(",", ":"), ensure_ascii=True, allow_nan=True).encode()


class TraceWriter:
    def __init__(self, directory: Path, header: dict[str, Any], robots: tuple[str, ...]) -> None:
        directory.mkdir(parents=True, exist_ok=True)
        self._jsonl: IO[bytes] = (directory / "trace.jsonl").open("wb", buffering=1 << 20)
        self._bin: IO[bytes] = (directory / TELEMETRY_FILE).open("wb", buffering=1 << 20)
        telemetry = {"file": TELEMETRY_FILE, "dtype": "<f8", "fields": ["t", *Frame.FIELDS], "robots": list(robots)}
        self._jsonl.write(dumps({"format": FORMAT, "version": VERSION, **header, "telemetry": telemetry}) + b"\n")
        self._width = len(robots) * len(Frame.FIELDS)

    def inbound(self, t: float, inbound: Inbound) -> None:
        record: dict[str, Any] = {"t": t, "dir": "in", "robot": inbound.entity, "attr": inbound.attribute}
        if inbound.message is not None:
            record["value"] = inbound.message
            self._jsonl.write(dumps(record) + b"\n")
        else:  # undecoded input is whatever a peer sent: written by the standard library (see raw_json)
            self._jsonl.write(dumps(record)[:-1] + b',"raw":' + raw_json(inbound.raw) + b"}\n")

    def publish(self, out: Publish) -> None:
        record = {"t": out.t, "dir": "out", "robot": out.robot, "attr": out.attribute, "value": out.message}
        self._jsonl.write(dumps(record) + b"\n")

    def frame(self, frame: Frame) -> None:
        self._bin.write(struct.pack("<d", frame.t))
        self._bin.write(frame.columns.astype("<f8", copy=False).tobytes())

    def end(self, t: float) -> None:
        """The last line: when the run stopped, so a replay stops at the same instant (SPEC §6)."""
        self._jsonl.write(dumps({"t": t, "dir": "end"}) + b"\n")

    def flush(self) -> None:
        """Hand what is buffered to the operating system (live mode, every tick): a killed run keeps its
        recording up to here. The telemetry file then ends with a whole row."""
        self._jsonl.flush()
        self._bin.flush()

    def close(self) -> None:
        self._jsonl.close()
        self._bin.close()


def read_header(path: Path) -> dict[str, Any]:
    try:
        with path.open(encoding="utf-8") as f:
            header = json.loads(f.readline())
    except UnicodeDecodeError:
        raise ValueError(f"{path}: not a vcran trace (not UTF-8 text)") from None
    except json.JSONDecodeError as exc:
        raise ValueError(f"{path}: not a vcran trace (line 1 is not JSON: {exc.msg})") from None
    if not isinstance(header, dict) or header.get("format") != FORMAT:
        raise ValueError(f"{path}: not a vcran trace (its first line is no vcran-trace header)")
    if header.get("version") != VERSION:
        raise ValueError(f"{path}: trace version {header.get('version')!r}, this vcran reads {VERSION}")
    return header


def records(path: Path) -> Iterator[dict[str, Any]]:
    """The records after the header, one dict per line."""
    return (record for _, record in lines(path))


def lines(path: Path) -> Iterator[tuple[str, dict[str, Any]]]:
    """The records after the header with their text as written (verification compares the text).

    Every record ends with a newline; a last line without one was cut off (a killed live run keeps what
    it flushed, docs/outputs.md) and is not a record."""
    with path.open(encoding="utf-8") as f:
        f.readline()
        for n, line in enumerate(f, start=2):
            if not line.endswith("\n"):
                return
            try:
                yield line, json.loads(line)
            except json.JSONDecodeError as exc:
                raise ValueError(f"{path}:{n}: not JSON: {exc}") from None


def telemetry(path: Path, robots: int, *, cut_off: bool = False) -> np.ndarray:
    """A telemetry file (or the one in a run folder) as a (ticks, 1 + robots * 5) float64 array.

    ``cut_off``: the recording was killed, so a last partial row is dropped instead of refused."""
    if path.is_dir():
        path = path / TELEMETRY_FILE
    data = np.fromfile(path, dtype="<f8")
    width = 1 + robots * len(Frame.FIELDS)
    if data.size % width:
        if not cut_off:
            raise ValueError(f"{path}: size is not a whole number of {width}-column rows")
        data = data[: data.size - data.size % width]
    return data.reshape(-1, width)
