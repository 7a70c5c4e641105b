"""Acceptance from the specification itself (issue 31 item 7): order cancellation, VDA 5050 2.1.0 §6.6.3
and Figure 9 ("Expected behavior after a cancelOrder", process_cancel_order_UML.md), both branches, with
§6.6.3.1 (a new order after a cancel) and §6.6.3.2 (no order to cancel).

Expected states are written out from the quoted sentences (``Bench.seen``: nodes and edges are the
nodeStates and edgeStates, ``?`` marks the horizon).
"""

from __future__ import annotations

from vcran.core.vda5050.config import VehicleConfig
from vcran.core.vda5050.effects import Abandon, Interrupt, StopAfterLeg, StopNow
from vcran.testing.vda5050.harness import Bench
from vcran.testing.vda5050.plans import MANUFACTURER, SERIAL, action, cancel, instant, order, pause, resume

A, B, C, D = ("a", 0, 0), ("b", 1, 0), ("c", 2, 0), ("d", 3, 0)


def driving_to_b(config: VehicleConfig | None = None) -> Bench:
    """A vehicle on edge a-b (it left a a moment ago), base a b c, horizon d; a HARD pick waits at c."""
    bench = Bench(config)
    bench.order(order("o", 0, [A, B, C, D], base=3, node_actions={"c": [action("pick", "pc", "HARD")]}))
    bench.now = 1.0
    return bench


def test_figure_9_a_vehicle_that_cannot_stop_between_nodes() -> None:
    bench = driving_to_b()
    effects = bench.instant(cancel("x"))
    # "AGV receives instantAction cancelOrder. Action is added to actionStates. Waiting actions are set to
    # FAILED." — "Can vehicle stop in between nodes? no: AGV drives to next node where it should be able to
    # receive a new order. cancelOrder action state is set to RUNNING. The nodeState for the node the AGV is
    # driving to is kept. All other nodeStates and edgeStates are deleted."
    assert bench.seen() == {"order": ("o", 0), "last": ("a", 0), "nodes": ["b2"], "edges": [],
                            "actions": {"pc": "FAILED", "x": "RUNNING"}, "driving": True, "errors": []}
    assert StopAfterLeg() in effects  # the running leg is finished, nothing after it is driven
    bench.now = 2.0
    bench.reach()
    # "AGV arrives at the node where it stops. lastNodeId and lastNodeSequenceId must be updated
    # accordingly." — "All nodeStates and edgeStates are deleted. actionStates are kept. cancelOrder action
    # state is set to FINISHED." §6.6.3: "The orderId and orderUpdateId are kept."
    assert bench.seen() == {"order": ("o", 0), "last": ("b", 2), "nodes": [], "edges": [],
                            "actions": {"pc": "FAILED", "x": "FINISHED"}, "driving": False, "errors": []}
    assert bench.route == []


def test_figure_9_holds_for_a_hard_cancel_too() -> None:
    """A master may send cancelOrder SOFT or HARD (vda-5050-lib's examples send their instant actions HARD).
    §6.12's HARD ("driving is not allowed") cannot keep a vehicle that stops only on nodes from the drive
    Figure 9 gives it ("AGV drives to next node"): the cancel would never be FINISHED. So a cancel's
    blocking type holds nothing, and the states are those of the NONE cancel above."""
    bench = driving_to_b()
    bench.instant(instant(action("cancelOrder", "x", "HARD")))
    assert bench.seen() == {"order": ("o", 0), "last": ("a", 0), "nodes": ["b2"], "edges": [],
                            "actions": {"pc": "FAILED", "x": "RUNNING"}, "driving": True, "errors": []}
    assert bench.holds == set()
    bench.now = 2.0
    bench.reach()
    assert bench.seen() == {"order": ("o", 0), "last": ("b", 2), "nodes": [], "edges": [],
                            "actions": {"pc": "FAILED", "x": "FINISHED"}, "driving": False, "errors": []}


def test_figure_9_a_vehicle_that_can_stop_between_nodes() -> None:
    bench = driving_to_b(VehicleConfig(MANUFACTURER, SERIAL, stop_between_nodes=True))
    effects = bench.instant(cancel("x"))
    # "Can vehicle stop in between nodes? yes: AGV stops." — "All nodeStates and edgeStates are deleted.
    # actionStates are kept. cancelOrder action state is set to FINISHED." The last node stays a.
    assert StopNow() in effects
    assert bench.seen() == {"order": ("o", 0), "last": ("a", 0), "nodes": [], "edges": [],
                            "actions": {"pc": "FAILED", "x": "FINISHED"}, "driving": False, "errors": []}


def test_figure_9_interruptible_running_actions_fail_at_once() -> None:
    """"Can running actions be interrupted? yes: Interrupt actions, set their state to FAILED"."""
    bench = Bench()
    bench.order(order("o", 0, [A, B], node_actions={"a": [action("waitForTrigger", "w", "HARD", triggerType="button")]}))
    assert bench.seen()["actions"] == {"w": "RUNNING"} and not bench.route  # HARD: the vehicle waits at a
    effects = bench.instant(cancel("x"))
    assert Interrupt("w") in effects
    # Standing on a, nothing left running: everything ends at once.
    assert bench.seen() == {"order": ("o", 0), "last": ("a", 0), "nodes": [], "edges": [],
                            "actions": {"w": "FAILED", "x": "FINISHED"}, "driving": False, "errors": []}


def test_figure_9_actions_that_cannot_be_interrupted_run_to_their_end() -> None:
    """"no: Finish the actions and report their respective state (RUNNING, FAILED, FINISHED)"; §6.6.3:
    "While actions are running, the cancelOrder action shall report RUNNING, until all actions are
    cancelled/finished"."""
    bench = Bench()
    bench.order(order("o", 0, [A, B], node_actions={"a": [action("pick", "p", "HARD")]}))
    bench.instant(cancel("x"))
    assert bench.seen() == {"order": ("o", 0), "last": ("a", 0), "nodes": [], "edges": [],
                            "actions": {"p": "RUNNING", "x": "RUNNING"}, "driving": False, "errors": []}
    bench.now = 4.0
    bench.finish("p")
    assert bench.seen()["actions"] == {"p": "FINISHED", "x": "FINISHED"}
    assert bench.route == []  # the order's b is never driven to


def test_a_cancel_at_the_instant_a_leg_begins_stops_the_vehicle_on_its_node() -> None:
    """A vehicle that "should be able to receive a new order" on a node and is still on one (its leg began at
    this very instant, R14's reading of instants) does not drive another edge first."""
    bench = Bench()
    bench.order(order("o", 0, [A, B]))
    effects = bench.instant(cancel("x"))
    assert Abandon() in effects
    assert bench.seen() == {"order": ("o", 0), "last": ("a", 0), "nodes": [], "edges": [],
                            "actions": {"x": "FINISHED"}, "driving": False, "errors": []}


def test_6_6_3_1_a_new_order_after_a_cancel_starts_where_the_vehicle_stands() -> None:
    """§6.6.3.1: "After the cancellation of an order, the vehicle shall be in a state to receive a new
    order." For a vehicle that stops between nodes, both options are accepted: "the first node is a
    temporary node that is positioned where the AGV currently stands" and "the first node is the last
    traversed node of the previous order but set the deviation range so large that the AGV is within this
    range"."""
    for first in [("here", 0.4, 0.0), ("a", 0, 0)]:
        bench = driving_to_b(VehicleConfig(MANUFACTURER, SERIAL, stop_between_nodes=True))
        bench.x = 0.4  # where the vehicle stopped on a-b
        bench.instant(cancel("x"))
        bench.order(order("next", 0, [first, C], deviation=0.5))
        assert bench.seen() == {"order": ("next", 0), "last": (first[0], 0), "nodes": ["c2"],
                                "edges": [f"{first[0]}-c"], "actions": {}, "driving": True, "errors": []}


def test_6_6_3_2_cancel_without_an_order() -> None:
    """§6.6.3.2: "If the AGV receives a cancelOrder action but, the AGV currently has no order, or the
    previous order was canceled, the cancelOrder action shall be reported as FAILED. The AGV shall report a
    noOrderToCancel error with the errorLevel set to WARNING. The actionId of the instantAction shall be
    passed as an errorReference"."""
    bench = Bench()
    bench.instant(cancel("x1"))
    assert bench.seen()["actions"] == {"x1": "FAILED"} and bench.seen()["errors"] == ["noOrderToCancel"]
    (error,) = bench.last.errors
    assert error.error_level.value == "WARNING"
    assert [(r.reference_key, r.reference_value) for r in error.error_references or ()] == [("actionId", "x1")]
    bench.order(order("o", 0, [A]))  # a one-node order, done at once
    bench.order(order("o2", 0, [A, B]))
    bench.instant(cancel("x2"))
    bench.instant(cancel("x3"))  # "the previous order was canceled"
    assert bench.seen()["actions"] == {"x2": "FINISHED", "x3": "FAILED"}
    assert bench.seen()["errors"] == ["noOrderToCancel"]


def test_a_cancel_while_driving_to_the_next_node_refuses_new_orders_until_it_stands() -> None:
    """Figure 8 (3) while the cancel runs: the nodeState of the node the vehicle drives to is kept, so the
    vehicle is still executing and a new order is refused; once it stands, one is accepted there."""
    bench = driving_to_b()
    bench.instant(cancel("x"))
    bench.order(order("next", 0, [B, C]))
    assert bench.seen()["errors"] == ["orderError"] and bench.seen()["order"] == ("o", 0)
    bench.reach()
    bench.order(order("next", 0, [B, C]))
    assert bench.seen()["order"] == ("next", 0) and bench.seen()["errors"] == []


def test_cancel_while_paused_finishes_once_the_vehicle_reaches_the_node() -> None:
    """Paused on an edge (§6.8.1 startPause: "reaching next node is not necessary"), a vehicle that cannot
    stop between nodes stays on its way to the next node: cancelOrder RUNNING until it gets there after
    stopPause."""
    bench = driving_to_b()
    bench.instant(pause("p"))
    bench.instant(cancel("x"))
    assert bench.seen()["actions"]["x"] == "RUNNING" and bench.holds == {"pause"}
    bench.instant(resume("r"))
    bench.reach()
    assert bench.seen()["actions"] == {"pc": "FAILED", "p": "FINISHED", "x": "FINISHED", "r": "FINISHED"}
    assert bench.seen()["last"] == ("b", 2)
