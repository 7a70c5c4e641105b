"""Round trips: every message of docs/contract.md §2 survives encode -> JSON text -> decode, in both renderings."""

from __future__ import annotations

import json
import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from vcran.core.opil.codec import (
    decode_attribute,
    decode_entity,
    encode_attribute,
    encode_attribute_json,
    encode_entity,
    encode_entity_json,
    escape_string,
    unescape_string,
)
from vcran.core.opil.messages import ATTRIBUTES, Header, Motion, PoseStamped, Time
from vcran.core.opil.plain import to_plain
from vcran.core.opil.schema import INT_RANGES, Message, MessageError
from vcran.testing.strategies import (
    attribute_messages,
    messages_of,
    motions,
    ros_strings,
)


def through_json(value: object) -> object:
    """What the other side of an HTTP connection gets."""
    return json.loads(json.dumps(value, allow_nan=False))


def assert_same(decoded: Message, original: Message) -> None:
    # ``==`` ignores id descriptions (ids are equal by uuid); the plain form compares every value.
    assert decoded == original
    assert to_plain(decoded) == to_plain(original)


@pytest.mark.slow
@pytest.mark.parametrize("rendering", ["normalized", "keyValues"])
@pytest.mark.parametrize("name", sorted(ATTRIBUTES))
@given(data=st.data())
def test_roundtrip(name: str, rendering: str, data: st.DataObject) -> None:
    message = data.draw(messages_of(ATTRIBUTES[name]))
    attr = encode_attribute(name, message)
    key_values = rendering == "keyValues"
    wire = through_json(attr["value"] if key_values else attr)  # keyValues shows just the value
    assert_same(decode_attribute(name, wire), message)  # rendering detected
    assert_same(decode_attribute(name, wire, key_values=key_values), message)


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(ATTRIBUTES))
@given(data=st.data())
def test_json_text_encoder_writes_exactly_the_dicts(name: str, data: st.DataObject) -> None:
    """The wire encoder is a second generated target; it must never drift from encode_attribute."""
    message = data.draw(messages_of(ATTRIBUTES[name]))
    text = encode_attribute_json(name, message)
    assert text == json.dumps(encode_attribute(name, message), separators=(",", ":"))
    assert_same(decode_attribute(name, json.loads(text)), message)


@pytest.mark.slow
@given(st.lists(attribute_messages(), max_size=4))
def test_entity_json_is_the_compact_entity(items: list[tuple[str, Message]]) -> None:
    messages = dict(items)
    expected = json.dumps(encode_entity("robot_1", "ROBOT", messages), separators=(",", ":")).encode()
    assert encode_entity_json("robot_1", "ROBOT", messages) == expected


@pytest.mark.slow
@given(st.lists(attribute_messages(), max_size=4), st.booleans())
def test_roundtrip_entity(items: list[tuple[str, Message]], key_values: bool) -> None:
    messages = dict(items)
    entity = encode_entity("robot_1", "ROBOT", messages)
    if key_values:
        entity = {k: v if k in ("id", "type") else v["value"] for k, v in entity.items()}
    decoded = decode_entity(through_json(entity))
    assert list(decoded) == list(messages)
    for name, message in messages.items():
        assert_same(decoded[name], message)


# --- strings: the Orion escape (docs/wire-format.md) --------------------------------------------------


@given(ros_strings(40))
def test_escape_is_reversible_and_orion_safe(text: str) -> None:
    escaped = escape_string(text)
    assert not set(escaped) & set("<>\"'=;()")
    assert unescape_string(escaped) == text


def test_escape_mapping_is_the_documented_one() -> None:
    assert escape_string("""a<b>c"d'e=f;g(h)i%j""") == "a%3Cb%3Ec%22d%27e%3Df%3Bg%28h%29i%25j"
    assert escape_string("length=3 (known: 0, 5)") == "length%3D3 %28known: 0, 5%29"
    assert escape_string("plain /map & more?#") == "plain /map & more?#"
    assert unescape_string("50% done, %41 stays, %3c is <") == "50% done, %41 stays, < is <"
    assert unescape_string("%253C") == "%3C"  # one pass: an escaped escape is not undone twice


# --- time stamps: simulated seconds without drift -----------------------------------------------------

SIXTY_DAYS = 60 * 86400.0


@given(st.floats(min_value=-SIXTY_DAYS, max_value=SIXTY_DAYS))
def test_stamp_from_simulated_seconds_is_nearest_nanosecond(t: float) -> None:
    stamp = Time.from_seconds(t)
    assert 0 <= stamp.nsecs < 1_000_000_000
    assert abs(stamp.to_seconds() - t) <= 0.5e-9 + 1e-15 * abs(t)


@given(st.floats(min_value=0.0, max_value=float(INT_RANGES["int32"][1])))
def test_stamps_do_not_drift_through_the_wire(t: float) -> None:
    """Stamp -> seconds -> stamp is a fixed point, also through an encoded current_motion."""
    stamp = Time.from_seconds(t)
    assert Time.from_seconds(stamp.to_seconds()) == stamp
    motion = Motion(current_position=PoseStamped(header=Header(stamp=stamp)))
    again = decode_attribute("current_motion", through_json(encode_attribute("current_motion", motion)))
    assert again.current_position.header.stamp == stamp  # type: ignore[attr-defined]
    assert again.current_position.header.stamp.to_seconds() == stamp.to_seconds()  # type: ignore[attr-defined]


@given(st.integers(0, 2**22 - 1), st.integers(0, 999_999_999))
def test_every_stamp_of_a_48_day_run_maps_to_seconds_and_back_exactly(secs: int, nsecs: int) -> None:
    stamp = Time(secs, nsecs)
    assert Time.from_seconds(stamp.to_seconds()) == stamp


def test_reference_stamp() -> None:
    assert Time(2291, 100_000_000).to_seconds() == 2291.1
    assert Time.from_seconds(2291.1) == Time(2291, 100_000_000)
    assert math.isclose(Time(1572008882, 381286634).to_seconds(), 1572008882.381286634, rel_tol=0, abs_tol=1e-6)


@pytest.mark.parametrize("t", [3e9, 1e308, -1e308, 2.0**32])
def test_a_time_beyond_a_stamp_is_a_message_error_naming_secs(t: float) -> None:
    """``t * 1e9`` overflows to inf for t = 1e308: that was an OverflowError (exit 70 from a scenario's
    script), not the MessageError the loader turns into a load error naming the entry."""
    with pytest.raises(MessageError, match="^secs: .* is outside the int32 range"):
        Time.from_seconds(t)


@pytest.mark.slow
@given(motions())
def test_encoded_numbers_keep_their_json_kind(message: Motion) -> None:
    """Float fields go out as JSON floats and int fields as ints, so the wire type never flips."""
    value = encode_attribute("current_motion", message)["value"]
    stamp = value["current_position"]["value"]["header"]["value"]["stamp"]["value"]
    assert all(type(stamp[k]["value"]) is int for k in ("secs", "nsecs"))
    position = value["current_position"]["value"]["pose"]["value"]["position"]["value"]
    assert all(type(position[k]["value"]) is float for k in "xyz")
