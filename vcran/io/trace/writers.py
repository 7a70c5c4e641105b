"""The run's writers (format 2, :mod:`vcran.io.trace`): :class:`TraceWriter` (``trace.jsonl.zst`` and
``legs.npy``) and :class:`EventWriter` (``events.jsonl.zst``), and the one JSON rendering of a line.

They write a line per message and per event of a run (millions), so their hot paths are spelled out in
place: a helper call there cost a tenth of a record in a plain Python run (issue 30).
"""

from __future__ import annotations

import json
import math
import struct
from pathlib import Path
from typing import Any

import orjson

from vcran.core.motion import Leg
from vcran.core.opil.messages import Message
from vcran.core.wire import Frame, Inbound, Publish
from vcran.io.render import converter, delta_converter
from vcran.io.trace.files import EVENT_KEYS, FORMAT, LEG_COLUMNS, LEGS_FILE, NPY_HEADER, TRACE_FILE, VERSION
from vcran.io.trace.streams import BATCH, open_output

_LEG = struct.Struct("<dI" + "d" * 11)
#: A halt's row of the leg log after ``t`` and ``robot`` (:data:`~vcran.io.trace.files.LEG_COLUMNS`).
HALT = (math.nan,) * 11


def leg_columns(leg: Leg) -> tuple[float, ...]:
    """A leg's row of the leg log after ``t`` and ``robot`` (:data:`~vcran.io.trace.files.LEG_COLUMNS`)."""
    lim = leg.limits
    goal = math.nan if leg.theta_goal is None else leg.theta_goal
    return (leg.t0, leg.x0, leg.y0, leg.theta0, leg.x1, leg.y1, goal, lim.speed, lim.accel, lim.decel, lim.turn_rate)


def abandon_columns(pose: tuple[float, float, float]) -> tuple[float, ...]:
    """An abandon's row after ``t`` and ``robot``: a halt giving the pose the robot rests at (R14)."""
    return (math.nan, *pose, *HALT[4:])


_dumps = orjson.dumps
#: orjson's option for a line: its newline appended.
_LINE = orjson.OPT_APPEND_NEWLINE
#: VDA 5050's encoder, its Version and the versions by name, once the first VDA 5050 message is written: the
#: imports and the enum lookup took 1.7 µs a message (timeit), 30,000 states a 100-vehicle hour (issue 31).
_VDA5050: tuple[Any, Any, dict[str, Any]] | None = None


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


class TraceWriter:
    """``trace.jsonl.zst`` and ``legs.npy`` of one run (:mod:`vcran.io.trace`)."""

    def __init__(self, directory: Path, header: dict[str, Any], robots: tuple[str, ...]) -> None:
        directory.mkdir(parents=True, exist_ok=True)
        self._jsonl = open_output(directory / TRACE_FILE)
        #: The batch records are added to (:class:`~vcran.io.trace.streams._Batched`): written to here,
        #: handed on by ``_jsonl``.
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
        message, wire = inbound.message, inbound.wire
        if message is None or wire is not None:  # written as it came: undecoded input is whatever a peer sent (by
            # the standard library, see raw_json); a VDA 5050 script's message the text its master sends
            raw = raw_json(inbound.raw) if wire is None else wire
            head = {"t": t, "dir": "in", "robot": inbound.entity, "attr": inbound.attribute}
            self._jsonl.write(json_line(head)[:-2] + b',"raw":' + raw + b"}\n")
            return
        key = ("in", inbound.entity, inbound.attribute)
        last = self._last.get(key)
        if last is not None and type(last[0]) is type(message):
            value = last[2](message, last[0], last[1])
            last[0] = message
        elif not isinstance(message, Message):
            self._wire(t, "in", inbound.entity, inbound.attribute, message)
            return
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
        elif not isinstance(message, Message):
            self._wire(out.t, "out", out.robot, out.attribute, message)
            return
        else:
            value = self._first(key, message)
        lines = self._lines
        lines.write(_dumps({"t": out.t, "dir": "out", "robot": out.robot, "attr": out.attribute, "value": value},
                           option=_LINE))
        if lines.tell() >= BATCH:
            self._jsonl.hand_on()

    def _wire(self, t: float, direction: str, robot: str, attribute: str, message: Any) -> None:
        """A VDA 5050 message (docs/vda5050.md): written whole, as ``raw``, in the wire form of the version its
        header names, so that each record is the message a master sends or receives (and validates against
        that version's official schema); a replay hands inbound ones to the vehicle to decode as it would
        a broker's. Visualization is not written: like OPIL's telemetry, the leg log determines it."""
        if attribute == "visualization":
            return
        global _VDA5050
        if _VDA5050 is None:  # only a VDA 5050 run loads its codec and schemas
            from vcran.core.vda5050.codec import to_plain
            from vcran.core.vda5050.enums import Version

            _VDA5050 = (to_plain, Version, {v.value: v for v in Version})
        to_plain, version, versions = _VDA5050
        named = message.header.version
        plain = to_plain(message, versions.get(named) or version(named))
        self._jsonl.write(_dumps({"t": t, "dir": direction, "robot": robot, "attr": attribute, "raw": plain},
                                 option=_LINE))

    def _first(self, key: tuple[str, str, str], message: Any) -> dict[str, Any]:
        """The ``value`` of the first record of ``key`` with a message of this class, in full; the records
        after it hold the fields that differ from the last one."""
        value: dict[str, Any] = converter(type(message), "compact")(message)
        self._last[key] = [message, dict(value), delta_converter(type(message))]
        return value

    #: Telemetry ticks are not written: the leg log determines them (:mod:`vcran.io.trace`).
    wants_frames = False

    def frame(self, frame: Frame) -> None:
        """Telemetry ticks are not written: the leg log determines them (:mod:`vcran.io.trace`)."""

    def leg(self, robot: int, leg: Leg, t: float) -> None:
        """Robot ``robot`` (fleet index) starts ``leg`` at ``t``: one row of the leg log."""
        self._legs.write(t, robot, leg_columns(leg))

    def halt(self, robot: int, t: float) -> None:
        """Robot ``robot`` halts mid-leg at ``t``: a row of NaN leg columns."""
        self._legs.write(t, robot, HALT)

    def abandon(self, robot: int, t: float, pose: tuple[float, float, float]) -> None:
        """Robot ``robot``'s leg is abandoned at ``t`` (R14): a halt row giving the pose it rests at."""
        self._legs.write(t, robot, abandon_columns(pose))

    def end(self, t: float) -> None:
        """The last line: when the run stopped, so a replay stops at the same instant (docs/contract.md §6)."""
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
    head = b"\x93NUMPY\x01\x00" + struct.pack("<H", NPY_HEADER - 10)
    return head + text.encode("latin1").ljust(NPY_HEADER - 11) + b"\n"


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
