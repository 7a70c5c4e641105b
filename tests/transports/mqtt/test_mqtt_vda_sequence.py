"""The third-party master's sequence, written again by hand (issue 31, "Must show": "test the same sequence
yourself"): the test's own paho client, not vcran's code, sends VDA 5050 2.0.0 JSON to vcran's 2.0.0
vehicle over Mosquitto: an order, an order update, a stale orderUpdateId, startPause/stopPause, cancelOrder,
and a cancelOrder with nothing left to cancel.

Each expected state is written out from the VDA 5050 2.1.0 text (quoted) and, where the text leaves the
vehicle a choice, from the choice docs/vda5050.md documents for vcran (named). Nodes and edges are
``id/sequenceId``, ``?`` marking the horizon (unreleased).

vcran's vehicle is ``vcran live SCENARIO --mqtt URL`` as its own process (the ``live_fleet`` fixture), one 2.0.0
vehicle standing at (0, 0) facing +x with free floor ahead (support.vehicle_scenario): 1 m/s at most, so
positions are where it stopped, never a time.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import orjson
import pytest
from jsonschema import Draft202012Validator

from tests.transports.mqtt.support import Watcher, vehicle_scenario, wait_until

pytestmark = pytest.mark.slow

MANUFACTURER, SERIAL, MAP = "vcran", "paho-1", "map"
TOPIC = f"uagv/v2/{MANUFACTURER}/{SERIAL}"
STATE_SCHEMA = json.loads((Path(__file__).parents[3] / "vcran/core/vda5050/schemas/2.0.0/state.schema").read_text())


class Master:
    """A VDA 5050 2.0.0 master in a few lines of paho: headers counted per topic (§6.4), states kept."""

    def __init__(self, url: str) -> None:
        self.watcher = Watcher(url, (f"{TOPIC}/state",))
        self.header_ids = {"order": 0, "instantActions": 0}

    def states(self) -> list[dict[str, Any]]:
        return [orjson.loads(seen.payload) for seen in self.watcher.of("state")]

    def send(self, topic: str, body: dict[str, Any]) -> None:
        header = {"headerId": self.header_ids[topic], "timestamp": "2026-11-27T18:00:00.00Z", "version": "2.0.0",
                  "manufacturer": MANUFACTURER, "serialNumber": SERIAL}
        self.header_ids[topic] += 1
        self.watcher.publish(f"{TOPIC}/{topic}", orjson.dumps(header | body))

    def order(self, order_id: str, update: int, nodes: list[tuple[str, int, float]], released: int) -> None:
        """Nodes ``(id, sequenceId, x)`` on y = 0; the first ``released`` nodes (and the edges between them)
        are the base."""
        self.send("order", {
            "orderId": order_id, "orderUpdateId": update,
            "nodes": [{"nodeId": n, "sequenceId": s, "released": i < released, "actions": [],
                       "nodePosition": {"x": x, "y": 0.0, "mapId": MAP}} for i, (n, s, x) in enumerate(nodes)],
            "edges": [{"edgeId": f"{a}-{b}", "sequenceId": s - 1, "released": i + 1 < released, "startNodeId": a,
                       "endNodeId": b, "actions": []}
                      for i, ((a, _, _), (b, s, _)) in enumerate(zip(nodes, nodes[1:], strict=False))],
        })

    def instant(self, action_type: str, action_id: str) -> None:
        self.send("instantActions", {"actions": [
            {"actionId": action_id, "actionType": action_type, "blockingType": "NONE"}]})

    def answer(self, act: Callable[[], None], until: Callable[[dict[str, Any]], bool]) -> dict[str, Any]:
        """Do ``act()``, then wait for the first state after it that shows its effect (``until``): a state
        published meanwhile for something else (the vehicle's start, a node reached) is not the answer."""
        before = len(self.watcher.of("state"))

        def found() -> dict[str, Any] | None:
            return next((state for state in self.states()[before:] if until(state)), None)

        act()
        assert wait_until(found), f"no such state after the step: {self.states()[before:]}"
        state = found()
        assert state is not None
        return state


def has(action_id: str) -> Callable[[dict[str, Any]], bool]:
    return lambda state: any(a["actionId"] == action_id for a in state["actionStates"])


def at(node_id: str) -> Callable[[dict[str, Any]], bool]:
    return lambda state: state["lastNodeId"] == node_id


def of(order_id: str, update: int) -> Callable[[dict[str, Any]], bool]:
    return lambda state: (state["orderId"], state["orderUpdateId"]) == (order_id, update)


def seen(state: dict[str, Any]) -> dict[str, Any]:
    return {
        "order": (state["orderId"], state["orderUpdateId"]),
        "last": (state["lastNodeId"], state["lastNodeSequenceId"]),
        "nodes": [f"{n['nodeId']}/{n['sequenceId']}{'' if n['released'] else '?'}" for n in state["nodeStates"]],
        "edges": [f"{e['edgeId']}/{e['sequenceId']}{'' if e['released'] else '?'}" for e in state["edgeStates"]],
        "driving": state["driving"], "paused": state.get("paused", False),
        "actions": {a["actionId"]: a["actionStatus"] for a in state["actionStates"]},
        "errors": [(e["errorType"], e["errorLevel"], {r["referenceKey"]: r["referenceValue"]
                                                      for r in e.get("errorReferences", [])})
                   for e in state["errors"]],
    }


@pytest.fixture
def vehicle(broker, live_fleet, tmp_path) -> str:
    """vcran's 2.0.0 vehicle (map "map", the vehicle's default), retained ONLINE on ``broker``."""
    live_fleet(broker.url, vehicle_scenario(tmp_path, SERIAL, version="2.0.0", manufacturer=MANUFACTURER), TOPIC,
               factor=2.0)
    return broker.url


def test_the_issues_sequence_by_hand_against_vcrans_2_0_0_vehicle(vehicle):
    master = Master(vehicle)
    try:
        drive(master)
        states = master.states()
    finally:
        master.watcher.close()
    validator = Draft202012Validator(STATE_SCHEMA)
    for state in states:
        assert not [e.message for e in validator.iter_errors(state)], state
        assert state["version"] == "2.0.0"
    header_ids = [state["headerId"] for state in states]
    assert header_ids == sorted(set(header_ids))  # §6.4: "incremented by 1 with each sent message"


def drive(master: Master) -> None:
    # §6.10: states come on events and at least every 30 s; stateRequest (§6.8.1) asks for one now. No order
    # yet: lastNodeId "" ("Empty string, if no lastNodeId is available", §6.10.6), nothing else.
    state = master.answer(lambda: master.instant("stateRequest", "ask"), has("ask"))
    assert seen(state) == {"order": ("", 0), "last": ("", 0), "nodes": [], "edges": [], "driving": False,
                           "paused": False, "actions": {"ask": "FINISHED"}, "errors": []}

    # §6.6.2 and Figure 8 (1)-(4): a new order whose first node is where the vehicle stands is accepted. vcran
    # counts that node as traversed at once (docs/vda5050.md, "The first node of a new order"; §6.6.3.1:
    # "this node shall be counted as traversed"), and drives the base; §6.10.6: "Action states, except for
    # running instant actions, are removed upon receiving a new order".
    o1 = [("start", 0, 0.0), ("n1", 2, 2.0), ("n2", 4, 4.0)]
    state = master.answer(lambda: master.order("o1", 0, o1, released=2), of("o1", 0))
    assert seen(state) == {"order": ("o1", 0), "last": ("start", 0), "nodes": ["n1/2", "n2/4?"],
                           "edges": ["start-n1/1", "n1-n2/3?"], "driving": True, "paused": False, "actions": {},
                           "errors": []}

    # The base ends on n1: the vehicle stops there, the horizon stays ("waiting for an update", Figure 8 (3)),
    # and it asks for more base (§6.10.3; vcran: while at most one released edge is left to drive).
    state = master.answer(lambda: None, at("n1"))
    at_n1 = {"order": ("o1", 0), "last": ("n1", 2), "nodes": ["n2/4?"], "edges": ["n1-n2/3?"], "driving": False,
             "paused": False, "actions": {}, "errors": []}
    assert seen(state) == at_n1 and state["newBaseRequest"] is True

    # §6.8.1/§6.8.2 startPause: "No more AGV driving movements", FINISHED when "The AGV reports .paused:
    # true" (an instant transition); "Order is resumable". The vehicle now stands whatever it is sent.
    paused = master.answer(lambda: master.instant("startPause", "p"), has("p"))
    assert seen(paused) == at_n1 | {"paused": True, "actions": {"p": "FINISHED"}}

    # Figure 8 (7): the update's first node is the decision point n1 (sequenceId 2): accepted, n2 and n3
    # released; the sequenceIds stay those of the order (§6.6.2: "Once a sequenceId is assigned, it does
    # not change with order updates"). An update is no new order: the finished startPause stays (§6.10.6).
    # Paused, the vehicle does not drive them.
    o1_1 = [("n1", 2, 2.0), ("n2", 4, 4.0), ("n3", 6, 6.0)]
    updated = {"order": ("o1", 1), "last": ("n1", 2), "nodes": ["n2/4", "n3/6"], "edges": ["n1-n2/3", "n2-n3/5"],
               "driving": False, "paused": True, "actions": {"p": "FINISHED"}, "errors": []}
    state = master.answer(lambda: master.order("o1", 1, o1_1, released=3), of("o1", 1))
    assert seen(state) == updated and state["newBaseRequest"] is False

    # §6.6.4.3, the update 0 again (headerId 2 on the order topic): "Vehicle does NOT take over the new
    # order", "keeps the previous order", "reports the warning orderUpdateError" (§6.6.6 orderUpdateId: "If
    # an order update is rejected, this field is to be passed in the rejection message"; the references of
    # vcran's orderUpdateError: docs/vda5050.md, "Errors").
    state = master.answer(lambda: master.order("o1", 0, o1[1:], released=2), lambda s: bool(s["errors"]))
    rejected = ("orderUpdateError", "WARNING", {"topic": "order", "headerId": "2", "orderId": "o1",
                                                "orderUpdateId": "0"})
    assert seen(state) == updated | {"errors": [rejected]}

    # stopPause: "Movement and all other actions will be resumed", from where the vehicle stood.
    resumed = master.answer(lambda: master.instant("stopPause", "r"), has("r"))
    assert seen(resumed) == updated | {"errors": [rejected], "driving": True, "paused": False,
                                       "actions": {"p": "FINISHED", "r": "FINISHED"}}
    assert resumed["agvPosition"]["x"] == state["agvPosition"]["x"] == paused["agvPosition"]["x"] == 2.0

    # "The vehicle continues with executing the previous order" (§6.6.4.3, 4): n2, then n3, the end of o1;
    # nodeStates and edgeStates shrink as they are passed (§6.10.2). The warning stays until an order is
    # accepted (docs/vda5050.md, "Errors", as §6.6.4.1 says of validationError).
    state = master.answer(lambda: None, at("n2"))
    assert (seen(state)["nodes"], seen(state)["edges"], state["lastNodeSequenceId"]) == (["n3/6"], ["n2-n3/5"], 4)
    state = master.answer(lambda: None, at("n3"))
    assert seen(state) == updated | {"last": ("n3", 6), "nodes": [], "edges": [], "driving": False,
                                     "paused": False, "errors": [rejected],
                                     "actions": {"p": "FINISHED", "r": "FINISHED"}}

    # A new order from n3: accepted (Figure 8 (3): nothing executing, (4): it stands on n3); the warning is
    # gone, and so are the finished instant actions (§6.10.6). Its first edge is 6 m long.
    o2 = [("n3", 0, 6.0), ("m1", 2, 12.0), ("m2", 4, 14.0)]
    state = master.answer(lambda: master.order("o2", 0, o2, released=3), of("o2", 0))
    assert seen(state) == {"order": ("o2", 0), "last": ("n3", 0), "nodes": ["m1/2", "m2/4"],
                           "edges": ["n3-m1/1", "m1-m2/3"], "driving": True, "paused": False, "actions": {},
                           "errors": []}

    # §6.6.3, Figure 9, for a vehicle that cannot stop between nodes (vcran's default, docs/vda5050.md,
    # "cancelOrder"): "AGV drives to next node", "cancelOrder action state is set to RUNNING. The nodeState
    # for the node the AGV is driving to is kept. All other nodeStates and edgeStates are deleted."
    state = master.answer(lambda: master.instant("cancelOrder", "c"), has("c"))
    assert seen(state) == {"order": ("o2", 0), "last": ("n3", 0), "nodes": ["m1/2"], "edges": [],
                           "driving": True, "paused": False, "actions": {"c": "RUNNING"}, "errors": []}
    # "AGV arrives at the node where it stops", "All nodeStates and edgeStates are deleted", cancelOrder
    # FINISHED; "The orderId and orderUpdateId are kept". m2 is never reached.
    state = master.answer(lambda: None, at("m1"))
    assert seen(state) == {"order": ("o2", 0), "last": ("m1", 2), "nodes": [], "edges": [], "driving": False,
                           "paused": False, "actions": {"c": "FINISHED"}, "errors": []}

    # §6.6.3.2: "the previous order was canceled": the cancelOrder is FAILED, with the warning
    # noOrderToCancel and the actionId as its reference.
    state = master.answer(lambda: master.instant("cancelOrder", "c2"), has("c2"))
    assert seen(state)["actions"] == {"c": "FINISHED", "c2": "FAILED"}
    assert [(e[0], e[1], e[2].get("actionId")) for e in seen(state)["errors"]] == [
        ("noOrderToCancel", "WARNING", "c2")]
    assert state["lastNodeId"] == "m1"
