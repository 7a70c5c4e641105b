"""Reading a recorded run, either format: its trace's header and records, its events and its leg log, and
format 1's files (``trace.jsonl``, ``events.jsonl``, ``telemetry.bin``), all presented in format 1's form
(every value complete, plain ids) so that every reader works on both (:mod:`vcran.io.trace`)."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

import orjson

from vcran.core.opil.messages import ATTRIBUTES, RENAMED
from vcran.core.wire import Frame
from vcran.io.render import expand
from vcran.io.trace.files import (
    EVENTS_FILE,
    EVENTS_FILE_V1,
    FORMAT,
    LEGS_FILE,
    NPY_HEADER,
    READS,
    TELEMETRY_FILE,
    TRACE_FILE,
    TRACE_FILE_V1,
    leg_dtype,
)
from vcran.io.trace.streams import check_whole, open_input, whole_lines

if TYPE_CHECKING:
    import numpy as np


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
    """``legs.npy`` (or the one in a run folder) as a structured array of :func:`leg_dtype` rows.
    ``cut_off``: the run was killed before the row count was written; every whole row is read."""
    import numpy as np

    dtype = leg_dtype()
    if path.is_dir():
        path = path / LEGS_FILE
    if cut_off:
        data = np.fromfile(path, dtype=np.uint8, offset=NPY_HEADER)
        return data[: data.size - data.size % dtype.itemsize].view(dtype)
    try:
        data = np.load(path, allow_pickle=False)
    except (ValueError, EOFError) as exc:
        raise ValueError(f"{path}: not a vcran leg log ({exc})") from None
    if data.dtype != dtype:
        raise ValueError(f"{path}: not a vcran leg log (columns {data.dtype.names})")
    return data


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




def trace_records(run: Path | str) -> list[dict[str, Any]]:
    """The records of a run's trace (either format) in full: every value complete, ids as
    ``{"uuid", "description"}`` (the header and the end line left out). ``pandas.DataFrame(...)`` of it
    has one row per message."""
    return [r for _, r in records(trace_in(Path(run)), ("in", "out"))]
