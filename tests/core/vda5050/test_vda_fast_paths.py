"""The VDA 5050 path's shortcuts for speed (issue 31's must-show, benchmarks/bench_vda5050_fleet.py) say exactly
what the plain code says (docs/contract.md §5: the same scenario and seed give the same bytes).

- The codec writes each model's encoder out once (:func:`vcran.core.vda5050.codec._encoder`); its reference is
  the field-by-field walk (``codec._put``) it replaced, which still names the field of a refusal.
- :func:`vcran.core.vda5050.header.timestamp` keeps the calendar seconds it formatted; its reference is §6.4's
  format read off the calendar afresh with :mod:`datetime` for every stamp, as it did before.
"""

from __future__ import annotations

from datetime import UTC, datetime, timedelta, timezone
from typing import Any
from zoneinfo import ZoneInfo

import orjson
import pytest
from hypothesis import given
from hypothesis import strategies as st

from vcran.core.vda5050 import codec
from vcran.core.vda5050.codec import EncodeError
from vcran.core.vda5050.enums import Topic, Version
from vcran.core.vda5050.header import DEFAULT_EPOCH, timestamp
from vcran.testing.vda5050.strategies import messages

V20, V21 = Version.V2_0_0, Version.V2_1_0
SENT = [Topic.ORDER, Topic.INSTANT_ACTIONS, Topic.STATE, Topic.VISUALIZATION, Topic.CONNECTION, Topic.FACTSHEET]


def walked(message: Any, version: Version) -> dict[str, Any] | str:
    """The field-by-field walk's wire form, or the path of its refusal."""
    out: dict[str, Any] = {}
    try:
        codec._put(message, version, out, "$")
    except EncodeError as refused:
        return refused.path
    return out


def written(message: Any, version: Version) -> dict[str, Any] | str:
    """The written-out encoder's wire form (through to_plain, which falls back to the walk to name a refusal)."""
    out: dict[str, Any] = {}
    try:
        codec._encoder(type(message), version)(message, out)
    except codec._Refused:
        try:
            codec.to_plain(message, version)
        except EncodeError as refused:
            return refused.path
        raise AssertionError("the encoder refused what to_plain sends") from None
    return out


@pytest.mark.parametrize("topic", SENT, ids=[t.value for t in SENT])
@given(data=st.data())
def test_the_written_out_encoder_writes_what_the_walk_writes(topic: Topic, data: st.DataObject) -> None:
    """Any message of either version, sent as either version: the same JSON, key for key in the same order
    (compared as orjson's bytes), or the same refusal naming the same field (a 2.1.0 message sent as 2.0.0)."""
    message = data.draw(messages(topic, data.draw(st.sampled_from([V20, V21]))))
    for version in (V20, V21):
        expected, got = walked(message, version), written(message, version)
        if isinstance(expected, str):
            assert got == expected
        else:
            assert isinstance(got, dict) and orjson.dumps(got) == orjson.dumps(expected)


def calendar(now: float, epoch: datetime) -> str:
    """§6.4's ``YYYY-MM-DDTHH:mm:ss.ffZ`` of ``now`` seconds after ``epoch``: rounded to the microsecond, then
    cut to hundredths, in UTC, read off the calendar afresh."""
    at = (epoch + timedelta(microseconds=round(now * 1_000_000))).astimezone(UTC)
    return f"{at:%Y-%m-%dT%H:%M:%S}.{at.microsecond // 10_000:02d}Z"


def test_stamps_within_a_second_and_across_one_read_the_calendar() -> None:
    """A run's stamps in time order, written out by hand: the same instant twice (a visualization per vehicle),
    within one second, and across a second, a minute, a day and a year."""
    stamps = [(0.5, "1970-01-01T00:00:00.50Z"), (0.5, "1970-01-01T00:00:00.50Z"), (0.999, "1970-01-01T00:00:00.99Z"),
              (1.0, "1970-01-01T00:00:01.00Z"), (1.004, "1970-01-01T00:00:01.00Z"), (59.99, "1970-01-01T00:00:59.99Z"),
              (60.0, "1970-01-01T00:01:00.00Z"), (86399.5, "1970-01-01T23:59:59.50Z"),
              (86400.25, "1970-01-02T00:00:00.25Z"), (365 * 86400.0, "1971-01-01T00:00:00.00Z")]
    assert [(now, timestamp(now)) for now, _ in stamps] == stamps
    # a second epoch in between, then the first again: each stamp on its own calendar
    epoch = datetime(2024, 2, 28, 12, tzinfo=UTC)
    assert [timestamp(1.5), timestamp(1.5, epoch), timestamp(1.75)] == [
        "1970-01-01T00:00:01.50Z", "2024-02-28T12:00:01.50Z", "1970-01-01T00:00:01.75Z"]


EPOCHS = [
    DEFAULT_EPOCH,
    datetime(2026, 3, 29, 1, 59, 58, tzinfo=ZoneInfo("Europe/Berlin")),  # two seconds before summer time
    datetime(2026, 11, 27, 21, 0, 0, 123456, tzinfo=UTC),  # a live run's wall-clock start: not on a whole second
    datetime(2026, 1, 1, tzinfo=timezone(timedelta(hours=2, microseconds=7))),  # an offset off the whole second
    datetime(2026, 1, 1, 0, 0, 0, 990000, tzinfo=UTC),
]


@given(st.lists(st.tuples(st.sampled_from(EPOCHS), st.floats(-1e5, 1e7) | st.sampled_from([0.0, 0.5, 1.0, 2.0])),
                max_size=60))
def test_stamps_in_any_order_and_on_any_calendar_are_the_calendars(stamps: list[tuple[datetime, float]]) -> None:
    """Whatever came before (instants back and forth, calendars interleaved, epochs and offsets off the whole
    second, a daylight-saving change), each stamp is its calendar's."""
    for epoch, now in stamps:
        assert timestamp(now, epoch) == calendar(now, epoch)
        assert timestamp(now, epoch) == calendar(now, epoch)  # the same instant again
