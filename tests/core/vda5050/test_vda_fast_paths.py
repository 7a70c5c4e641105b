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


# --- the quick schema check ---------------------------------------------------------------------------------

JSON_VALUES = st.recursive(
    st.none() | st.booleans() | st.integers(-3, 3) | st.floats(-3.0, 3.0) | st.sampled_from([1.0, -1.0, 0.5]) |
    st.sampled_from(["", "x", "HARD", "SOFT", "NONE", "map", "2.1.0", "AUTOMATIC"]),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.sampled_from(["x", "nodeId", "actions"]), inner,
                                                                  max_size=3),
    max_leaves=6)


def places(doc: Any, path: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    """Every place in ``doc`` (the path of keys and indexes to it), the document itself first."""
    out = [path]
    if isinstance(doc, dict):
        for key, value in doc.items():
            out += places(value, (*path, key))
    elif isinstance(doc, list):
        for i, value in enumerate(doc):
            out += places(value, (*path, i))
    return out


def changed(doc: Any, path: tuple[Any, ...], value: Any, remove: bool) -> Any:
    """``doc`` with the value at ``path`` replaced by ``value`` (or removed, from an object)."""
    if not path:
        return value
    copy: Any = dict(doc) if isinstance(doc, dict) else list(doc)
    head, rest = path[0], path[1:]
    if not rest and remove and isinstance(copy, dict):
        del copy[head]
    else:
        copy[head] = changed(copy[head], rest, value, remove)
    return copy


@pytest.mark.parametrize("topic", SENT, ids=[t.value for t in SENT])
@given(data=st.data())
def test_the_quick_check_never_passes_what_jsonschema_refuses(topic: Topic, data: st.DataObject) -> None:
    """A message of each kind and version, and the same with one value anywhere replaced by any JSON value or
    removed: whenever the quick check says valid, jsonschema (the official schema, as received messages are
    checked) says valid too; and a message vcran builds passes it, which is what makes decoding fast."""
    from vcran.core.vda5050 import validation

    version = data.draw(st.sampled_from([V20, V21]))
    validator = validation.inbound(topic, version)
    quick = validation._quick(validator)
    if quick is None:
        assert topic is Topic.FACTSHEET  # the one schema beyond the quick check's keywords: jsonschema alone
        return
    doc = codec.to_plain(data.draw(messages(topic, version)), version)
    assert quick(doc) and validator.is_valid(doc)
    for _ in range(5):
        path = data.draw(st.sampled_from(places(doc)))
        mutated = changed(doc, path, data.draw(JSON_VALUES), data.draw(st.booleans()))
        if quick(mutated):
            assert validator.is_valid(mutated), (path, mutated)


def test_the_quick_check_compiles_only_its_keywords() -> None:
    """Each keyword by hand (jsonschema's meaning, module docstring of vcran.core.vda5050.quickcheck)."""
    from vcran.core.vda5050.quickcheck import compile_schema

    schema = {"type": "object", "required": ["n"], "properties": {
        "n": {"type": "integer", "minimum": 0, "maximum": 3}, "s": {"type": "string", "enum": ["A", "B"]},
        "l": {"type": "array", "items": {"$ref": "#/definitions/p"}}, "u": {"anyOf": [{"type": "null"}, {"type": "number"}]}},
        "definitions": {"p": {"type": ["boolean", "null"]}}}
    check = compile_schema(schema)
    assert check is not None
    assert [check(d) for d in ({"n": 0}, {"n": 3.0}, {"n": 2, "s": "B", "l": [True, None], "u": 1.5}, {"n": 1, "x": {}})] \
        == [True, True, True, True]
    assert [check(d) for d in ({}, {"n": True}, {"n": 1.5}, {"n": -1}, {"n": 4}, {"n": 1, "s": "C"}, {"n": 1, "l": [1]},
                               {"n": 1, "u": "x"}, {"n": 1, "l": {}}, [])] == [False] * 10
    for beyond in ({"pattern": "^a"}, {"additionalProperties": False}, {"enum": [1, 2]}, {"items": [{}]},
                   {"$ref": "other.json#/x"}, {"type": "int"}):
        assert compile_schema({"type": "object", "properties": {"a": beyond}}) is None
