"""Acceptance from the specification itself (issue 31 item 7): the order and order update process of
VDA 5050 2.1.0 §6.6.2 — Figures 4 to 7 (an order, its extension) and Figure 8 ("The process of accepting an
order or order update", process_order_update_UML.md), every branch (1) to (9).

Each expected state is written out by hand from the sentences quoted beside it, never from the code. The
compact view (``Bench.seen``): ``nodes`` and ``edges`` are the nodeStates and edgeStates, ``id`` +
sequenceId, ``?`` marking the horizon (released false).
"""

from __future__ import annotations

from vcran.core.vda5050.order import Order
from vcran.testing.vda5050.harness import Bench
from vcran.testing.vda5050.plans import action, order

# Figure 5 as positions on a line, one metre apart: f d g b h, then i.
F, D, G, B, H, I = ("f", 0, 0), ("d", 1, 0), ("g", 2, 0), ("b", 3, 0), ("h", 4, 0), ("i", 5, 0)


def figure5() -> Order:
    """Figure 5: orderId 1234, orderUpdateId 0; nodes f d g released, b h not; edges e1 e3 released, e8 e9
    not. sequenceIds: "first node of an order receives a 0, the first edge then gets the 1, the second
    node then gets the 2, and so on" (§6.6.2)."""
    return order("1234", 0, [F, D, G, B, H], base=3, edge_ids=["e1", "e3", "e8", "e9"])


def figure6(update_id: int = 1) -> Order:
    """Figure 6: the extension, orderUpdateId 1: g b h released, i not; e8 e9 released, e10 not. "Once a
    sequenceId is assigned, it does not change with order updates": g keeps 4."""
    return order("1234", update_id, [G, B, H, I], base=3, start=4, edge_ids=["e8", "e9", "e10"])


def test_figures_5_to_7_an_order_and_its_extension() -> None:
    bench = Bench()
    # Figure 8 (2) new, (3) not executing, (4) the vehicle stands on f: "accept order, set orderId and
    # orderUpdateId, populate states of new order (9)". The first node is where the vehicle stands: "the
    # AGV shall realize that this node shall be counted as traversed" (§6.6.3.1), so f is the last node
    # and the nodeStates are "all nodes/edges, that the AGV still shall traverse" (§6.10.1), horizon
    # included (Figure 8 (3): "Nodes and edges ... of the order horizon are also included inside the state").
    bench.order(figure5())
    assert bench.seen() == {"order": ("1234", 0), "last": ("f", 0), "nodes": ["d2", "g4", "b6?", "h8?"],
                            "edges": ["e1", "e3", "e8?", "e9?"], "actions": {}, "driving": True, "errors": []}
    # §6.10.2: "The AGV reports the traversal of a node by removing its nodeState from the nodeStates array
    # and setting the lastNodeId, lastNodeSequenceId to the traversed node's values. The traversal of a
    # node also marks the leaving of the edge leading up to the node. The edge shall then be removed".
    bench.reach()
    assert bench.seen()["last"] == ("d", 2)
    assert (bench.seen()["nodes"], bench.seen()["edges"]) == (["g4", "b6?", "h8?"], ["e3", "e8?", "e9?"])
    # Only the base is driven: "If a node or edge is not released, the AGV shall not traverse it" (§6.6.1).
    assert [w.tag.node_id for w in bench.route] == ["g"]
    # t = 3, Figure 6, while driving e3: (5) not deprecated, (6) not on the vehicle, (3) still executing,
    # (7) "Is the first node of the received order equal to the current decision point (last node of the
    # current base)?" g is: "clear horizon, if vehicle has one; accept order update; set orderUpdateId;
    # append states to the ones currently running/planned (9)".
    bench.order(figure6())
    assert bench.seen() == {"order": ("1234", 1), "last": ("d", 2), "nodes": ["g4", "b6", "h8", "i10?"],
                            "edges": ["e3", "e8", "e9", "e10?"], "actions": {}, "driving": True, "errors": []}
    # "The AGV shall stop at the decision point if no further nodes and edges are added to the base": h.
    for expected in (("g", 4), ("b", 6), ("h", 8)):
        bench.reach()
        assert bench.seen()["last"] == expected
    assert bench.seen() == {"order": ("1234", 1), "last": ("h", 8), "nodes": ["i10?"], "edges": ["e10?"],
                            "actions": {}, "driving": False, "errors": []}
    assert bench.route == []
    # At the end of the base with a horizon, the vehicle asks for more (§6.10.3, docs/vda5050.md).
    assert bench.last.new_base_request is True


def test_an_update_may_delete_the_horizon() -> None:
    """§6.6.2: "Master control has the option to make changes to the horizon by sending entirely different
    nodes as the new base. The horizon can also be deleted." An update of the decision point g alone
    stitches at g and adds nothing: the horizon b h goes, and the order ends at g."""
    bench = Bench()
    bench.order(figure5())
    bench.order(order("1234", 1, [G], start=4))
    assert bench.seen() == {"order": ("1234", 1), "last": ("f", 0), "nodes": ["d2", "g4"], "edges": ["e1", "e3"],
                            "actions": {}, "driving": True, "errors": []}
    bench.reach()
    bench.reach()
    assert bench.seen()["nodes"] == [] and bench.last.new_base_request is False


def test_6_a_resent_update_is_discarded() -> None:
    """Figure 8 (6) "is order update currently on vehicle? yes - vehicle already has received update ->
    discard message"; §6.6.4.3: "If the AGV receives an order with the same orderId and orderUpdateId
    twice, the second order will be ignored". The vehicle answers with a state (the master resent it
    because it missed one, §6.6.4.3), unchanged."""
    bench = Bench()
    bench.order(figure5())
    bench.reach()
    bench.order(figure6())
    before = bench.seen()
    published = len(bench.states)
    bench.order(figure6())
    assert len(bench.states) == published + 1
    assert bench.seen() == before


def test_5_an_older_update_is_refused_and_the_order_goes_on() -> None:
    """Figure 8 (5) "Is orderUpdateId smaller than the one currently on the vehicle?" -> reject;
    §6.6.4.3: "Vehicle keeps the previous order in its buffer. The vehicle reports the warning
    orderUpdateError. The vehicle continues with executing the previous order"."""
    bench = Bench()
    bench.order(figure5())
    bench.order(figure6(update_id=2))
    bench.order(figure6(update_id=1))
    assert bench.seen() == {"order": ("1234", 2), "last": ("f", 0), "nodes": ["d2", "g4", "b6", "h8", "i10?"],
                            "edges": ["e1", "e3", "e8", "e9", "e10?"], "actions": {}, "driving": True,
                            "errors": ["orderUpdateError"]}
    for _ in range(4):
        bench.reach()
    assert bench.seen()["last"] == ("h", 8)


def test_7_an_update_that_does_not_start_at_the_decision_point_is_refused() -> None:
    """Figure 8 (7): "the order update is only accepted if the first node of the new base is equal to the
    last node of the previous base". §6.6.2: "Since the base cannot be changed, a retransmission of nodes
    f and d is not valid": an update starting at d is refused, the order unchanged."""
    bench = Bench()
    bench.order(figure5())
    resent = order("1234", 1, [D, G, B, H], base=4, start=2, edge_ids=["e3", "e8", "e9"])
    bench.order(resent)
    assert bench.seen() == {"order": ("1234", 0), "last": ("f", 0), "nodes": ["d2", "g4", "b6?", "h8?"],
                            "edges": ["e1", "e3", "e8?", "e9?"], "actions": {}, "driving": True,
                            "errors": ["orderUpdateError"]}


def test_7_the_decision_point_is_matched_by_sequence_id_too() -> None:
    """§6.6.2: "The AGV can always check that the last known base node has the same nodeId (and
    nodeSequenceId, more on that later) as the first new base node": g with another sequenceId is not g."""
    bench = Bench()
    bench.order(figure5())
    bench.order(order("1234", 1, [G, B], start=6, edge_ids=["e8"]))
    assert bench.seen()["errors"] == ["orderUpdateError"]
    assert bench.seen()["order"] == ("1234", 0)


def test_8_an_update_continues_a_completed_order_from_its_last_node() -> None:
    """Figure 8 (8): the vehicle "has completed its base with all related actions and does not have a
    horizon": "The order update is now accepted if it continues from the last traversed node, therefore the
    first node of the new base needs to match the vehicle's lastNodeId as well as lastNodeSequenceId" —
    then "accept order update, set orderUpdateId, populate newly added states (9)"."""
    bench = Bench()
    bench.order(order("7", 0, [F, D]))
    bench.reach()
    assert bench.seen() == {"order": ("7", 0), "last": ("d", 2), "nodes": [], "edges": [], "actions": {},
                            "driving": False, "errors": []}
    bench.order(order("7", 1, [F, G], start=0))  # f, sequenceId 0: not the last node
    assert bench.seen()["errors"] == ["orderUpdateError"] and bench.seen()["order"] == ("7", 0)
    bench.order(order("7", 2, [D, G], start=2))
    assert bench.seen() == {"order": ("7", 2), "last": ("d", 2), "nodes": ["g4"], "edges": ["d-g"], "actions": {},
                            "driving": True, "errors": []}  # an accepted order clears the refusal (§6.6.4.3)


def test_3_a_new_order_is_refused_while_the_vehicle_executes_or_waits() -> None:
    """Figure 8 (3) "is vehicle still executing an order or waiting for an update?": "Are nodeStates not
    empty ...? Vehicle might still have a horizon and therefore waiting for an update" -> reject. The order
    at the end of its base, waiting with a horizon, is still the vehicle's."""
    bench = Bench()
    bench.order(figure5())
    bench.order(order("other", 0, [F, D]))
    assert bench.seen()["errors"] == ["orderError"] and bench.seen()["order"] == ("1234", 0)
    bench.reach()
    bench.reach()
    assert bench.seen()["nodes"] == ["b6?", "h8?"] and not bench.route  # waiting at g for an update
    bench.order(order("other", 0, [G, D]))
    assert bench.seen()["order"] == ("1234", 0)
    assert bench.seen()["errors"] == ["orderError"]


def test_3_running_actions_of_the_order_count_as_executing() -> None:
    """Figure 8 (3): "... or are actionStates containing states which are neither FAILED nor FINISHED?"."""
    bench = Bench()
    bench.order(order("1", 0, [F], node_actions={"f": [action("pick", "p", "HARD")]}))
    assert bench.seen()["nodes"] == [] and bench.seen()["actions"] == {"p": "RUNNING"}
    bench.order(order("2", 0, [F, D]))
    assert bench.seen()["order"] == ("1", 0) and bench.seen()["errors"] == ["orderError"]
    bench.finish("p")
    bench.order(order("2", 0, [F, D]))
    # "delete states of previous order": the pick's actionState goes with order 1 (§6.10.6: "Action states,
    # except for running instant actions, are removed upon receiving a new order").
    assert bench.seen() == {"order": ("2", 0), "last": ("f", 0), "nodes": ["d2"], "edges": ["f-d"], "actions": {},
                            "driving": True, "errors": []}


def test_4_a_new_order_must_start_where_the_vehicle_is() -> None:
    """Figure 8 (4) "Is the vehicle already standing on the node, or is it in the node's deviation range?";
    §6.6.1: "The first node of an order shall be trivially reachable for the AGV"."""
    bench = Bench(x=0.5, y=0.0)
    bench.order(order("1", 0, [F, D]))  # f is 0.5 m away, beyond the vehicle's tolerance (5 cm)
    assert bench.seen() == {"order": ("", 0), "last": ("", 0), "nodes": [], "edges": [], "actions": {},
                            "driving": False, "errors": ["orderError"]}
    bench.order(order("1", 0, [F, D], deviation=0.6))  # "If the AGV passes a node within the deviation radius"
    assert bench.seen()["order"] == ("1", 0) and bench.seen()["last"] == ("f", 0)
    assert bench.seen()["errors"] == []


def test_1_an_order_that_is_not_valid_is_refused_whole() -> None:
    """Figure 8 (1) "All formatting and JSON data types are correct?" -> reject order, throw error."""
    bench = Bench()
    bench.order(b'{"headerId": 3, "orderId": "1", "nodes": []}')
    assert bench.seen() == {"order": ("", 0), "last": ("", 0), "nodes": [], "edges": [], "actions": {},
                            "driving": False, "errors": ["validationError"]}
    (error,) = bench.last.errors
    assert error.error_description == "$.timestamp: required field missing"
