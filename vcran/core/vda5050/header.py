"""The protocol header (§6.4) that starts every VDA 5050 message, and the stamping of sent messages.

On the wire the header is five top-level fields, not an object; in vcran's models it is one ``header``
field, flattened by the codec. A vehicle stamps what it sends with a :class:`Stamper`: ``headerId`` counts
per topic ("incremented by 1 with each sent message", §6.4) and the timestamp is simulated time read on a
fixed calendar (``epoch``: the scenario's, 1970 unless it sets one, the wall-clock start in a live run), so
a run's messages are the same bytes on every machine and in its replay (docs/contract.md §5).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from datetime import UTC, datetime, timedelta
from functools import cache

from vcran.core.epoch import epoch_instant
from vcran.core.slots import slot_init
from vcran.core.vda5050.enums import Version

#: Where simulated time 0 falls on the calendar unless the scenario says otherwise (``[simulation] epoch``;
#: a live run sets it to the wall-clock start): the Unix epoch, a date no master mistakes for a real one.
DEFAULT_EPOCH = datetime(1970, 1, 1, tzinfo=UTC)


@cache
def epoch_of(text: str | None) -> datetime:
    """The calendar a scenario's ``[simulation] epoch`` names (:mod:`vcran.core.epoch`; checked as it loads),
    :data:`DEFAULT_EPOCH` when it names none. One object per text: :func:`timestamp` keeps the seconds it
    formatted for the epoch it was given last, which every vehicle of a fleet then shares."""
    return DEFAULT_EPOCH if text is None else epoch_instant(text)


@slot_init
@dataclass(frozen=True, slots=True)
class Header:
    """§6.4. ``version`` is a string: a received message may carry any; vcran stamps its vehicle's."""

    header_id: int
    timestamp: str
    version: str
    manufacturer: str
    serial_number: str


def timestamp(now: float, epoch: datetime = DEFAULT_EPOCH) -> str:
    """``now`` (simulated seconds) as §6.4 writes a timestamp: ``YYYY-MM-DDTHH:mm:ss.ffZ``, UTC.

    The instant is rounded to the microsecond first (R14's resolution) and then cut to hundredths, so a
    stamp never names an instant later than ``now``: ``timestamp(1.239) == '1970-01-01T00:00:01.23Z'``.
    """
    global _STAMPED
    known = _STAMPED
    if known[0] is epoch:
        if now == known[2]:
            return known[3]
        micros = round(now * 1_000_000)
        second, fraction = divmod(micros, 1_000_000)
        text = known[1].get(second)
        if text is not None:
            stamp = f"{text}.{fraction // 10_000:02d}Z"
            _STAMPED = (epoch, known[1], now, stamp)
            return stamp
    micros = round(now * 1_000_000)
    second, fraction = divmod(micros, 1_000_000)
    at = epoch + timedelta(microseconds=micros)
    at = at.astimezone(UTC)
    text = f"{at:%Y-%m-%dT%H:%M:%S}"
    stamp = f"{text}.{at.microsecond // 10_000:02d}Z"
    if at.microsecond == fraction:  # the epoch (and its offset) on a whole second, as the default epoch
        seconds = known[1] if known[0] is epoch and len(known[1]) < 4096 else {}
        seconds[second] = text
        _STAMPED = (epoch, seconds, now, stamp)
    return stamp


#: What :func:`timestamp` formatted lately, for one epoch: (the epoch, the calendar seconds' texts by second
#: since the epoch, the last ``now`` and its stamp), one tuple so that a thread reads it whole. A fleet stamps
#: many messages within a second, and a visualization per vehicle at the same instant every tick: formatting
#: the calendar for each was 5% of a 100-vehicle hour (benchmarks/bench_vda5050_fleet.py). Kept only where the
#: epoch and its offset fall on a whole second, so that a second's text is the same for every instant in it.
_STAMPED: tuple[datetime | None, dict[int, str], float, str] = (None, {}, math.nan, "")


@dataclass(slots=True)
class Stamper:
    """Headers for one vehicle's sent messages: a ``headerId`` counter per topic, from 0."""

    version: Version
    manufacturer: str
    serial_number: str
    epoch: datetime = DEFAULT_EPOCH
    _next: dict[str, int] = field(default_factory=dict)

    def stamp(self, topic: str, now: float) -> Header:
        """The header of the next message on ``topic``; call once per message sent."""
        n = self._next.get(topic, 0)
        self._next[topic] = n + 1
        return Header(n, timestamp(now, self.epoch), self.version._value_, self.manufacturer, self.serial_number)
