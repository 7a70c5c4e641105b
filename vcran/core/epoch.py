"""Where simulated time 0 falls on the calendar: a scenario's ``[simulation] epoch`` (docs/scenarios.md).

VDA 5050 stamps every message with "the time when the message was sent", ISO 8601 in UTC (§6.4). vcran's
messages carry simulated time read on a fixed calendar, so a run's bytes are the same on every machine
(docs/contract.md §5); a scenario names that calendar's start as text (``"2026-01-01T00:00:00Z"``), which
the trace header records as written and a replay reads back. ``vcran live --mqtt`` sets it to the wall
clock at the run's start (:func:`vcran.commands.live.on_wall_clock`), so that a real master sees real time.

The text is strict: ISO 8601's extended form in UTC, ``YYYY-MM-DDTHH:MM:SS`` with up to six decimals, then
``Z``. One spelling per instant keeps the header readable and leaves no offset to misread; the years are
1970 to 2999, a calendar every master can read (a Unix time that is not negative) with room for any run.
"""

from __future__ import annotations

import re
from datetime import UTC, datetime

__all__ = ["epoch_instant", "epoch_problem", "epoch_text"]

_FORM = re.compile(r"\d{4}-\d{2}-\d{2}T\d{2}:\d{2}:\d{2}(\.\d{1,6})?Z")
_EARLIEST, _END = datetime(1970, 1, 1, tzinfo=UTC), datetime(3000, 1, 1, tzinfo=UTC)
_EXAMPLE = '"2026-01-01T00:00:00Z"'


def epoch_problem(text: str) -> str | None:
    """What is wrong with ``text`` as an epoch, in one line, or None."""
    if not _FORM.fullmatch(text):
        return (f"{text!r} is not a UTC date and time as ISO 8601 writes it: {_EXAMPLE} (seconds, optionally "
                "with up to six decimals, then Z for UTC)")
    try:
        at = datetime.fromisoformat(text)
    except ValueError as exc:  # a 30th of February, an hour 24
        return f"{text!r}: {exc}"
    if not _EARLIEST <= at < _END:
        return f"{text!r}: the years of the calendar are 1970 to 2999"
    return None


def epoch_instant(text: str) -> datetime:
    """The instant ``text`` names (UTC); a ValueError says what is wrong with it."""
    problem = epoch_problem(text)
    if problem is not None:
        raise ValueError(problem)
    return datetime.fromisoformat(text)


def epoch_text(at: datetime) -> str:
    """``at`` (timezone-aware) as an epoch, cut to the millisecond: ``2026-11-27T21:30:12.345Z``. Cut, not
    rounded, so that the epoch of a run that starts now never lies ahead of now."""
    at = at.astimezone(UTC)
    return f"{at:%Y-%m-%dT%H:%M:%S}.{at.microsecond // 1000:03d}Z"
