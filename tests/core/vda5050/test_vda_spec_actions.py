"""Acceptance from the specification itself (issue 31 item 7): actions on nodes and edges, VDA 5050 2.1.0
§6.10.2 (traversal and triggering), §6.11 (action states) and §6.12 with Figure 17 ("Handling multiple
actions", handling_multiple_actions_UML.md).

Expected action states are written out by hand from the quoted sentences; ``seen()["actions"]`` maps
actionId to actionStatus, in the order the vehicle lists them.
"""

from __future__ import annotations

from collections.abc import Sequence

from vcran.core.vda5050.config import PREDEFINED, ActionSpec, VehicleConfig
from vcran.core.vda5050.effects import Act, Interrupt
from vcran.core.vda5050.enums import ActionScope
from vcran.testing.vda5050.harness import Bench
from vcran.testing.vda5050.plans import MANUFACTURER, SERIAL, action, order

A, B, C = ("a", 0, 0), ("b", 1, 0), ("c", 2, 0)
#: A vehicle that also performs "beep" and "lift", anywhere, with any blocking type, interruptible.
CONFIG = VehicleConfig(MANUFACTURER, SERIAL, actions=(
    *PREDEFINED, ActionSpec("beep", frozenset(ActionScope)), ActionSpec("lift", frozenset(ActionScope))))


def started(effects: Sequence[object]) -> list[str]:
    return [e.action_id for e in effects if isinstance(e, Act)]


def test_figure_17_multiple_actions_on_one_node() -> None:
    """Five actions on node b, in this order: n1 NONE, s1 SOFT, h1 HARD, n2 NONE, s2 SOFT.

    Figure 17: "parallel execution list = []; iterate over action list": NONE -> "Add action to parallel
    execution list"; SOFT -> "stop driving", add; HARD -> "stop driving", "Execute actions from parallel
    execution list", "Execute HARD action"; after the last: "Execute actions from parallel execution list",
    "Continue order handling". Table 3: "HARD: Action shall not be executed in parallel with other
    actions", "NONE: Action can be executed in parallel with other actions and while the vehicle is
    driving", "SOFT: ... Vehicle shall not drive"."""
    acts = [action("beep", "n1", "NONE"), action("lift", "s1", "SOFT"), action("beep", "h1", "HARD"),
            action("beep", "n2", "NONE"), action("lift", "s2", "SOFT")]
    bench = Bench(CONFIG)
    bench.order(order("o", 0, [A, B, C], node_actions={"b": acts}))
    # §6.11 WAITING: "the node where it triggers was not yet reached".
    assert bench.seen()["actions"] == dict.fromkeys(["n1", "s1", "h1", "n2", "s2"], "WAITING")
    assert [w.tag.node_id for w in bench.route] == ["b"]  # SOFT and HARD on b: the vehicle stops there
    # §6.10.2: "As soon as the AGV reports the node as traversed, the AGV shall trigger the actions".
    assert started(bench.reach()) == ["n1", "s1"]  # the first parallel list
    assert bench.seen()["actions"] == {"n1": "RUNNING", "s1": "RUNNING", "h1": "WAITING", "n2": "WAITING",
                                       "s2": "WAITING"}
    assert not bench.seen()["driving"] and not bench.route
    bench.finish("n1")
    assert bench.seen()["actions"]["h1"] == "WAITING"  # s1 still runs: HARD is not executed in parallel
    assert started(bench.finish("s1")) == ["h1"]
    assert bench.seen()["actions"] == {"n1": "FINISHED", "s1": "FINISHED", "h1": "RUNNING", "n2": "WAITING",
                                       "s2": "WAITING"}
    assert started(bench.finish("h1")) == ["n2", "s2"]  # the last parallel list, after the HARD action
    assert not bench.route  # s2 is SOFT: no driving yet
    bench.finish("s2")
    # "Continue order handling": only a NONE action runs, which may run while driving.
    assert [w.tag.node_id for w in bench.route] == ["c"] and bench.seen()["driving"]
    assert bench.seen()["actions"]["n2"] == "RUNNING"
    bench.finish("n2")
    bench.reach()
    assert bench.seen()["actions"] == dict.fromkeys(["n1", "s1", "h1", "n2", "s2"], "FINISHED")
    assert bench.seen()["nodes"] == [] and not bench.seen()["driving"]


def test_none_actions_do_not_stop_the_vehicle() -> None:
    """Table 3, NONE: "Action can be executed ... while the vehicle is driving": the route goes past b."""
    bench = Bench(CONFIG)
    bench.order(order("o", 0, [A, B, C], node_actions={"b": [action("beep", "n", "NONE")]}))
    assert [w.tag.node_id for w in bench.route] == ["b", "c"]
    assert started(bench.reach()) == ["n"]
    assert bench.seen()["driving"] and bench.seen()["actions"] == {"n": "RUNNING"}


def test_a_hard_action_waits_for_any_action_still_running() -> None:
    """"HARD: is the only allowed action at that time" (§6.6.6): a NONE action started at a and still running
    when the vehicle reaches b keeps b's HARD action waiting."""
    bench = Bench(CONFIG)
    bench.order(order("o", 0, [A, B], node_actions={"a": [action("beep", "n", "NONE")],
                                                    "b": [action("lift", "h", "HARD")]}))
    assert bench.seen()["actions"] == {"n": "RUNNING", "h": "WAITING"}
    assert started(bench.reach()) == []
    assert started(bench.finish("n")) == ["h"]


def test_edge_actions_run_while_the_vehicle_is_on_the_edge() -> None:
    """§6.10.2: "The traversal of the node also marks the moment, when the AGV enters the following edge ...
    The edge's actions shall now be triggered"; "The traversal of a node also marks the leaving of the edge
    leading up to the node ... the actions that were active on the edge shall be finished"; §6.6.6 edge
    actions: "When the AGV leaves the edge, the action will stop"."""
    bench = Bench(CONFIG)
    effects = bench.order(order("o", 0, [A, B, C], edge_actions={"b-c": [action("beep", "e", "NONE")]}))
    assert started(effects) == [] and bench.seen()["actions"] == {"e": "WAITING"}
    assert started(bench.reach()) == ["e"]  # b traversed: b-c entered
    assert bench.seen()["actions"] == {"e": "RUNNING"} and bench.seen()["driving"]
    effects = bench.reach()  # c traversed: b-c left
    assert Interrupt("e") in effects
    assert bench.seen()["actions"] == {"e": "FINISHED"} and bench.seen()["edges"] == []


def test_a_soft_edge_action_holds_the_vehicle_at_the_start_of_its_edge() -> None:
    """§6.10.2: "if the AGV has to pause on the edge (because of a soft or hard blocking edge, or otherwise)
    – then the AGV enters the edge after it begins moving again": the vehicle stands at b while the SOFT
    action of b-c runs, and drives b-c when it ends (docs/vda5050.md)."""
    bench = Bench(CONFIG)
    bench.order(order("o", 0, [A, B, C], edge_actions={"b-c": [action("lift", "s", "SOFT")]}))
    assert [w.tag.node_id for w in bench.route] == ["b"]
    assert started(bench.reach()) == ["s"]
    assert not bench.route and not bench.seen()["driving"]
    bench.finish("s")
    assert [w.tag.node_id for w in bench.route] == ["c"] and bench.seen()["driving"]


def test_horizon_actions_wait_and_are_replaced_with_the_horizon() -> None:
    """§6.8.1, pick: "the action could be announced in the horizon in advance. But ... are not reported as
    RUNNING in the AGV state, because the associated node is not released yet"; an update "clear[s] the
    horizon" (Figure 8), so its announced actions go with it and come back as the update says."""
    bench = Bench()
    bench.order(order("o", 0, [A, B, C], base=2, node_actions={"c": [action("pick", "p", "HARD")]}))
    bench.reach()
    assert bench.seen()["actions"] == {"p": "WAITING"} and not bench.route
    bench.order(order("o", 1, [B, C], start=2, node_actions={"c": [action("drop", "d", "SOFT")]}))
    assert bench.seen()["actions"] == {"d": "WAITING"}
    assert started(bench.reach()) == ["d"]


def test_a_failed_action_is_reported_and_the_order_goes_on() -> None:
    """§6.11 FAILED: "Action could not be finished for whatever reason"; §6.8.2 pick: "Failed pick operations
    should correspond with an error". The vehicle drives on: cancelling is the master's (docs/vda5050.md)."""
    bench = Bench()
    bench.order(order("o", 0, [A, B, C], node_actions={"b": [action("pick", "p", "HARD")]}))
    bench.reach()
    bench.finish("p", ok=False, message="no load at the station")
    assert bench.seen()["actions"] == {"p": "FAILED"} and bench.seen()["errors"] == ["actionFailed"]
    (error,) = bench.last.errors
    assert error.error_description == "no load at the station"
    assert {(r.reference_key, r.reference_value) for r in error.error_references or ()} == {
        ("actionId", "p"), ("actionType", "pick"), ("orderId", "o")}
    assert [w.tag.node_id for w in bench.route] == ["c"]
