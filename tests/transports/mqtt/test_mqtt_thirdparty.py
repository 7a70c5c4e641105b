"""A VDA 5050 master written with a widely used third-party library drives a 2.0.0 vehicle (issue 31, "Must
show"): coatyio's vda-5050-lib 1.4.0 (npm; JavaScript; its MasterController), not vcran's code, through an
order, an order update, a stale orderUpdateId, startPause/stopPause and cancelOrder, over a real Mosquitto.

The master is tests/transports/mqtt/thirdparty/master.js; it prints what it observed as JSON lines. It is
first proven against the library's own virtual AGV (its AgvController with the VirtualAgvAdapter), then
run unchanged against vcran's 2.0.0 vehicle. Both runs are checked with the same expectations, written
from the VDA 5050 2.1.0 text (the sections are quoted where used), which both vehicles must meet whatever
they choose where the text leaves room (how the first node is counted, where a cancel stops).

vcran's vehicle here is ``vcran live SCENARIO --mqtt URL`` as its own process (the ``live_fleet`` fixture): one
2.0.0 vehicle standing at (0, 0) facing +x with free floor ahead (support.vehicle_scenario).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import pytest
from jsonschema import Draft202012Validator

from tests.transports.mqtt.support import vehicle_scenario
from tests.transports.mqtt.thirdparty.runner import Outcome, installed, run_master

pytestmark = pytest.mark.slow

#: The official 2.0.0 state schema, verbatim in the package (the schema files' own test says so).
STATE_SCHEMA = json.loads((Path(__file__).parents[3] / "vcran/core/vda5050/schemas/2.0.0/state.schema").read_text())


@pytest.fixture
def master(request) -> Path:
    return installed(request)


@dataclass(frozen=True)
class Served:
    """What the master is told of the vehicle: its topic levels and map (the vehicle's default map id)."""

    manufacturer: str = "vcran"
    serial_number: str = "thirdparty-1"
    map_id: str = "map"


@pytest.fixture
def vcran_vehicle(broker, live_fleet, tmp_path) -> Served:
    """vcran's 2.0.0 vehicle standing at (0, 0) on ``broker``, retained ONLINE."""
    served = Served()
    scenario = vehicle_scenario(tmp_path, served.serial_number, version="2.0.0", manufacturer=served.manufacturer)
    live_fleet(broker.url, scenario, f"uagv/v2/{served.manufacturer}/{served.serial_number}", factor=2.0)
    return served


def test_the_master_drives_the_librarys_own_virtual_agv(broker, master):
    """The master script is proven against the vehicle its library ships."""
    outcome = run_master(master, broker.url, "coatyio", "virtual-1", map_id="local", virtual_agv=True)
    check_sequence(outcome)


def test_a_vda_5050_lib_master_drives_vcrans_2_0_0_vehicle(broker, master, vcran_vehicle):
    """The same script, unchanged, drives vcran's vehicle; every state it got validates against the official
    2.0.0 schema (the library checked them against its own 2.0 schema too: it drops what fails, and
    nothing was dropped)."""
    config = vcran_vehicle
    outcome = run_master(master, broker.url, config.manufacturer, config.serial_number, map_id=config.map_id)
    check_sequence(outcome)
    validator = Draft202012Validator(STATE_SCHEMA)
    for line in outcome.states:
        problems = [e.message for e in validator.iter_errors(line["raw"])]
        assert not problems, (problems, line["raw"])
    assert all(line["raw"]["version"] == "2.0.0" for line in outcome.states)


def check_sequence(outcome: Outcome) -> None:
    """What any VDA 5050 2.0 vehicle must show the master in this sequence (master.js's header lists it)."""
    shown = outcome.report()
    assert outcome.returncode == 0 and outcome.of("done"), shown
    assert not outcome.of("dropped"), shown  # no state failed the library's 2.0 schema check
    steps = [line["name"] for line in outcome.of("step")]
    assert steps == ["order", "pause", "update", "stale", "resume", "cancel"], shown

    def after(step: str) -> list[dict]:
        """The states received after the master began ``step``."""
        begin = outcome.lines.index(outcome.of("step", name=step)[0])
        return [line for line in outcome.lines[begin:] if line["event"] == "state"]

    # §6.6.2: the base (start, n1) is driven, the horizon (n2) is not: the vehicle stops on n1, and holds
    # n2 and its edge unreleased ("?") waiting for the update; the library calls the order processed, still
    # active (it has a horizon), without an error.
    at_n1 = next(s for s in after("order") if s["lastNodeId"] == "n1")
    assert (at_n1["orderId"], at_n1["orderUpdateId"], at_n1["lastNodeSequenceId"]) == ("o1", 0, 2), shown
    assert (at_n1["nodes"], at_n1["edges"], at_n1["driving"]) == (["n2/4?"], ["n1-n2/3?"], False), shown
    assert outcome.of("orderProcessed", order="o1/0")[0] | {"lastNodeId": None} == {
        "event": "orderProcessed", "order": "o1/0", "error": None, "byCancelation": False, "active": True,
        "lastNodeId": None}, shown

    # §6.8.1 startPause: "No more AGV driving movements", "Order is resumable"; §6.8.2: FINISHED when "The
    # AGV reports .paused: true". Until stopPause the vehicle does not move, whatever it is sent.
    pause = outcome.of("instantActionState", actionType="startPause")[0]["actionId"]
    paused = next(s for s in after("pause") if s["paused"] and s["actions"].get(pause) == "FINISHED")
    assert (paused["orderUpdateId"], paused["lastNodeId"], paused["driving"]) == (0, "n1", False), shown

    # §6.6.2, Figure 8 (7): the update stitches on the decision point n1 (seq 2) and is accepted: n2 and n3
    # released, nothing before n1 comes back; paused, the vehicle does not drive them yet.
    update = next(s for s in after("update") if s["orderUpdateId"] == 1)
    assert (update["orderId"], update["lastNodeId"]) == ("o1", "n1"), shown
    assert (update["paused"], update["driving"]) == (True, False), shown
    assert (update["nodes"], update["edges"]) == (["n2/4", "n3/6"], ["n1-n2/3", "n2-n3/5"]), shown

    # §6.6.4.3: o1/0 again, lower than the current 1: "Vehicle does NOT take over the new order", "keeps the
    # previous order", "reports the warning orderUpdateError" (with orderId and orderUpdateId of the
    # rejected update, §6.6.6's orderUpdateId: "If an order update is rejected, this field is to be passed
    # in the rejection message") and "continues with executing the previous order" (below).
    stale = next(s for s in after("stale") if s["errors"])
    assert (stale["orderUpdateId"], stale["nodes"], stale["lastNodeId"]) == (1, update["nodes"], "n1"), shown
    [error] = stale["errors"]
    assert (error["type"], error["level"], error["refs"].get("orderId"), error["refs"].get("orderUpdateId")) \
        == ("orderUpdateError", "WARNING", "o1", "0"), shown
    assert [line["error"] for line in outcome.of("orderProcessed", order="o1/0")][1:] == [
        {"type": "orderUpdateError", "level": "WARNING"}], shown

    # stopPause: "Movement and all other actions will be resumed": from where the vehicle stood when paused,
    # o1/1 is driven to its end (n3), the stale update changing nothing.
    resume = outcome.of("instantActionState", actionType="stopPause")[0]["actionId"]
    resumed = next(s for s in after("resume") if s["actions"].get(resume) == "FINISHED")
    assert not resumed["paused"] and resumed["position"] == paused["position"], shown
    assert all(s["position"] == paused["position"] for s in after("pause") if s["paused"]), shown
    done = next(s for s in after("resume") if s["lastNodeId"] == "n3")
    assert (done["orderId"], done["orderUpdateId"], done["lastNodeSequenceId"]) == ("o1", 1, 6), shown
    assert (done["nodes"], done["edges"], done["driving"]) == ([], [], False), shown
    assert outcome.of("orderProcessed", order="o1/1") == [{
        "event": "orderProcessed", "order": "o1/1", "error": None, "byCancelation": False, "active": False,
        "lastNodeId": "n3"}], shown

    # §6.6.3: cancelOrder while o2 drives: "the vehicle stops (based on its capabilities, e.g., right where
    # it is or on the next node)", then FINISHED with no nodeStates or edgeStates left (Figure 9); "The
    # orderId and orderUpdateId are kept". Either way it never reaches m2.
    cancel = outcome.of("instantActionState", actionType="cancelOrder")
    assert [line["status"] for line in cancel][-1] == "FINISHED", shown
    cancelled = next(s for s in after("cancel") if s["actions"].get(cancel[0]["actionId"]) == "FINISHED")
    assert (cancelled["orderId"], cancelled["orderUpdateId"]) == ("o2", 0), shown
    assert (cancelled["nodes"], cancelled["edges"], cancelled["driving"]) == ([], [], False), shown
    assert cancelled["lastNodeId"] in ("n3", "m1"), shown
    assert outcome.of("orderProcessed", order="o2/0")[0]["byCancelation"] is True, shown
