"""Prepared converters (issue 14): the same JSON as the generic schema walk, for every message class."""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from vcran.core.ids import NIL, Id, id_for
from vcran.core.messages import ATTRIBUTES
from vcran.core.plain import to_plain
from vcran.io.render import ID_STYLES, expand, from_compact_id, to_json_value
from vcran.testing.strategies import attribute_messages, messages_of


@given(attribute_messages())
def test_plain_converter_equals_the_schema_walk(pair):  # §6: trace v1 values are to_plain
    _, message = pair
    assert to_json_value(message) == to_plain(message)


@given(attribute_messages())
def test_compact_converter_round_trips(pair):  # §6 v2: compact ids read back to the same message
    attribute, message = pair
    compact = to_json_value(message, "compact")
    assert expand(ATTRIBUTES[attribute], compact) == to_plain(message)


def test_compact_ids_by_hand():
    named = id_for("task_7")
    compact = ID_STYLES["compact"]
    assert compact(named) == "task_7"
    assert compact(NIL) is None
    # same bytes, another description: the name alone would read back as a different description
    other = Id(named.uuid, "not the name")
    assert compact(other) == [named.canonical, "not the name"]
    bare = Id(named.uuid)
    assert compact(bare) == [named.canonical, ""]
    for ident in (named, NIL, other, bare, Id(NIL.uuid, "not supported")):
        back = from_compact_id(compact(ident))
        assert back == ident and back.description == ident.description


@given(st.data())
def test_delta_converter_writes_exactly_the_changed_fields(data):  # §6 v2: nothing repeated
    from vcran.io.render import converter, delta_converter

    attribute, first = data.draw(attribute_messages())
    second = data.draw(messages_of(type(first)))
    before, after = converter(type(first), "compact")(first), converter(type(first), "compact")(second)
    full = dict(before)
    out = delta_converter(type(first))(second, first, full)
    assert full == after
    assert out == {k: v for k, v in after.items() if before[k] != v}
    assert delta_converter(type(first))(first, first, dict(before)) == {}  # the same message: nothing
