"""Acceptance from the specification itself (issue 31 item 7): every case of order rejection, VDA 5050
2.1.0 §6.6.4, with its resolution as the text lists it.

§6.6.4.1 malformed order: "1. Vehicle does NOT take over the new order in its internal buffer. 2. The
vehicle reports the warning validationError 3. The warning shall be reported until the vehicle has
accepted a new order." §6.6.4.2 actions it cannot perform, fields it cannot use: the same, with
"orderError with the wrong fields as error references". §6.6.4.3 a lower orderUpdateId: "orderUpdateError",
the previous order kept and executed.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import orjson
import pytest

from vcran.core.vda5050 import codec
from vcran.core.vda5050.enums import OrientationType, Version
from vcran.core.vda5050.order import ControlPoint, Corridor, Order, Trajectory
from vcran.testing.vda5050.harness import Bench
from vcran.testing.vda5050.plans import action, order

A, B, C = ("a", 0, 0), ("b", 1, 0), ("c", 2, 0)
IDLE = {"order": ("", 0), "last": ("", 0), "nodes": [], "edges": [], "actions": {}, "driving": False}


def good() -> Order:
    return order("o", 0, [A, B, C], header_id=5)


def edit(o: Order, *, node: int | None = None, edge: int | None = None, **fields: Any) -> Order:
    if node is not None:
        return replace(o, nodes=tuple(replace(n, **fields) if i == node else n for i, n in enumerate(o.nodes)))
    if edge is not None:
        return replace(o, edges=tuple(replace(e, **fields) if i == edge else e for i, e in enumerate(o.edges)))
    return replace(o, **fields)


def references(bench: Bench) -> dict[str, str]:
    (error,) = bench.last.errors
    return {r.reference_key: r.reference_value for r in error.error_references or ()}


def refused_then_accepted(bench: Bench, bad: Order | bytes, error_type: str) -> None:
    """Nothing of ``bad`` is taken over, the warning stays until an order is accepted, then goes."""
    bench.order(bad)
    assert bench.seen() == {**IDLE, "errors": [error_type]}
    bench.call("on_timer", "state")  # later states still carry it
    bench.now = 30.0
    bench.at(30.0)
    assert bench.seen()["errors"] == [error_type]
    bench.order(good())
    assert bench.seen()["order"] == ("o", 0) and bench.seen()["errors"] == []


# --- §6.6.4.1 ----------------------------------------------------------------------------------------------

MALFORMED_JSON = [
    ("not JSON", b"{", "$"),
    ("a required field", orjson.dumps({k: v for k, v in codec.to_plain(good(), Version.V2_1_0).items()
                                       if k != "orderUpdateId"}), "$.orderUpdateId"),
    ("a data type", orjson.dumps({**codec.to_plain(good(), Version.V2_1_0), "nodes": "a,b,c"}), "$.nodes"),
]


@pytest.mark.parametrize(("raw", "field"), [(raw, field) for _, raw, field in MALFORMED_JSON],
                         ids=[name for name, _, _ in MALFORMED_JSON])
def test_6_6_4_1_formatting_and_data_types(raw: bytes, field: str) -> None:
    """Figure 8 (1): "All formatting and JSON data types are correct?"."""
    bench = Bench()
    refused_then_accepted(bench, raw, "validationError")
    bench2 = Bench()
    bench2.order(raw)
    assert references(bench2)["field"] == field and references(bench2)["topic"] == "order"


MALFORMED_GRAPH = [
    ("no node", replace(good(), nodes=(), edges=()), "$.nodes"),
    ("edges for nodes", replace(good(), edges=good().edges[:1]), "$.edges"),
    ("a node's sequenceId", edit(good(), node=1, sequence_id=3), "$.nodes[1].sequenceId"),
    ("an edge's sequenceId", edit(good(), edge=1, sequence_id=4), "$.edges[1].sequenceId"),
    ("an edge's start", edit(good(), edge=1, start_node_id="a"), "$.edges[1].startNodeId"),
    ("an edge's end", edit(good(), edge=0, end_node_id="c"), "$.edges[0].endNodeId"),
    ("the first node unreleased", order("o", 0, [A, B, C], base=0), "$.nodes[0].released"),
    ("a released edge to an unreleased node", edit(order("o", 0, [A, B, C], base=2), edge=1, released=True),
     "$.edges[1].released"),
    ("a released node after the horizon", edit(order("o", 0, [A, B, C], base=1), node=2, released=True),
     "$.nodes[2].released"),
    ("an actionId twice", order("o", 0, [A, B], node_actions={"a": [action("pick", "p")],
                                                              "b": [action("drop", "p")]}),
     "$.nodes[1].actions[0].actionId"),
]


@pytest.mark.parametrize(("bad", "field"), [(bad, field) for _, bad, field in MALFORMED_GRAPH],
                         ids=[name for name, _, _ in MALFORMED_GRAPH])
def test_6_6_4_1_graph_rules_of_6_6_1(bad: Order, field: str) -> None:
    """§6.6.1: "For a valid order, there shall be at least one node and the number of edges shall be equal to
    the number of nodes minus one"; "An edge can be released only if both the start and the end node of the
    edge are released"; "After an unreleased edge, no released nodes or edges can follow in the sequence";
    §6.6.2: the sequenceId "runs over the nodes and edges"; §6.6.6: actionId "Unique ID"."""
    bench = Bench()
    refused_then_accepted(bench, bad, "validationError")
    bench2 = Bench()
    bench2.order(bad)
    assert references(bench2) == {"topic": "order", "headerId": str(bad.header.header_id), "orderId": "o",
                                  "orderUpdateId": "0", "field": field}


def test_6_6_4_1_malformed_instant_actions() -> None:
    bench = Bench()
    bench.instant(b'{"headerId": 1}')
    assert bench.seen()["errors"] == ["validationError"]
    assert references(bench) == {"topic": "instantActions", "headerId": "1", "field": "$.timestamp"}


# --- §6.6.4.2 ----------------------------------------------------------------------------------------------

CURVE = Trajectory(degree=1, knot_vector=(0.0, 0.0, 1.0, 1.0),
                   control_points=(ControlPoint(x=0.0, y=0.0), ControlPoint(x=1.0, y=0.0)))
UNUSABLE = [
    ("an unknown action", order("o", 0, [A, B], node_actions={"b": [action("detectObject", "x")]}),
     {"nodeId": "b", "actionId": "x", "actionType": "detectObject"}),
    ("an action where it cannot run", order("o", 0, [A, B], edge_actions={"a-b": [action("pick", "x")]}),
     {"edgeId": "a-b", "actionId": "x", "actionType": "pick"}),
    ("a blocking type it cannot honour", order("o", 0, [A, B], node_actions={"b": [action("pick", "x", "NONE")]}),
     {"nodeId": "b", "actionId": "x", "actionType": "pick", "blockingType": "NONE"}),
    ("a missing parameter", order("o", 0, [A, B], node_actions={"b": [action("waitForTrigger", "x")]}),
     {"nodeId": "b", "actionId": "x", "actionType": "waitForTrigger", "parameter": "triggerType"}),
    ("a trajectory", edit(good(), edge=0, trajectory=CURVE), {"edgeId": "a-b", "field": "trajectory"}),
    ("a corridor", edit(good(), edge=1, corridor=Corridor(left_width=0.5, right_width=0.5)),
     {"edgeId": "b-c", "field": "corridor"}),
    ("an orientation", edit(good(), edge=0, orientation=1.0, orientation_type=OrientationType.TANGENTIAL),
     {"edgeId": "a-b", "field": "orientation"}),
    ("a map it does not have", order("o", 0, [A, B], map_id="hall2"), {"nodeId": "a", "mapId": "hall2"}),
    ("a node without a position", edit(good(), node=2, node_position=None), {"nodeId": "c"}),
    ("a speed it cannot drive", edit(good(), edge=0, max_speed=0.0), {"edgeId": "a-b", "field": "maxSpeed"}),
]


@pytest.mark.parametrize(("bad", "fields"), [(bad, fields) for _, bad, fields in UNUSABLE],
                         ids=[name for name, _, _ in UNUSABLE])
def test_6_6_4_2_actions_it_cannot_perform_and_fields_it_cannot_use(bad: Order, fields: dict[str, str]) -> None:
    """§6.6.4.2: "Non-executable actions ... Non-useable fields: trajectory, etc." -> "orderError with the
    wrong fields as error references"; §6.1.1: "If the AGV cannot process the message accordingly then the
    expected behavior is to communicate this within an error message and to reject the order"."""
    bench = Bench()
    refused_then_accepted(bench, bad, "orderError")
    bench2 = Bench()
    bench2.order(bad)
    assert references(bench2) == {"topic": "order", "headerId": str(bad.header.header_id), "orderId": "o",
                                  "orderUpdateId": "0", **fields}


# --- §6.6.4.3 ----------------------------------------------------------------------------------------------


def test_6_6_4_3_a_lower_order_update_id() -> None:
    """"1. Vehicle does NOT take over the new order in its internal buffer. 2. Vehicle keeps the previous
    order in its buffer. 3. The vehicle reports the warning orderUpdateError 4. The vehicle continues with
    executing the previous order." — and "If the AGV receives an order with the same orderId and
    orderUpdateId twice, the second order will be ignored"."""
    bench = Bench()
    bench.order(order("o", 3, [A, B, C], base=2))
    bench.order(order("o", 2, [B, C], start=2))
    assert bench.seen() == {"order": ("o", 3), "last": ("a", 0), "nodes": ["b2", "c4?"], "edges": ["a-b", "b-c?"],
                            "actions": {}, "driving": True, "errors": ["orderUpdateError"]}
    assert references(bench) == {"topic": "order", "headerId": "0", "orderId": "o", "orderUpdateId": "2"}
    bench.order(order("o", 3, [A, B, C], base=3))  # the same update again: ignored, not an error
    assert bench.seen()["nodes"] == ["b2", "c4?"] and bench.seen()["errors"] == ["orderUpdateError"]
    bench.reach()
    assert bench.seen()["last"] == ("b", 2)
