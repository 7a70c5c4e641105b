"""ISO 8601 times as Orion reads and prints them.

Orion reads a time with ``parse8601Time`` (common/globals.cpp) and prints one with ``isodate2str``
(common/string.cpp); :func:`parse_time` and :func:`iso_time` reproduce both, because a client of this
broker should read back the text a real Orion gives: ``2016-10-01``, ``2016-10-01T00Z`` and
``2016-10-01T000000.000`` all read back ``2016-10-01T00:00:00.000Z`` (Orion's functional test
2631_partial_datetimes/partial_datetime_creation.test).

Used for ``DateTime`` (and ``ISO8601``) attribute and metadata values, a subscription's ``expires`` and
the builtin ``dateCreated``/``dateModified``.
"""

from __future__ import annotations

import calendar
import re
import struct
import time

#: Attribute and metadata types whose values are times (Orion's DATE_TYPE and DATE_TYPE_ALT).
DATE_TYPES = ("DateTime", "ISO8601")

#: The forms parse8601Time accepts (its sscanf patterns): a date, then ``T`` and hh, hhmm, hh:mm,
#: hhmmss, hh:mm:ss, with a fraction of a second, and a zone ``Z``, ``±hh:mm``, ``±hhmm`` or ``±hh``;
#: a date alone takes no zone.
_TIME = re.compile(
    r"(?P<y>\d{4})-(?P<mo>\d{2})-(?P<d>\d{2})"
    r"(?:T(?P<h>\d{2})(?::?(?P<mi>\d{2})(?::?(?P<s>\d{2}(?:\.\d*)?))?)?(?P<tz>Z|[+-]\d{2}(?::?\d{2})?)?)?"
)


class Moment(str):
    """A time value as Orion keeps it (a number, printed by isodate2str): JSON shows it as a string, and
    ``GET .../value`` as text shows it without quotes (ngsi/ContextAttribute.cpp), unlike a string. A
    moment and a string of the same text are different values."""

    __slots__ = ()


def _float32(x: float) -> float:
    """``x`` as a C ``float``: parse8601Time keeps seconds in one."""
    return float(struct.unpack("f", struct.pack("f", x))[0])


def parse_time(text: str) -> float | None:
    """Seconds since the epoch (UTC) of an ISO 8601 time as Orion's parse8601Time reads it, or None
    where Orion answers -1 (not a time it reads, or a field out of range)."""
    if len(text) > 29 or any(c.isalpha() and c not in "TZ" for c in text):
        return None
    match = _TIME.fullmatch(text)
    if match is None:
        return None
    year, month, day = int(match["y"]), int(match["mo"]), int(match["d"])
    hour, minute = int(match["h"] or 0), int(match["mi"] or 0)
    seconds = _float32(float(match["s"] or 0))
    if not (year >= 1900 and 1 <= month <= 12 and 1 <= day <= calendar.monthrange(year, month)[1]
            and hour <= 23 and minute <= 59 and int(seconds) <= 59):
        return None
    offset = 0
    zone = match["tz"] or "Z"
    if zone != "Z":
        digits = zone[1:].replace(":", "")
        offset = (int(digits[:2]) * 3600 + int(digits[2:] or 0) * 60) * (1 if zone[0] == "+" else -1)
    whole = calendar.timegm((year, month, day, hour, minute, int(seconds), 0, 0, 0)) - offset
    return whole + _float32(seconds - int(seconds))


def iso_time(t: float) -> str:
    """Orion's isodate2str: UTC, milliseconds (a microsecond added before cutting, as Orion does), ``Z``."""
    seconds = int(t)  # C's (time_t) cast truncates
    micros = int((t - seconds) * 1_000_000)
    millis = int((micros + 1) / 1000)
    return time.strftime("%Y-%m-%dT%H:%M:%S", time.gmtime(seconds)) + f".{millis:03d}Z"
