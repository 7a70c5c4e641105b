"""VDA 5050 messages (docs/contract.md §11, issue 31 item 1): every kind, in 2.0.0 and 2.1.0, encodes to JSON that the
official schema accepts and decodes back to the same model; each difference between the versions is
handled as docs/vda5050.md ("Versions") says; received messages that are not valid come back as an
``Invalid`` naming the field, never as an exception."""

from __future__ import annotations

from dataclasses import replace
from datetime import UTC, datetime
from typing import Any

import orjson
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vcran.core.vda5050 import codec, validation
from vcran.core.vda5050.codec import EncodeError, Invalid
from vcran.core.vda5050.enums import (
    BlockingType,
    ErrorLevel,
    EStop,
    MapStatus,
    OperatingMode,
    OrientationType,
    Topic,
    Version,
)
from vcran.core.vda5050.factsheet import VehicleConfig
from vcran.core.vda5050.header import Header, Stamper, timestamp
from vcran.core.vda5050.order import (
    Action,
    ActionParameter,
    ControlPoint,
    Corridor,
    Edge,
    InstantActions,
    Node,
    NodePosition,
    Order,
    Trajectory,
)
from vcran.core.vda5050.state import BatteryState, EdgeState, Error, Map, NodeState, SafetyState, State
from vcran.testing.vda5050.strategies import factsheets, messages

V20, V21 = Version.V2_0_0, Version.V2_1_0
CASES = [(topic, version) for topic in Topic for version in Version]


def official_problem(topic: Topic, version: Version, raw: bytes) -> tuple[str, str] | None:
    return validation.first_problem(validation.outbound(topic, version), orjson.loads(raw))


@pytest.mark.parametrize(("topic", "version"), CASES, ids=[f"{t.value}-{v.value}" for t, v in CASES])
@settings(max_examples=25)
@given(data=st.data())
def test_every_kind_validates_and_round_trips(topic: Topic, version: Version, data: st.DataObject) -> None:
    """docs/contract.md §11: every message vcran sends validates against the official schema of its version, and a
    received one decodes to what was sent."""
    message = data.draw(messages(topic, version))
    raw = codec.encode(message, version)
    assert official_problem(topic, version, raw) is None
    assert codec.decode(topic, raw, version) == message


@settings(max_examples=25)
@given(factsheets(V20))
def test_a_2_0_factsheet_also_passes_the_2_1_schema(sheet: Any) -> None:
    """2.0.0's factsheet.json puts its properties at the top level, outside ``properties``, so it checks
    only the required keys; the 2.1.0 schema has the same fields (and vehicleConfig, which 2.0.0 lacks)
    and really checks them."""
    assert official_problem(Topic.FACTSHEET, V21, codec.encode(sheet, V20)) is None


def header(version: Version = V21) -> Header:
    return Header(header_id=7, timestamp="2024-01-01T00:00:00.00Z", version=version.value, manufacturer="acme",
                  serial_number="agv1")


def order(*, position: NodePosition | None = None, edge: dict[str, Any] | None = None,
          parameter: Any = "floor", version: Version = V21) -> Order:
    pick = Action(action_type="pick", action_id="p1", blocking_type=BlockingType.HARD,
                  action_parameters=(ActionParameter(key="stationType", value=parameter),))
    return Order(
        header=header(version), order_id="o1", order_update_id=0,
        nodes=(Node(node_id="a", sequence_id=0, released=True,
                    node_position=position or NodePosition(x=0.0, y=0.0, map_id="map")),
               Node(node_id="b", sequence_id=2, released=True, actions=(pick,),
                    node_position=NodePosition(x=1.0, y=0.0, map_id="map"))),
        edges=(Edge(edge_id="e1", sequence_id=1, released=True, start_node_id="a", end_node_id="b", **(edge or {})),),
    )


# --- the differences between 2.0.0 and 2.1.0 ---------------------------------------------------------------


@pytest.mark.parametrize(("version", "spelling"), [(V20, "allowedDeviationXy"), (V21, "allowedDeviationXY")])
def test_allowed_deviation_is_spelled_as_each_version_spells_it(version: Version, spelling: str) -> None:
    """The 2.0.0 schema writes allowedDeviationXy, 2.1.0 allowedDeviationXY: sent as the version spells
    it, read in either spelling (a master reading the other version's text loses nothing)."""
    sent = order(position=NodePosition(x=0.0, y=0.0, map_id="map", allowed_deviation_xy=0.5), version=version)
    doc = orjson.loads(codec.encode(sent, version))
    assert doc["nodes"][0]["nodePosition"][spelling] == 0.5
    other = "allowedDeviationXY" if spelling == "allowedDeviationXy" else "allowedDeviationXy"
    assert other not in doc["nodes"][0]["nodePosition"]
    doc["nodes"][0]["nodePosition"][other] = doc["nodes"][0]["nodePosition"].pop(spelling)
    received = codec.decode(Topic.ORDER, doc, version)
    assert isinstance(received, Order)
    assert received.nodes[0].node_position == NodePosition(x=0.0, y=0.0, map_id="map", allowed_deviation_xy=0.5)


@pytest.mark.parametrize(("message", "topic", "path"), [
    (order(edge={"corridor": Corridor(left_width=1.0, right_width=1.0)}), Topic.ORDER, "$.edges[0].corridor"),
    (order(edge={"orientation": 0.0, "orientation_type": OrientationType.GLOBAL}), Topic.ORDER,
     "$.edges[0].orientationType"),
    (order(parameter={"shelf": 3}), Topic.ORDER, "$.nodes[1].actions[0].actionParameters[0].value"),
], ids=["corridor", "orientationType", "object parameter"])
def test_what_2_0_cannot_carry_is_refused_with_its_path(message: Any, topic: Topic, path: str) -> None:
    """Corridors, orientationType and object-valued action parameters came with 2.1.0: sending them as
    2.0.0 is an error naming the field, never a silent loss (2.1.0 sends them)."""
    with pytest.raises(EncodeError) as caught:
        codec.encode(message, V20)
    assert caught.value.path == path
    assert official_problem(topic, V21, codec.encode(message, V21)) is None


def test_a_2_1_state_with_maps_or_error_hints_is_refused_as_2_0() -> None:
    state = a_state()
    with_maps = replace(state, maps=(Map(map_id="m", map_version="1", map_status=MapStatus.ENABLED),))
    with pytest.raises(EncodeError, match=r"^\$\.maps: "):
        codec.encode(with_maps, V20)
    hinted = replace(state, maps=None, errors=(Error(error_type="x", error_level=ErrorLevel.WARNING, error_hint="h"),))
    with pytest.raises(EncodeError, match=r"^\$\.errors\[0\]\.errorHint: "):
        codec.encode(hinted, V20)


@given(factsheets(V21))
def test_vehicle_config_is_2_1_only(sheet: Any) -> None:
    with pytest.raises(EncodeError, match=r"^\$\.vehicleConfig: "):
        codec.encode(replace(sheet, vehicle_config=VehicleConfig()), V20)


def test_2_0_state_needs_theta_and_weights_where_its_schema_requires_them() -> None:
    """2.0.0's state schema requires a nodeState position's theta and every control point's weight
    (2.1.0 does not)."""
    state = a_state(V20)
    no_theta = replace(state, node_states=(NodeState(node_id="n", sequence_id=0, released=True,
                                                     node_position=NodePosition(x=0.0, y=0.0, map_id="m")),))
    with pytest.raises(EncodeError) as caught:
        codec.encode(no_theta, V20)
    assert caught.value.path == "$.nodeStates[0].nodePosition.theta"
    curve = Trajectory(degree=1, knot_vector=(0.0, 0.0, 1.0, 1.0),
                       control_points=(ControlPoint(x=0.0, y=0.0, weight=1.0), ControlPoint(x=1.0, y=0.0)))
    no_weight = replace(state, edge_states=(EdgeState(edge_id="e", sequence_id=1, released=True, trajectory=curve),))
    with pytest.raises(EncodeError) as caught:
        codec.encode(no_weight, V20)
    assert caught.value.path == "$.edgeStates[0].trajectory.controlPoints[1].weight"
    for fine in (no_theta, no_weight):
        assert official_problem(Topic.STATE, V21, codec.encode(replace(fine, header=header()), V21)) is None


def a_state(version: Version = V21) -> State:
    return State(header=header(version), order_id="", order_update_id=0, last_node_id="", last_node_sequence_id=0,
                 node_states=(), edge_states=(), driving=False, action_states=(),
                 battery_state=BatteryState(battery_charge=100.0, charging=False),
                 operating_mode=OperatingMode.AUTOMATIC, errors=(),
                 safety_state=SafetyState(e_stop=EStop.NONE, field_violation=False))


def instant(version: Version) -> InstantActions:
    return InstantActions(header=header(version), actions=(
        Action(action_type="startPause", action_id="i1", blocking_type=BlockingType.NONE),))


def test_2_0_instant_actions_carry_both_spellings_of_the_type() -> None:
    """The official 2.0.0 schema requires actionName, the 2.0.0 text actionType: vcran sends both, and
    reads either (docs/vda5050.md); 2.1.0 has actionType only."""
    doc = orjson.loads(codec.encode(instant(V20), V20))
    assert doc["actions"][0]["actionType"] == doc["actions"][0]["actionName"] == "startPause"
    assert "actionName" not in orjson.loads(codec.encode(instant(V21), V21))["actions"][0]
    for spelling in ("actionType", "actionName"):
        action = {"actionId": "i1", "blockingType": "NONE", spelling: "startPause"}
        received = codec.decode(Topic.INSTANT_ACTIONS, {**doc, "actions": [action]}, V20)
        assert received == instant(V20)
    renamed = {**doc, "actions": [{"actionId": "i1", "blockingType": "NONE", "actionName": "startPause"}]}
    assert codec.decode(Topic.INSTANT_ACTIONS, renamed, V21) == Invalid(
        Topic.INSTANT_ACTIONS, "$.actions[0].actionType", "required field missing", 7)


def test_2_0_instant_actions_may_name_their_list_instant_actions() -> None:
    """The 2.0.0 schema calls the list ``actions``, the 2.0 text of June 2020 ``instantActions``
    (VDA5050/vd-m-a-5050 issue 16), which vda-5050-lib 1.x sends (coatyio/vda-5050-lib.js pull request
    32, open): a 2.0.0 vehicle reads either, and refuses a message with neither; 2.1.0 has ``actions``
    only."""
    doc = orjson.loads(codec.encode(instant(V20), V20))
    text_spelling = {key: value for key, value in doc.items() if key != "actions"}
    text_spelling["instantActions"] = [{"actionId": "i1", "blockingType": "NONE", "actionType": "startPause"}]
    assert codec.decode(Topic.INSTANT_ACTIONS, text_spelling, V20) == instant(V20)
    assert codec.decode(Topic.INSTANT_ACTIONS, {**text_spelling, "instantActions": [{"actionId": "i1"}]}, V20) \
        == Invalid(Topic.INSTANT_ACTIONS, "$.instantActions[0].blockingType", "required field missing", 7)
    neither = {key: value for key, value in text_spelling.items() if key != "instantActions"}
    assert codec.decode(Topic.INSTANT_ACTIONS, neither, V20) == Invalid(
        Topic.INSTANT_ACTIONS, "$.actions", "required field missing", 7)
    assert codec.decode(Topic.INSTANT_ACTIONS, {**text_spelling, "version": "2.1.0"}, V21) == Invalid(
        Topic.INSTANT_ACTIONS, "$.actions", "required field missing", 7)


def test_2_0_instant_actions_need_a_header_as_the_text_says() -> None:
    doc = orjson.loads(codec.encode(instant(V20), V20))
    del doc["timestamp"]
    assert codec.decode(Topic.INSTANT_ACTIONS, doc, V20) == Invalid(
        Topic.INSTANT_ACTIONS, "$.timestamp", "required field missing", 7)


# --- refusing what is not valid ----------------------------------------------------------------------------


def sent(version: Version = V21) -> dict[str, Any]:
    doc: dict[str, Any] = orjson.loads(codec.encode(order(version=version), version))
    return doc


@pytest.mark.parametrize(("change", "path", "problem"), [
    (lambda d: d["nodes"][1].pop("released"), "$.nodes[1].released", "required field missing"),
    (lambda d: d["edges"][0].update(sequenceId=-1), "$.edges[0].sequenceId", "-1 is below the minimum 0"),
    (lambda d: d["nodes"][1]["actions"][0].update(blockingType="FIRM"), "$.nodes[1].actions[0].blockingType",
     '"FIRM" is not one of NONE, SOFT, HARD'),
    (lambda d: d.update(nodes={"a": 1}), "$.nodes", "expected array, got object"),
    (lambda d: d["nodes"][0]["nodePosition"].update(x="1"), "$.nodes[0].nodePosition.x", "expected number, got string"),
    (lambda d: d.update(orderUpdateId=1.5), "$.orderUpdateId", "expected integer, got number"),
], ids=["missing", "minimum", "enum", "type", "number", "integer"])
def test_an_invalid_order_names_the_offending_field(change: Any, path: str, problem: str) -> None:
    """§6.6.4.1: a malformed order is refused as a validationError naming the field by JSON path, with the
    ids a master matches it by (§7.1)."""
    doc = sent()
    change(doc)
    assert codec.decode(Topic.ORDER, orjson.dumps(doc), V21) == Invalid(Topic.ORDER, path, problem, 7, "o1", None
                                                                      if path == "$.orderUpdateId" else 0)


def test_whole_number_floats_are_integers_as_json_schema_says() -> None:
    doc = sent()
    doc["orderUpdateId"] = 3.0
    received = codec.decode(Topic.ORDER, doc, V21)
    assert isinstance(received, Order) and received.order_update_id == 3 and type(received.order_update_id) is int


@pytest.mark.parametrize("raw", [b"", b"{", b"[1, 2]", b'"order"', b"NaN", b'{"headerId": 1e999}'])
def test_what_is_not_a_json_object_is_refused_whole(raw: bytes) -> None:
    received = codec.decode(Topic.ORDER, raw, V21)
    assert isinstance(received, Invalid) and received.path == "$"


JSON = st.recursive(
    st.none() | st.booleans() | st.integers(-(2**63), 2**63 - 1) | st.floats(allow_nan=False, allow_infinity=False)
    | st.text(max_size=5),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.sampled_from(
        ["nodes", "edges", "orderId", "headerId", "actions", "sequenceId", "released", "x", "timestamp"]), inner,
        max_size=4),
    max_leaves=12)


@given(st.binary(max_size=40) | JSON.map(orjson.dumps))
def test_decoding_never_raises(raw: bytes) -> None:
    """docs/contract.md §11: an invalid message is refused, never a crash."""
    for topic in (Topic.ORDER, Topic.INSTANT_ACTIONS):
        for version in Version:
            result = codec.decode(topic, raw, version)
            assert isinstance(result, (Invalid, codec.MODELS[topic]))


def test_a_mutated_valid_order_is_invalid_or_still_an_order() -> None:
    doc = sent()
    doc["nodes"][0]["nodePosition"]["x"] = float("inf")
    received = codec.decode(Topic.ORDER, doc, V21)
    assert received == Invalid(Topic.ORDER, "$.nodes[0].nodePosition.x", "not a finite number", 7, "o1", 0)


# --- header ------------------------------------------------------------------------------------------------


@pytest.mark.parametrize(("now", "epoch", "expected"), [
    (0.0, None, "1970-01-01T00:00:00.00Z"),
    (1.239, None, "1970-01-01T00:00:01.23Z"),  # cut to hundredths: never an instant later than now
    (1.23, None, "1970-01-01T00:00:01.23Z"),  # 1.23 is 1.2299999999999999822 in binary: read to the µs
    (0.0099999999, None, "1970-01-01T00:00:00.01Z"),  # 9999.9999 µs is 10000 µs (R14's resolution)
    (3661.5, datetime(2024, 1, 1, tzinfo=UTC), "2024-01-01T01:01:01.50Z"),
    (86400.0, datetime(2024, 2, 28, 12, tzinfo=UTC), "2024-02-29T12:00:00.00Z"),  # a leap day
])
def test_timestamps_read_simulated_time_on_a_calendar(now: float, epoch: datetime | None, expected: str) -> None:
    """§6.4: YYYY-MM-DDTHH:mm:ss.ffZ, UTC (expected values worked out by hand)."""
    assert (timestamp(now) if epoch is None else timestamp(now, epoch)) == expected


def test_header_ids_count_per_topic() -> None:
    """§6.4: "The headerId is defined per topic and incremented by 1 with each sent message"."""
    stamper = Stamper(V20, "acme", "agv1")
    ids = [(topic, stamper.stamp(topic, 0.0).header_id) for topic in ("state", "state", "visualization", "state")]
    assert ids == [("state", 0), ("state", 1), ("visualization", 0), ("state", 2)]
    assert stamper.stamp("connection", 2.0) == Header(header_id=0, timestamp="1970-01-01T00:00:02.00Z",
                                                     version="2.0.0", manufacturer="acme", serial_number="agv1")
