"""Run files (docs/contract.md §6, §8): the trace, the events, the leg log; written compressed as they happen.

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

One concept per module (issue 30): :mod:`~vcran.io.trace.files` (the files' names and layouts),
:mod:`~vcran.io.trace.streams` (zstd streams: batched writing, reading, checking one whole),
:mod:`~vcran.io.trace.writers` (the run's writers), :mod:`~vcran.io.trace.readers` (reading either
format) and :mod:`~vcran.io.trace.reconstruct` (the telemetry from the leg log). Their public names are
imported from here, ``vcran.io.trace``, as they were when it was one module; the modules' own names are
for vcran's code and tests that reach a private one.
"""

from __future__ import annotations

from vcran.io.trace.files import (
    EVENT_KEYS,
    EVENTS_FILE,
    EVENTS_FILE_V1,
    FORMAT,
    LEG_COLUMNS,
    LEGS_FILE,
    READS,
    SUMMARY_FILE,
    TELEMETRY_FILE,
    TRACE_FILE,
    TRACE_FILE_V1,
    VERSION,
    leg_dtype,
)
from vcran.io.trace.readers import (
    event_records,
    events_beside,
    legs,
    lines,
    read_header,
    records,
    robots_of,
    telemetry,
    trace_in,
    trace_records,
)
from vcran.io.trace.reconstruct import long_table, samples, telemetry_table
from vcran.io.trace.streams import BATCH, check_whole, open_input, open_output, whole_lines, zst_cut_off
from vcran.io.trace.writers import EventWriter, LegLog, TraceWriter, json_line, raw_json

__all__ = [
    "BATCH", "EVENTS_FILE", "EVENTS_FILE_V1", "EVENT_KEYS", "FORMAT", "LEGS_FILE", "LEG_COLUMNS", "READS",
    "SUMMARY_FILE", "TELEMETRY_FILE", "TRACE_FILE", "TRACE_FILE_V1", "VERSION", "EventWriter", "LegLog",
    "TraceWriter", "check_whole", "event_records", "events_beside", "json_line", "leg_dtype", "legs", "lines",
    "long_table", "open_input", "open_output", "raw_json", "read_header", "records", "robots_of", "samples",
    "telemetry", "telemetry_table", "trace_in", "trace_records", "whole_lines", "zst_cut_off",
]
