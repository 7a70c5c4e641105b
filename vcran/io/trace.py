"""Run files (SPEC §6, §8): the trace, the events, the leg log; written compressed as they happen.

Format 2 (docs/outputs.md), what :class:`TraceWriter` and :class:`EventWriter` write:

* ``trace.jsonl.zst``: a header line (format, version, scenario, seed, options, the fleet as
  :meth:`Scenario.fleet_dict` so that a replay needs nothing else, and the leg log's layout), then one
  record per message ``{"t", "dir": "in"|"out", "robot", "attr", "value"}``, ids compact
  (:mod:`vcran.io.render`), and ``value`` holding only the fields that differ from the last value of the
  same direction, robot and attribute (the first one in full); a published message equal to that last
  value is not written at all (robot descriptions re-sent unchanged), an inbound one is, with an empty
  ``value`` (the RAN reacted to it: a repeated cancel is an error). An inbound payload that did not decode is
  kept as ``"raw"``. The last line, ``{"t", "dir": "end"}``, says when the run stopped.
* ``events.jsonl.zst``: one object per event, every line with the same keys in the same order
  (:data:`EVENT_KEYS`, ``null`` where an event has no such field).
* ``legs.npy``: every leg an AGV drove, one row each (:data:`LEG_COLUMNS`); ``current_motion`` at every
  telemetry tick is a function of the fleet's initial poses and these rows, which :func:`samples`
  evaluates with the very code that produced the published values, so it is reproduced bit for bit.

Both JSON Lines files are zstd streams written as the run goes (a long run never holds its output in
memory). Format 1 (``trace.jsonl``, ``telemetry.bin``, ``events.jsonl``, uncompressed, every value in
full) is still read: :func:`records`, :func:`event_records` and :func:`samples` present both formats in
format 1's form.
"""

from __future__ import annotations

import heapq
import io
import json
import math
import struct
from collections.abc import Iterator
from functools import cache
from pathlib import Path
from typing import IO, TYPE_CHECKING, Any

import orjson

from vcran.core.motion import Leg
from vcran.core.opil.messages import ATTRIBUTES, RENAMED
from vcran.core.wire import Frame, Inbound, Publish
from vcran.io.render import converter, delta_converter, expand

if TYPE_CHECKING:
    import numpy as np

FORMAT = "vcran-trace"
VERSION = 2
READS = (1, 2)
TRACE_FILE = "trace.jsonl.zst"
EVENTS_FILE = "events.jsonl.zst"
LEGS_FILE = "legs.npy"
SUMMARY_FILE = "summary.json"
#: Format 1's files, still read.
TRACE_FILE_V1 = "trace.jsonl"
EVENTS_FILE_V1 = "events.jsonl"
TELEMETRY_FILE = "telemetry.bin"

#: The keys of every ``events.jsonl.zst`` line, in order. An event field not listed here is written after
#: them (and a test fails until it is listed).
EVENT_KEYS = ("t", "robot", "event", "task", "motion", "action", "from", "to", "reason", "ok",
              "code", "severity", "message",
              # a fleet manager's job events (closed loop, SPEC §9: vcran.core.jobs)
              "job", "pickup", "dropoff", "priority", "deadline", "lead_time", "tasks",
              # a robot on its own (SPEC §4: vcran.core.incidents)
              "kind", "duration", "applied", "charge", "percentage", "other", "x", "y")

#: One row of ``legs.npy``. A leg: robot ``robot`` (index in the header's / summary's robot order) started,
#: at ``t``, the leg from ``(x0, y0, theta0)`` to ``(x, y)`` ending at heading ``theta`` (NaN: facing the
#: direction of travel) with its speed limits, timed from ``t0`` (``t`` itself, except for a leg resumed
#: after a hold: the held leg shifted by the hold's length). A halt (pause, breakdown, a stop on its own;
#: SPEC §4): every column but ``t`` and ``robot`` NaN; the robot rests where its leg had brought it at ``t``.
#: An abandon (R14: the leg began at the instant of a cancel or deadline, and does not happen): a halt
#: with ``x0``, ``y0``, ``theta0`` set, where the robot rests (where the leg began).
LEG_COLUMNS = (("t", "<f8"), ("robot", "<u4"), ("t0", "<f8"), ("x0", "<f8"), ("y0", "<f8"),
               ("theta0", "<f8"), ("x", "<f8"), ("y", "<f8"), ("theta", "<f8"),
               ("speed", "<f8"), ("accel", "<f8"), ("decel", "<f8"), ("turn_rate", "<f8"))


@cache
def leg_dtype() -> np.dtype:
    """:data:`LEG_COLUMNS` as a numpy structured dtype (also ``LEG_DTYPE``, made on first use: writing the
    leg log needs no numpy, so a run that nobody samples does not import it; issue 14)."""
    import numpy as np

    return np.dtype(list(LEG_COLUMNS))


def __getattr__(name: str) -> Any:
    if name == "LEG_DTYPE":  # the dtype under its historical name, without importing numpy for everyone
        return leg_dtype()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


_LEG = struct.Struct("<dI" + "d" * 11)
_HALT = (math.nan,) * 11
_NPY_HEADER = 512  # bytes reserved for the .npy header, rewritten with the row count at close

#: zstd level 3 (zstd's default: 300+ MB/s). Long-distance matching does not pay here: measured on a
#: 1000-robot hour's trace it saved 1.5% for twice the compression time and a 128 MiB window per file.
ZSTD_LEVEL = 3
ZSTD_WINDOW_LOG = 23  # 8 MiB: what a run's repeats need (27 with long-distance matching: 1.5% smaller, 2x the CPU, 128 MiB)


_dumps = orjson.dumps
#: orjson's option for a line: its newline appended.
_LINE = orjson.OPT_APPEND_NEWLINE


def json_line(value: Any) -> bytes:
    """The one JSON rendering of every output line: compact, key order as built, ending in a newline.

    orjson instead of the standard library: trace writing is the hot path of a large run (millions of
    records), and its output is as deterministic (shortest round-trip floats). Messages reach it as
    plain values through :mod:`vcran.io.render`; they are validated finite, so no NaN reaches it. The
    newline is orjson's (``OPT_APPEND_NEWLINE``), not a second bytes object per line. The run's writers
    (:class:`TraceWriter`, :class:`EventWriter`) call ``_dumps(value, option=_LINE)`` themselves: the
    same line without a Python call per record.
    """
    return _dumps(value, option=_LINE)


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


# --- compressed streams ---------------------------------------------------------------------------------


def open_output(path: Path) -> _Batched:
    """A file that compresses what is written to it when its name ends in ``.zst``; lines written to it are
    gathered in batches either way (:class:`_Batched`)."""
    raw = path.open("wb")
    if path.suffix != ".zst":
        return _Batched(raw)
    import zstandard

    params = zstandard.ZstdCompressionParameters.from_level(
        ZSTD_LEVEL, window_log=ZSTD_WINDOW_LOG, write_checksum=True)
    return _Batched(zstandard.ZstdCompressor(compression_params=params).stream_writer(raw, write_size=1 << 20))


#: Bytes gathered before they cross into the compressor.
BATCH = 1 << 18


class _Batched(io.RawIOBase):
    """Lines gathered into batches of 256 kB before they cross into the compressor: a call into
    zstandard per record cost more than compressing it.

    The batch is an ``io.BytesIO`` rewound after each hand-on: its buffer grows to a batch's size once
    and is then refilled in place, lines copied into it by C code. A buffer emptied after each batch
    was reallocated (and, among a large run's other allocations, copied) dozens of times a batch, 5% of
    a 1000-robot run (py-spy); a list of the lines joined per batch raised the run's peak memory by
    14 MiB (the allocator kept what thousands of line objects a batch had used), and lines joined 64 at a
    time by 3 MiB at 4 h; a ``bytearray`` filled by slice assignment cost 0.5 µs a line, an eighth of
    what writing a 10-robot run's outputs costs (issue 14). A line longer than a batch (a raw payload
    near Orion's 1 MB limit) makes one batch that long; the buffer it grew is released after it.

    The batch stays the same object for the file's life, so that the run's writers, which write a line per
    record, add to it themselves (``batch.write``, then :meth:`hand_on` once it holds :data:`BATCH`
    bytes) rather than through :meth:`write`, a Python call per line (issue 30). zstd's output does not
    depend on where its input was cut into calls, only on :meth:`flush`."""

    def __init__(self, inner: Any) -> None:
        super().__init__()
        self._inner, self.batch = inner, io.BytesIO()

    def writable(self) -> bool:
        return True

    def write(self, data: Any) -> int:
        batch = self.batch
        batch.write(data)
        if batch.tell() >= BATCH:
            self.hand_on()
        return len(data)

    def hand_on(self) -> None:
        """Pass what the batch holds on to the compressor (or the file), and start the batch again."""
        batch = self.batch
        size = batch.tell()
        if size:
            with batch.getbuffer() as view:
                self._inner.write(view[:size])
            batch.seek(0)
            if size > 2 * BATCH:  # grown by a long line: its buffer is not kept for the batches after it
                batch.truncate(0)

    def flush(self) -> None:
        """Compress what is gathered and end the zstd block: a reader of the file gets every line so far."""
        if not self.closed and self._inner is not None:
            self.hand_on()
            self._inner.flush()

    def close(self) -> None:
        if not self.closed:
            self.hand_on()
            self._inner.close()
            self._inner = None
        super().close()


ZSTD_MAGIC = b"\x28\xb5\x2f\xfd"


def zst_cut_off(path: Path) -> bool:
    """Whether the zstd file ``path`` ends before its last frame does (a ValueError if it is no zstd
    stream at all). A truncated stream reads as a shorter one, without an error: cut at a block boundary
    it even ends with a whole line. Walks the block headers (a seek per 128 kB block), decompressing nothing."""
    import zstandard

    size = path.stat().st_size
    pos = 0
    with path.open("rb") as f:
        while pos < size:
            f.seek(pos)
            head = f.read(18)  # a frame header is at most 18 bytes
            if len(head) >= 4 and head[0] & 0xF0 == 0x50 and head[1:4] == b"\x2a\x4d\x18":  # a skippable frame
                pos += 8 + int.from_bytes(head[4:8], "little")  # (pzstd writes them): its length, then its bytes
                if len(head) < 8:
                    return True
                continue
            if head[:4] != ZSTD_MAGIC[: len(head)]:
                raise ValueError(f"{path}: not a zstd stream")
            try:
                pos += zstandard.frame_header_size(head)
                checksum = zstandard.get_frame_parameters(head).has_checksum
            except zstandard.ZstdError:  # the magic number, and the file ends inside the header
                return True
            last = False
            while not last:
                f.seek(pos)
                block = f.read(3)
                if len(block) < 3:
                    return True
                bits = int.from_bytes(block, "little")
                last, kind = bool(bits & 1), (bits >> 1) & 3
                pos += 3 + (1 if kind == 1 else bits >> 3)  # an RLE block holds one byte
            pos += 4 if checksum else 0
    return pos > size or size == 0


def check_whole(path: Path) -> None:
    """A ValueError when the zstd file ``path`` of a finished run is cut off (:func:`zst_cut_off`): read
    as it is, it would pass for a shorter run. A plain (format 1) file is taken as it is."""
    if path.suffix == ".zst" and zst_cut_off(path):
        raise ValueError(f"{path}: cut off: the zstd stream ends before its end (the file was truncated or its "
                         "run killed)")


def open_input(path: Path) -> IO[bytes]:
    """Read ``path``, decompressing a ``.zst`` file as it is read."""
    if path.suffix != ".zst":
        return path.open("rb")
    import zstandard

    reader = zstandard.ZstdDecompressor(max_window_size=1 << 27).stream_reader(path.open("rb"), closefd=True)
    return io.BufferedReader(reader, buffer_size=1 << 20)  # type: ignore[arg-type]


# --- writing --------------------------------------------------------------------------------------------


class TraceWriter:
    """``trace.jsonl.zst`` and ``legs.npy`` of one run (module docstring)."""

    def __init__(self, directory: Path, header: dict[str, Any], robots: tuple[str, ...]) -> None:
        directory.mkdir(parents=True, exist_ok=True)
        self._jsonl = open_output(directory / TRACE_FILE)
        #: The batch records are added to (:class:`_Batched`): written to here, handed on by ``_jsonl``.
        self._lines = self._jsonl.batch
        self._legs = LegLog(directory / LEGS_FILE)
        legs = {"file": LEGS_FILE, "columns": [name for name, _ in LEG_COLUMNS], "robots": list(robots)}
        self._jsonl.write(json_line({"format": FORMAT, "version": VERSION, **header, "legs": legs}))
        self._index = {robot: i for i, robot in enumerate(robots)}
        #: (dir, robot, attr) -> [last message, its full JSON value, the delta converter of its class]: what
        #: the next record is a difference to, and how
        self._last: dict[tuple[str, str, str], list[Any]] = {}

    # A record is written once per message of a run (millions): :meth:`inbound` and :meth:`publish` spell out
    # the difference to the last value and the line's hand-on, where helper calls cost a tenth of the
    # record in a plain Python run (issue 30).

    def inbound(self, t: float, inbound: Inbound) -> None:
        message = inbound.message
        if message is None:  # undecoded input is whatever a peer sent: written by the standard library (see raw_json)
            head = {"t": t, "dir": "in", "robot": inbound.entity, "attr": inbound.attribute}
            self._jsonl.write(json_line(head)[:-2] + b',"raw":' + raw_json(inbound.raw) + b"}\n")
            return
        key = ("in", inbound.entity, inbound.attribute)
        last = self._last.get(key)
        if last is not None and type(last[0]) is type(message):
            value = last[2](message, last[0], last[1])
            last[0] = message
        else:
            value = self._first(key, message)
        # an inbound message is always written, even one equal to the last (value {}): the RAN reacted to it
        lines = self._lines
        lines.write(_dumps({"t": t, "dir": "in", "robot": inbound.entity, "attr": inbound.attribute, "value": value},
                           option=_LINE))
        if lines.tell() >= BATCH:
            self._jsonl.hand_on()

    def publish(self, out: Publish) -> None:
        message = out.message
        key = ("out", out.robot, out.attribute)
        last = self._last.get(key)
        if last is not None and type(last[0]) is type(message):
            if last[0] is message:
                return  # the very message of the last record (a robot description sent again): no field differs
            value = last[2](message, last[0], last[1])
            last[0] = message
            if not value:
                return  # nothing a reader cannot take from the last record
        else:
            value = self._first(key, message)
        lines = self._lines
        lines.write(_dumps({"t": out.t, "dir": "out", "robot": out.robot, "attr": out.attribute, "value": value},
                           option=_LINE))
        if lines.tell() >= BATCH:
            self._jsonl.hand_on()

    def _first(self, key: tuple[str, str, str], message: Any) -> dict[str, Any]:
        """The ``value`` of the first record of ``key`` with a message of this class, in full; the records
        after it hold the fields that differ from the last one."""
        value: dict[str, Any] = converter(type(message), "compact")(message)
        self._last[key] = [message, dict(value), delta_converter(type(message))]
        return value

    #: Telemetry ticks are not written: the leg log determines them (module docstring).
    wants_frames = False

    def frame(self, frame: Frame) -> None:
        """Telemetry ticks are not written: the leg log determines them (module docstring)."""

    def leg(self, robot: int, leg: Leg, t: float) -> None:
        """Robot ``robot`` (fleet index) starts ``leg`` at ``t``: one row of the leg log."""
        lim = leg.limits
        goal = math.nan if leg.theta_goal is None else leg.theta_goal
        self._legs.write(t, robot, (leg.t0, leg.x0, leg.y0, leg.theta0, leg.x1, leg.y1, goal,
                                    lim.speed, lim.accel, lim.decel, lim.turn_rate))

    def halt(self, robot: int, t: float) -> None:
        """Robot ``robot`` halts mid-leg at ``t``: a row of NaN leg columns."""
        self._legs.write(t, robot, _HALT)

    def abandon(self, robot: int, t: float, pose: tuple[float, float, float]) -> None:
        """Robot ``robot``'s leg is abandoned at ``t`` (R14): a halt row giving the pose it rests at."""
        self._legs.write(t, robot, (math.nan, *pose, *_HALT[4:]))

    def end(self, t: float) -> None:
        """The last line: when the run stopped, so a replay stops at the same instant (SPEC §6)."""
        self._jsonl.write(json_line({"t": t, "dir": "end"}))

    def flush(self) -> None:
        """Hand what is buffered to the operating system (live mode, every tick): a killed run keeps its
        recording up to here. The telemetry file then ends with a whole row."""
        self._jsonl.flush()
        self._legs.flush()

    def close(self) -> None:
        self._jsonl.close()
        self._legs.close()


class LegLog:
    """``legs.npy`` written row by row; the header's row count is filled in when it is closed."""

    def __init__(self, path: Path) -> None:
        self._f = path.open("wb", buffering=1 << 20)
        self._rows = 0
        self._f.write(_npy_header(0))

    def write(self, t: float, robot: int, columns: tuple[float, ...]) -> None:
        self._f.write(_LEG.pack(t, robot, *columns))
        self._rows += 1

    def flush(self) -> None:
        self._f.flush()

    def close(self) -> None:
        if self._f.closed:
            return
        self._f.seek(0)
        self._f.write(_npy_header(self._rows))
        self._f.close()


def _npy_header(rows: int) -> bytes:
    descr = list(LEG_COLUMNS)  # what numpy.lib.format.dtype_to_descr gives for the structured dtype
    text = f"{{'descr': {descr!r}, 'fortran_order': False, 'shape': ({rows},), }}"
    head = b"\x93NUMPY\x01\x00" + struct.pack("<H", _NPY_HEADER - 10)
    return head + text.encode("latin1").ljust(_NPY_HEADER - 11) + b"\n"


_BLANK_EVENT: dict[str, Any] = dict.fromkeys(EVENT_KEYS)

#: How the event lines of one name and one set of field keys are written (:func:`_event_plan`): the text
#: after the robot's id up to the first field's value, then each field's key with the text after its value;
#: None: as a dict.
_EventPlan = tuple[bytes, tuple[tuple[str, bytes], ...]] | None


def _event_plan(name: str, keys: tuple[str, ...]) -> _EventPlan:
    """The fixed text of the event lines named ``name`` with fields ``keys``: every key of :data:`EVENT_KEYS`
    in order, ``null`` where the event has no such field, then the fields not listed there in their order,
    as ``json_line`` writes the dict that :class:`EventWriter` describes. None when a field would take the
    place of ``t`` or ``robot``: such a line is written as that dict."""
    if "t" in keys or "robot" in keys:
        return None
    text, rest, field, head = b"", [], None, b""
    for key in EVENT_KEYS[2:] + tuple(k for k in keys if k not in EVENT_KEYS):
        text += b"," + _dumps(key) + b":"
        if key in keys:
            if field is None:
                head = text
            else:
                rest.append((field, text))
            field, text = key, b""
        else:
            text += _dumps(name) if key == "event" else b"null"
    text += b"}\n"
    if field is None:
        return text, ()
    rest.append((field, text))
    return head, tuple(rest)


class EventWriter:
    """``events.jsonl.zst``: one object per line, the same keys in the same order (:data:`EVENT_KEYS`).

    A line is ``{"t", "robot", "event"}`` and the event's fields over :data:`EVENT_KEYS` (``null`` for the
    keys it has not), as ``json_line`` writes that dict. An event sets two to five of the 28 keys, so
    most of a line is the same text line after line: made once per event name and set of field keys
    (:func:`_event_plan`), a line is those pieces with the event's values between them, each rendered by
    orjson as it renders them in the dict. Copying, filling and rendering a dict of 28 keys per line cost
    more than half of writing an event (issue 30).
    """

    def __init__(self, path: Path) -> None:
        self._f = open_output(path)
        self._lines = self._f.batch  # written to directly, as TraceWriter's records are
        self._plans: dict[tuple[str, ...], _EventPlan] = {}
        self.count = 0

    def write(self, t: float, robot: str, name: str, fields: dict[str, Any]) -> None:
        key = (name, *fields)
        try:
            plan = self._plans[key]
        except KeyError:
            plan = self._plans[key] = _event_plan(name, key[1:])
        if plan is None:
            line = _BLANK_EVENT.copy()
            line["t"], line["robot"], line["event"] = t, robot, name
            line.update(fields)
            text = _dumps(line, option=_LINE)
        else:
            head, rest = plan
            parts = [b'{"t":', _dumps(t), b',"robot":', _dumps(robot), head]
            for field, after in rest:
                parts += _dumps(fields[field]), after
            text = b"".join(parts)
        lines = self._lines
        lines.write(text)
        if lines.tell() >= BATCH:
            self._f.hand_on()
        self.count += 1

    def flush(self) -> None:
        self._f.flush()

    def close(self) -> None:
        self._f.close()


# --- reading --------------------------------------------------------------------------------------------


def trace_in(path: Path) -> Path:
    """The trace of a run folder (either format), or ``path`` itself when it is a file. A format 1 name
    that does not exist beside a format 2 trace (``DIR/trace.jsonl``, as commands written before format 2
    say) means that trace."""
    if not path.is_dir():
        if path.name == TRACE_FILE_V1 and not path.exists() and (path.parent / TRACE_FILE).is_file():
            return path.parent / TRACE_FILE
        return path
    for name in (TRACE_FILE, TRACE_FILE_V1):
        if (path / name).exists():
            return path / name
    raise ValueError(f"{path}: a folder without {TRACE_FILE} (or format 1's {TRACE_FILE_V1}); give a recorded "
                     "run's folder or its trace")


def events_beside(trace: Path) -> Path:
    """The events file that belongs to ``trace`` (it may not exist: a bare trace replays too)."""
    return trace.parent / (EVENTS_FILE if trace.suffix == ".zst" else EVENTS_FILE_V1)


def read_header(path: Path) -> dict[str, Any]:
    try:
        with open_input(path) as f:
            first = f.readline()
        if not first.endswith(b"\n"):
            raise ValueError(f"{path}: no complete first line; the recording did not finish (was it interrupted?)")
        header = json.loads(first.decode("utf-8"))
    except UnicodeDecodeError:
        raise ValueError(f"{path}: not a vcran trace (not UTF-8 text)") from None
    except json.JSONDecodeError as exc:
        raise ValueError(f"{path}: not a vcran trace (line 1 is not JSON: {exc.msg})") from None
    except Exception as exc:  # zstandard.ZstdError: not a zstd stream
        if type(exc).__name__ != "ZstdError":
            raise
        raise ValueError(f"{path}: not a vcran trace (not a zstd stream: {exc})") from None
    if not isinstance(header, dict) or header.get("format") != FORMAT:
        raise ValueError(f"{path}: not a vcran trace (its first line is no vcran-trace header)")
    if header.get("version") not in READS:
        raise ValueError(f"{path}: trace version {header.get('version')!r}, this vcran reads {', '.join(map(str, READS))}")
    return header


def robots_of(header: dict[str, Any]) -> list[str]:
    """The fleet's robot ids in column order, from a header of either format."""
    layout = header.get("legs") or header.get("telemetry") or {}
    return [str(r) for r in layout.get("robots", [])]


def lines(path: Path, dirs: tuple[str, ...] | None = None, attrs: tuple[str, ...] | None = None, *,
          expanded: bool = True) -> Iterator[tuple[int, bytes, dict[str, Any]]]:
    """The records after the header (those of direction ``dirs`` and attribute ``attrs`` when given): line
    number, the line as written and its record in format 1's form (full values, plain ids), so that every
    reader works on both formats. A difference refers only to records of its own attribute, so lines of
    other attributes are skipped unparsed (a large run's trace is mostly status). ``expanded=False`` leaves
    a format 2 value complete but compact, ids as written (:mod:`vcran.io.render`): for a reader of a few
    fields of many records (``vcran view``: expanding every id was most of its time on a large run).

    Every record ends with a newline; a last line without one, or the end of a zstd stream cut off
    mid-block, is where a killed run's recording stops (it keeps what it flushed, docs/outputs.md)."""
    version = read_header(path)["version"]
    last: dict[tuple[str, str, str], dict[str, Any]] = {}
    # a prefilter on the quoted name, whatever the spacing (a hand-edited line may have JSON's default one);
    # a recording made before an attribute took OPIL's own name holds the old one (RENAMED)
    old_names = {new: old for old, new in RENAMED.items()}
    needles = tuple(b'"%s"' % n.encode() for a in attrs for n in (a, old_names.get(a)) if n) if attrs is not None else ()
    with open_input(path) as f:
        f.readline()
        for n, line in enumerate(whole_lines(f), start=2):
            if needles and not any(needle in line for needle in needles):
                continue
            try:
                # A raw payload is whatever a peer sent, written by the standard library (raw_json); only it
                # reads such a line back as it was: orjson turns an integer beyond 64 bits into a float and
                # refuses NaN. Every other line is vcran's own, which orjson reads faster.
                record = json.loads(line) if b'"raw"' in line else orjson.loads(line)
            except (orjson.JSONDecodeError, json.JSONDecodeError, UnicodeDecodeError) as exc:
                raise ValueError(f"{path}:{n}: not JSON: {exc}") from None
            if not isinstance(record, dict):
                raise ValueError(f"{path}:{n}: not a trace record (a JSON object expected)")
            renamed = RENAMED.get(record.get("attr"))  # type: ignore[arg-type]
            if renamed is not None:  # read as it is written today, so that the recording still verifies
                line = line.replace(b'"attr":"%s"' % record["attr"].encode(), b'"attr":"%s"' % renamed.encode(), 1)
                record["attr"] = renamed
            if (dirs is not None and record.get("dir") not in dirs) or (attrs is not None and record.get("attr") not in attrs):
                continue
            if version == 2 and isinstance(record.get("value"), dict):
                record["value"] = _full(record, last, expanded)
            yield n, line, record


def whole_lines(f: IO[bytes]) -> Iterator[bytes]:
    """The complete lines of ``f``: up to a cut-off last line or a truncated zstd stream."""
    try:
        for line in f:
            if not line.endswith(b"\n"):
                return
            yield line
    except Exception as exc:  # zstandard.ZstdError: the stream ends mid-block
        if type(exc).__name__ != "ZstdError":
            raise


def _full(record: dict[str, Any], last: dict[tuple[str, str, str], dict[str, Any]], expanded: bool = True) -> Any:
    key = (str(record.get("dir")), str(record.get("robot")), str(record.get("attr")))
    value = record["value"]
    before = last.get(key)
    if before is not None:
        value = {**before, **value}
    last[key] = value
    cls = ATTRIBUTES.get(str(record.get("attr")))
    return expand(cls, value) if cls is not None and expanded else value


def records(path: Path, dirs: tuple[str, ...] | None = None, attrs: tuple[str, ...] | None = None, *,
            expanded: bool = True) -> Iterator[tuple[int, dict[str, Any]]]:
    """The records after the header (of direction ``dirs`` and attribute ``attrs`` when given) with their
    line numbers, in format 1's form (:func:`lines`; ``expanded=False``: values compact)."""
    return ((n, record) for n, _, record in lines(path, dirs, attrs, expanded=expanded))


def event_records(path: Path, *, cut_off: bool = False) -> Iterator[Any]:
    """The events of ``events.jsonl.zst`` (or format 1's ``events.jsonl``), fields without a value left out
    (a line that is JSON but no object is passed through, for the caller to name). ``cut_off``: the
    recording was killed; it ends at its last whole line."""
    if not cut_off:
        check_whole(path)
    with open_input(path) as f:
        for n, line in enumerate(whole_lines(f) if cut_off else f, start=1):
            try:  # orjson reads vcran's own lines 3x faster; the standard library what else JSON allows (NaN)
                event = orjson.loads(line)
            except orjson.JSONDecodeError:
                try:
                    event = json.loads(line)
                except (json.JSONDecodeError, UnicodeDecodeError) as exc:
                    raise ValueError(f"{path}:{n}: not JSON: {exc}") from None
            yield {k: v for k, v in event.items() if v is not None} if isinstance(event, dict) else event


def legs(path: Path, *, cut_off: bool = False) -> np.ndarray:
    """``legs.npy`` (or the one in a run folder) as a structured array of :data:`LEG_DTYPE` rows.
    ``cut_off``: the run was killed before the row count was written; every whole row is read."""
    import numpy as np

    dtype = leg_dtype()
    if path.is_dir():
        path = path / LEGS_FILE
    if cut_off:
        data = np.fromfile(path, dtype=np.uint8, offset=_NPY_HEADER)
        return data[: data.size - data.size % dtype.itemsize].view(dtype)
    try:
        data = np.load(path, allow_pickle=False)
    except (ValueError, EOFError) as exc:
        raise ValueError(f"{path}: not a vcran leg log ({exc})") from None
    if data.dtype != dtype:
        raise ValueError(f"{path}: not a vcran leg log (columns {data.dtype.names})")
    return data


def samples(trace: Path) -> np.ndarray:
    """``current_motion`` of the whole fleet at every telemetry tick: a (ticks, 1 + robots * 5) float64
    array ``[t, x0, y0, theta0, v0, w0, x1, ...]``, robots in header order; from ``telemetry.bin``
    (format 1) or evaluated from the leg log (format 2), bit for bit what was published."""
    trace = trace_in(trace)
    header = read_header(trace)
    robots = robots_of(header)
    from vcran.io.verify import recorded_end

    end, complete = recorded_end(trace, header)
    if header["version"] == 1:
        path = trace.parent / str(header.get("telemetry", {}).get("file", TELEMETRY_FILE))
        return telemetry(path, len(robots), cut_off=not complete)
    return _evaluate(header, legs(trace.parent / str(header["legs"]["file"]), cut_off=not complete), end)


def _evaluate(header: dict[str, Any], rows: np.ndarray, end: float) -> np.ndarray:
    """Drive a :class:`FleetKinematics` through the logged legs and sample it at every tick, exactly as
    the telemetry process did (:meth:`vcran.sim.opil.ran.Ran.telemetry`: tick k at ``k * period``, up to and
    including the end)."""
    import numpy as np

    from vcran.core.motion import FleetKinematics, Limits

    fleet_spec = header["fleet"]
    poses = [tuple(float(c) for c in r["pose"]) for r in fleet_spec["robots"]]
    period = float(fleet_spec["simulation"].get("telemetry_period", 1.0))
    fleet = FleetKinematics(poses)  # type: ignore[arg-type]
    ending: list[tuple[float, int, int, Leg]] = []  # (t_end, row, robot, leg): legs to finish
    out = []
    j, k, n = 0, 0, len(rows)
    while (t := k * period) <= end:
        # leg ends and logged rows up to this tick, in the order they happened: a halt before a leg's end
        # stops it there, a leg's end before a halt leaves nothing to halt (ties: the end first, which
        # stops the robot at the same place, and lets a leg start where the last one ended)
        while (ending and ending[0][0] <= t) or (j < n and rows[j]["t"] <= t):
            if ending and ending[0][0] <= t and (j >= n or ending[0][0] <= rows[j]["t"]):
                _, _, i, done = heapq.heappop(ending)
                if fleet.current.get(i) is done:
                    fleet.finish(i)
                continue
            r = rows[j]
            i = int(r["robot"])
            if math.isnan(r["t0"]) and not math.isnan(r["x0"]):  # an abandon: it rests where the leg began
                fleet.place(i, float(r["t"]), (float(r["x0"]), float(r["y0"]), float(r["theta0"])))
            elif math.isnan(r["t0"]):  # a halt: the robot rests where its leg had brought it
                if i in fleet.current:
                    fleet.stop(i, float(r["t"]))
            else:
                if i in fleet.current:
                    fleet.finish(i)
                goal = float(r["theta"])
                leg = Leg(float(r["t0"]), float(r["x0"]), float(r["y0"]), float(r["theta0"]), float(r["x"]),
                          float(r["y"]), None if math.isnan(goal) else goal,
                          Limits(float(r["speed"]), float(r["accel"]), float(r["decel"]), float(r["turn_rate"])))
                fleet.start(i, leg)
                heapq.heappush(ending, (leg.t_end, j, i, leg))
            j += 1
        row = np.empty(1 + 5 * len(poses))
        row[0] = t
        row[1:] = fleet.sample(t).reshape(-1)
        out.append(row)
        k += 1
    return np.vstack(out) if out else np.empty((0, 1 + 5 * len(poses)))


def telemetry(path: Path, robots: int, *, cut_off: bool = False) -> np.ndarray:
    """A format 1 ``telemetry.bin`` (or the one in a run folder) as a (ticks, 1 + robots * 5) float64 array.

    ``cut_off``: the recording was killed, so a last partial row is dropped instead of refused."""
    import numpy as np

    if path.is_dir():
        path = path / TELEMETRY_FILE
    data = np.fromfile(path, dtype="<f8")
    width = 1 + robots * len(Frame.FIELDS)
    if data.size % width:
        if not cut_off:
            raise ValueError(f"{path}: size is not a whole number of {width}-column rows")
        data = data[: data.size - data.size % width]
    return data.reshape(-1, width)



def telemetry_table(run: Path | str) -> np.ndarray:
    """Every robot's ``current_motion`` at every telemetry tick of a run folder (either format), one row
    per robot and tick, ticks in order and robots in fleet order, as a structured array with named
    columns ``t``, ``robot``, ``x``, ``y``, ``theta``, ``v``, ``w``: ``pandas.DataFrame(telemetry_table(run))``
    or ``polars.from_numpy(telemetry_table(run))``. The values are bit for bit those published."""
    trace = trace_in(Path(run))
    return long_table(samples(trace), tuple(robots_of(read_header(trace))))


def long_table(rows: np.ndarray, robots: tuple[str, ...]) -> np.ndarray:
    """Telemetry rows ``[t, x0, y0, theta0, v0, w0, x1, ...]`` as one record per tick and robot."""
    import numpy as np

    n, ticks = len(robots), rows.shape[0]
    width = max((len(r) for r in robots), default=1)
    table = np.empty(ticks * n, dtype=[("t", "<f8"), ("robot", f"<U{width}"),
                                       *((name, "<f8") for name in Frame.FIELDS)])
    table["t"] = np.repeat(rows[:, 0], n)
    table["robot"] = np.tile(np.array(robots), ticks)
    columns = rows[:, 1:].reshape(ticks, n, len(Frame.FIELDS))
    for k, name in enumerate(Frame.FIELDS):
        table[name] = columns[:, :, k].ravel()
    return table


def trace_records(run: Path | str) -> list[dict[str, Any]]:
    """The records of a run's trace (either format) in full: every value complete, ids as
    ``{"uuid", "description"}`` (the header and the end line left out). ``pandas.DataFrame(...)`` of it
    has one row per message."""
    return [r for _, r in records(trace_in(Path(run)), ("in", "out"))]
