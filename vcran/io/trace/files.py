"""What a run folder's files are called and what their lines and rows hold (format 2, and format 1's names,
still read): the names every writer and reader of :mod:`vcran.io.trace` shares, and nothing else."""

from __future__ import annotations

from functools import cache
from typing import TYPE_CHECKING

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
              # a fleet manager's job events (closed loop, docs/contract.md §9: vcran.core.jobs)
              "job", "pickup", "dropoff", "priority", "deadline", "lead_time", "tasks",
              # a robot on its own (docs/contract.md §4: vcran.core.incidents)
              "kind", "duration", "applied", "charge", "percentage", "other", "x", "y")

#: One row of ``legs.npy``. A leg: robot ``robot`` (index in the header's / summary's robot order) started,
#: at ``t``, the leg from ``(x0, y0, theta0)`` to ``(x, y)`` ending at heading ``theta`` (NaN: facing the
#: direction of travel) with its speed limits, timed from ``t0`` (``t`` itself, except for a leg resumed
#: after a hold: the held leg shifted by the hold's length). A halt (pause, breakdown, a stop on its own;
#: docs/contract.md §4): every column but ``t`` and ``robot`` NaN; the robot rests where its leg had brought it at ``t``.
#: An abandon (R14: the leg began at the instant of a cancel or deadline, and does not happen): a halt
#: with ``x0``, ``y0``, ``theta0`` set, where the robot rests (where the leg began).
LEG_COLUMNS = (("t", "<f8"), ("robot", "<u4"), ("t0", "<f8"), ("x0", "<f8"), ("y0", "<f8"),
               ("theta0", "<f8"), ("x", "<f8"), ("y", "<f8"), ("theta", "<f8"),
               ("speed", "<f8"), ("accel", "<f8"), ("decel", "<f8"), ("turn_rate", "<f8"))


@cache
def leg_dtype() -> np.dtype:
    """:data:`LEG_COLUMNS` as a numpy structured dtype (made on first use: writing the
    leg log needs no numpy, so a run that nobody samples does not import it; issue 14)."""
    import numpy as np

    return np.dtype(list(LEG_COLUMNS))


#: Bytes reserved for ``legs.npy``'s header, rewritten with the row count when the log is closed (a killed
#: run's rows start here).
NPY_HEADER = 512
