"""Prepared converters (issue 14): the same JSON as the generic schema walk, for every message class."""

from __future__ import annotations

import copy
import dataclasses
import pickle

from hypothesis import given
from hypothesis import strategies as st

from vcran.core.opil.ids import NIL, Id, NamedId, id_for
from vcran.core.opil.messages import ATTRIBUTES
from vcran.core.opil.plain import to_plain
from vcran.io.render import ID_STYLES, expand, from_compact_id, to_json_value
from vcran.io.trace import json_line
from vcran.testing.strategies import attribute_messages, messages_of


@given(attribute_messages())
def test_plain_converter_equals_the_schema_walk(pair):  # docs/contract.md §6: trace v1 values are to_plain
    _, message = pair
    assert to_json_value(message) == to_plain(message)


@given(attribute_messages())
def test_compact_converter_round_trips(pair):  # docs/contract.md §6 v2: compact ids read back to the same message
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


def test_compact_id_of_an_id_not_made_by_id_for():  # docs/ids.md: the rendering depends on bytes and text only
    compact = ID_STYLES["compact"]
    decoded = Id.from_octets(list(id_for("task_8").uuid), "task_8")  # as a peer's payload decodes
    assert type(decoded) is Id and compact(decoded) == "task_8"
    assert compact(Id(id_for("task_8").uuid, "task_9")) == [id_for("task_8").canonical, "task_9"]


def test_named_ids_stay_honest():  # ids.NamedId: the class vouches for its bytes; nothing else may claim it
    named = id_for("task_10")
    assert type(named) is NamedId and named == Id(named.uuid) and hash(named) == hash(Id(named.uuid))
    relabelled = dataclasses.replace(named, description="task_11")
    assert type(relabelled) is Id and relabelled == named
    assert ID_STYLES["compact"](relabelled) == [named.canonical, "task_11"]
    assert type(NamedId(id_for("x").uuid, "y")) is Id
    for copied in (pickle.loads(pickle.dumps(named)), copy.deepcopy(named), copy.copy(named)):
        assert type(copied) is NamedId and copied.description == "task_10" and copied.uuid == named.uuid
    assert repr(named) == f"Id('{named.canonical}', 'task_10')"


@given(st.data())
def test_delta_converter_writes_exactly_the_changed_fields(data):  # docs/contract.md §6 v2: nothing repeated
    from vcran.io.render import converter, delta_converter

    attribute, first = data.draw(attribute_messages())
    second = data.draw(messages_of(type(first)))
    before, after = converter(type(first), "compact")(first), converter(type(first), "compact")(second)
    full = dict(before)
    out = delta_converter(type(first))(second, first, full)
    # compared as JSON text, not as Python values: -0.0 == 0.0, but a trace must keep the sign a fleet
    # manager wrote (a replay feeds the recorded value, and a leg to x = -0.0 is another leg, bit for bit)
    assert json_line(full) == json_line(after)
    assert json_line(out) == json_line({k: v for k, v in after.items() if json_line(before[k]) != json_line(v)})
    assert delta_converter(type(first))(first, first, dict(before)) == {}  # the same message: nothing


def test_delta_of_a_rebuilt_array():  # docs/contract.md §6 v2: an array rebuilt with the same ids is unchanged, a relabelled id is not
    from vcran.core.opil.messages import RanStatus
    from vcran.io.render import converter, delta_converter

    a, b = id_for("task_1"), id_for("task_2")
    first = RanStatus(state="ACTIVE", queue=(a, b), queued=2)
    full = dict(converter(RanStatus, "compact")(first))
    delta = delta_converter(RanStatus)
    assert delta(RanStatus(state="ACTIVE", queue=(a, b), queued=2), first, full) == {}
    relabelled = Id(b.uuid, "renamed")  # equal to b (same bytes), written differently
    second = RanStatus(state="ACTIVE", queue=(a, relabelled), queued=2)
    assert delta(second, first, full) == {"queue": ["task_1", [b.canonical, "renamed"]]}
    assert delta(RanStatus(state="ACTIVE", queue=(a,), queued=1), second, full) == {"queue": ["task_1"], "queued": 1}
