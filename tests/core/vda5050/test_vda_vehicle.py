"""The VDA 5050 vehicle beyond the specification's diagrams (docs/contract.md §11, issue 31 item 2): instant actions,
the body's faults (docs/contract.md §4) as errors, what the state reports, the heartbeat, and the messages it builds
validating against the official schemas of its version."""

from __future__ import annotations

import math
from collections.abc import Sequence

import orjson
import pytest

from vcran.core.vda5050 import codec, validation
from vcran.core.vda5050.config import VehicleConfig
from vcran.core.vda5050.effects import (
    Act,
    Hold,
    LocalProtocolError,
    NodeTag,
    OrderEnded,
    Place,
    PublishFactsheet,
    PublishState,
    Release,
    StartTimer,
)
from vcran.core.vda5050.enums import ConnectionState, Topic, Version
from vcran.testing.vda5050.harness import Bench
from vcran.testing.vda5050.plans import MANUFACTURER, SERIAL, action, instant, order, pause, resume

A, B, C = ("a", 0, 0), ("b", 3, 4), ("c", 3, 8)


def kinds(effects: Sequence[object]) -> list[str]:
    return [type(e).__name__ for e in effects]


# --- pause (§6.8.1 startPause/stopPause) -------------------------------------------------------------------


def test_pause_holds_the_body_and_its_actions_and_resume_goes_on() -> None:
    """startPause: "No more AGV driving movements - reaching next node is not necessary"; FINISHED: "Vehicle
    stands still. All actions will be paused. The pause mode is activated. The AGV reports .paused: true"."""
    bench = Bench()
    bench.order(order("o", 0, [A, B, C], node_actions={"a": [action("waitForTrigger", "w", "NONE", triggerType="t")]}))
    effects = bench.instant(pause("p"))
    assert Hold("pause") in effects and bench.last.paused and not bench.last.driving
    assert bench.seen()["actions"] == {"w": "RUNNING", "p": "FINISHED"}  # the schemas have no PAUSED
    bench.instant(pause("p2"))  # idempotent (§6.8.1)
    assert bench.holds == {"pause"} and bench.seen()["actions"]["p2"] == "FINISHED"
    effects = bench.instant(resume("r"))
    assert Release("pause") in effects and not bench.last.paused and bench.last.driving


def test_the_pause_button_pauses_as_start_pause_does() -> None:
    """§6.10.6 paused: "either because of the push of a physical button on the AGV or because of an
    instantAction" (docs/contract.md §4's pause and resume faults)."""
    bench = Bench()
    bench.order(order("o", 0, [A, B]))
    assert Hold("pause") in bench.call("on_pause_button", True)
    assert bench.last.paused and not bench.last.driving and bench.seen()["actions"] == {}
    assert Release("pause") in bench.call("on_pause_button", False)
    assert bench.last.driving


def test_paused_actions_are_reported_paused_where_configured() -> None:
    """§6.11 PAUSED: "The action is paused because of a pause instantAction" (``report_paused``)."""
    bench = Bench(VehicleConfig(MANUFACTURER, SERIAL, report_paused=True))
    bench.order(order("o", 0, [A, B], node_actions={"a": [action("waitForTrigger", "w", "HARD", triggerType="t")]}))
    bench.instant(pause())
    assert bench.seen()["actions"]["w"] == "PAUSED"
    bench.instant(resume())
    assert bench.seen()["actions"]["w"] == "RUNNING"


def test_instant_actions_wait_while_paused() -> None:
    bench = Bench()
    bench.instant(pause())
    effects = bench.instant(instant(action("finePositioning", "f", "SOFT")))
    assert not any(isinstance(e, Act) for e in effects) and bench.seen()["actions"]["f"] == "WAITING"
    effects = bench.instant(resume())
    assert Act("finePositioning", "f") in effects and bench.seen()["actions"]["f"] == "RUNNING"


# --- other instant actions (§6.8.1, §6.8.2) ----------------------------------------------------------------


def test_state_and_factsheet_requests() -> None:
    """stateRequest FINISHED: "The state has been communicated"; factsheetRequest: "The factsheet has been
    communicated"."""
    bench = Bench()
    effects = bench.instant(instant(action("stateRequest", "s", "NONE"), action("factsheetRequest", "f", "NONE")))
    assert kinds(effects).count("PublishState") == 1 and PublishFactsheet() in effects
    assert bench.seen()["actions"] == {"s": "FINISHED", "f": "FINISHED"}


def test_init_position_sets_the_pose_and_last_node() -> None:
    """initPosition FINISHED: "The pose is reset. The AGV reports .agvPosition.x = x ... .lastNodeId"."""
    bench = Bench()
    effects = bench.instant(instant(action("initPosition", "i", "NONE", x=5.0, y=6.0, theta=4.0, mapId="map",
                                           lastNodeId="n5")))
    assert Place(5.0, 6.0, 4.0 - 2 * math.pi, "map") in effects
    position = bench.last.agv_position
    assert position is not None and (position.x, position.y) == (5.0, 6.0)
    assert bench.seen()["last"] == ("n5", 0) and bench.seen()["actions"] == {"i": "FINISHED"}


@pytest.mark.parametrize(("params", "reference"), [
    ({"x": 1.0, "y": 2.0, "theta": 0.0, "mapId": "map"}, ("parameter", "lastNodeId")),
    ({"x": "1", "y": 2.0, "theta": 0.0, "mapId": "map", "lastNodeId": "n"}, ("parameter", "x")),
    ({"x": 1.0, "y": 2.0, "theta": 0.0, "mapId": "elsewhere", "lastNodeId": "n"}, ("mapId", "elsewhere")),
])
def test_init_position_refuses_what_it_cannot_set(params: dict[str, object], reference: tuple[str, str]) -> None:
    """initPosition FAILED: "The pose is not valid or cannot be reset"."""
    bench = Bench()
    effects = bench.instant(instant(action("initPosition", "i", "NONE", **params)))
    assert not any(isinstance(e, Place) for e in effects)
    assert bench.seen()["actions"] == {"i": "FAILED"} and bench.seen()["errors"] == ["instantActionError"]
    (error,) = bench.last.errors
    assert reference in {(r.reference_key, r.reference_value) for r in error.error_references or ()}


def test_init_position_is_refused_while_an_order_runs() -> None:
    bench = Bench()
    bench.order(order("o", 0, [A, B]))
    bench.instant(instant(action("initPosition", "i", "NONE", x=1.0, y=2.0, theta=0.0, mapId="map", lastNodeId="n")))
    assert bench.seen()["actions"]["i"] == "FAILED" and bench.seen()["last"] == ("a", 0)


def test_charging_starts_standing_and_stops_on_request() -> None:
    """startCharging FINISHED: "The charging process is started. The AGV reports .batteryState.charging:
    true"; a new order waits for stopCharging (§6.8.1: "Deactivates the charging process to send a new
    order")."""
    bench = Bench()
    bench.battery = 40.0
    effects = bench.instant(instant(action("startCharging", "c1", "NONE")))
    assert Act("startCharging", "c1") in effects and bench.seen()["actions"]["c1"] == "RUNNING"
    bench.finish("c1")
    assert bench.last.battery_state.charging and bench.last.battery_state.battery_charge == 40.0
    bench.order(order("o", 0, [A, B]))
    assert bench.seen()["errors"] == ["orderError"]
    bench.instant(instant(action("stopCharging", "c2", "NONE")))
    bench.finish("c2")
    assert not bench.last.battery_state.charging
    bench.order(order("o", 0, [A, B]))
    assert bench.seen()["order"] == ("o", 0)


def test_stop_charging_after_start_charging_in_one_message_stops_the_charge_it_started() -> None:
    """The actions of one instantActions message are performed in order (§6.9): a stopCharging behind a
    startCharging still starting the charge (RUNNING, §6.8.2) waits for it, WAITING, and is not taken for a
    stopCharging while not charging (FINISHED at once, §6.8.1): once the charge runs, the body is told to stop
    it, and the vehicle reports charging false when it has."""
    bench = Bench()
    bench.battery = 40.0
    effects = bench.instant(instant(action("startCharging", "c1", "NONE"), action("stopCharging", "c2", "NONE")))
    assert [e for e in effects if isinstance(e, Act)] == [Act("startCharging", "c1")]
    assert {k: bench.seen()["actions"][k] for k in ("c1", "c2")} == {"c1": "RUNNING", "c2": "WAITING"}
    assert [e for e in bench.finish("c1") if isinstance(e, Act)] == [Act("stopCharging", "c2")]  # the charge runs: stop it
    assert bench.last.battery_state.charging and bench.seen()["actions"]["c2"] == "RUNNING"
    bench.finish("c2")
    assert not bench.last.battery_state.charging
    assert {k: bench.seen()["actions"][k] for k in ("c1", "c2")} == {"c1": "FINISHED", "c2": "FINISHED"}


def test_a_body_action_behind_a_waiting_stop_charging_waits_with_it() -> None:
    """start, stop, start in one message: the second startCharging is not started before the stopCharging
    ahead of it (§6.9, in order), so the body is told start, stop, start, and the vehicle ends charging."""
    bench = Bench()
    bench.instant(instant(action("startCharging", "c1", "NONE"), action("stopCharging", "c2", "NONE"),
                          action("startCharging", "c3", "NONE")))
    assert {k: bench.seen()["actions"][k] for k in ("c1", "c2", "c3")} == {"c1": "RUNNING", "c2": "WAITING", "c3": "WAITING"}
    assert [e for e in bench.finish("c1") if isinstance(e, Act)] == [Act("stopCharging", "c2"), Act("startCharging", "c3")]
    bench.finish("c2")
    bench.finish("c3")
    assert bench.last.battery_state.charging
    assert {k: bench.seen()["actions"][k] for k in ("c1", "c2", "c3")} == {"c1": "FINISHED", "c2": "FINISHED", "c3": "FINISHED"}


def test_stop_charging_behind_a_failed_start_charging_is_finished() -> None:
    """The startCharging before it FAILED (no charger in reach): nothing charges, so the stopCharging is
    FINISHED as any stopCharging while not charging (§6.8.1), with nothing for the body to do."""
    bench = Bench()
    bench.instant(instant(action("startCharging", "c1", "NONE"), action("stopCharging", "c2", "NONE")))
    effects = bench.finish("c1", ok=False, message="no charger in reach")
    assert not [e for e in effects if isinstance(e, Act)]
    assert {k: bench.seen()["actions"][k] for k in ("c1", "c2")} == {"c1": "FAILED", "c2": "FINISHED"}
    assert not bench.last.battery_state.charging


def test_charging_is_reported_as_the_vehicle_decides_it_with_or_without_a_battery_model() -> None:
    """The state says what the acceptance rules use: a master that sees charging false must not get an
    orderError for charging (found by the fuzzing machine: a robot without a battery model reported false)."""
    bench = Bench()
    assert bench.battery is None
    bench.instant(instant(action("startCharging", "c1", "NONE")))
    bench.finish("c1")
    assert bench.last.battery_state.charging and bench.last.battery_state.battery_charge == 100.0


def test_charging_is_refused_while_driving() -> None:
    bench = Bench()
    bench.order(order("o", 0, [A, B]))
    bench.instant(instant(action("startCharging", "c", "NONE")))
    assert bench.seen()["actions"]["c"] == "FAILED" and bench.seen()["errors"] == ["instantActionError"]


@pytest.mark.parametrize(("bad", "expected_actions"), [
    (action("detectObject", "x", "NONE"), {"x": "FAILED"}),  # not performed by vcran
    (action("pick", "x", "HARD"), {"x": "FAILED"}),  # §6.8.1: pick is not an instant action
    (action("waitForTrigger", "x", "NONE"), {"x": "FAILED"}),  # its triggerType is missing
])
def test_instant_actions_it_cannot_perform_fail(bad: object, expected_actions: dict[str, str]) -> None:
    bench = Bench()
    bench.instant(instant(bad))  # type: ignore[arg-type]
    assert bench.seen()["actions"] == expected_actions and bench.seen()["errors"] == ["instantActionError"]


def test_an_instant_action_with_a_used_action_id_is_refused_unlisted() -> None:
    bench = Bench()
    bench.instant(instant(action("stateRequest", "x", "NONE")))
    bench.instant(instant(action("startPause", "x", "NONE")))
    assert bench.seen()["actions"] == {"x": "FINISHED"} and not bench.last.paused
    assert bench.seen()["errors"] == ["instantActionError"]


def test_a_soft_instant_action_holds_the_vehicle_while_it_runs() -> None:
    """§6.12 SOFT: "Vehicle shall not drive"."""
    bench = Bench()
    bench.order(order("o", 0, [A, B]))
    effects = bench.instant(instant(action("finePositioning", "f", "SOFT")))
    assert Hold("instant") in effects and not bench.last.driving
    effects = bench.finish("f")
    assert Release("instant") in effects and bench.last.driving


# --- the body's faults (docs/contract.md §4) ---------------------------------------------------------------------------


@pytest.mark.parametrize(("why", "error_type", "level"), [
    ("battery_empty", "batteryEmpty", "FATAL"), ("motion_failed", "motionFailed", "WARNING"),
    ("collision", "collision", "WARNING")])
def test_a_halt_gives_up_the_order(why: str, error_type: str, level: str) -> None:
    """The body stopped for good: open actions FAILED, nodeStates and edgeStates emptied, orderId kept."""
    bench = Bench()
    bench.order(order("o", 0, [A, B, C], node_actions={"b": [action("pick", "p", "HARD")]}))
    bench.route.clear()  # the body halted on its leg
    effects = bench.call("on_halted", why)
    assert OrderEnded("o", why) in effects
    assert bench.seen() == {"order": ("o", 0), "last": ("a", 0), "nodes": [], "edges": [], "actions": {"p": "FAILED"},
                            "driving": False, "errors": [error_type]}
    assert bench.last.errors[0].error_level.value == level
    bench.order(order("o2", 0, [A, B]))
    assert (bench.seen()["order"] == ("o", 0)) is (level == "FATAL")  # FATAL: "not in running condition"


def test_an_empty_battery_is_fatal_until_serviced() -> None:
    bench = Bench()
    bench.call("on_halted", "battery_empty")
    bench.order(order("o", 0, [A, B]))
    assert bench.seen()["errors"] == ["batteryEmpty", "orderError"]
    bench.call("on_serviced")
    bench.order(order("o", 0, [A, B]))
    assert bench.seen()["order"] == ("o", 0) and bench.seen()["errors"] == []


def test_a_breakdown_is_fatal_while_it_lasts_and_the_order_resumes() -> None:
    bench = Bench()
    bench.order(order("o", 0, [A, B]))
    bench.call("on_breakdown")
    assert bench.seen()["errors"] == ["breakdown"] and not bench.last.driving
    assert bench.last.errors[0].error_level.value == "FATAL"
    bench.call("on_repaired")
    assert bench.seen()["errors"] == [] and bench.last.driving
    bench.reach()
    assert bench.seen()["last"] == ("b", 2)


def test_battery_low_and_field_violation_are_reported_while_they_last() -> None:
    bench = Bench()
    bench.order(order("o", 0, [A, B]))
    bench.call("on_battery_low", True)
    bench.call("on_field_violation", True)
    assert bench.seen()["errors"] == ["batteryLow"] and bench.last.safety_state.field_violation
    assert not bench.last.driving  # the body brakes for the field (docs/contract.md §12)
    bench.call("on_field_violation", False)
    bench.call("on_battery_low", False)
    assert bench.seen()["errors"] == [] and bench.last.driving


# --- what the state says -----------------------------------------------------------------------------------


def test_distance_since_last_node_counts_from_the_node() -> None:
    bench = Bench()
    bench.order(order("o", 0, [A, B, C]))
    assert bench.last.distance_since_last_node == 0.0
    bench.reach()  # (0, 0) to (3, 4): 5 m
    bench.odometer += 1.5  # on its way to c
    bench.instant(instant(action("stateRequest", "s", "NONE")))
    assert bench.last.distance_since_last_node == 1.5


def test_new_base_request_near_the_end_of_the_base() -> None:
    """§6.10.3: "If the AGV detects that its base is running low, it can set the newBaseRequest flag"; vcran:
    one released edge left, or none, with a horizon to come (docs/vda5050.md)."""
    bench = Bench()
    bench.order(order("o", 0, [A, B, C, ("d", 3, 12)], base=3))
    assert bench.last.new_base_request is False
    bench.reach()
    assert bench.last.new_base_request is True
    other = Bench()  # without a horizon there is nothing to ask for
    other.order(order("o", 0, [A, B, C]))
    other.reach()
    assert other.last.new_base_request is False


def test_a_state_goes_out_at_least_every_30_seconds() -> None:
    """§6.10: "The AGV state message will be published with occurrence of relevant events or at the latest
    every 30s"."""
    bench = Bench()
    assert bench.timers == {"state": 30.0}
    published = len(bench.states)
    bench.at(75.0)
    assert len(bench.states) == published + 2 and bench.timers == {"state": 90.0}
    bench.now = 80.0
    bench.order(order("o", 0, [A, B]))  # an event: a state now, and the next one 30 s after it
    assert bench.timers == {"state": 110.0}


def test_an_input_that_changes_nothing_publishes_nothing() -> None:
    bench = Bench()
    effects = bench.call("on_field_violation", False)
    assert effects == []


def test_misuse_by_the_driver_raises() -> None:
    bench = Bench()
    bench.order(order("o", 0, [A, B]))
    with pytest.raises(LocalProtocolError):
        bench.vehicle.on_reached(0.0, NodeTag("o", "c", 4), bench.where())
    with pytest.raises(LocalProtocolError):
        bench.vehicle.on_acted(0.0, "nothing")
    with pytest.raises(LocalProtocolError):
        bench.vehicle.on_timer(-1.0, "state")


# --- the messages it sends validate ------------------------------------------------------------------------


@pytest.mark.parametrize("version", list(Version), ids=lambda v: v.value)
def test_everything_a_vehicle_sends_validates_against_its_official_schema(version: Version) -> None:
    """docs/contract.md §11: "Every message vcran sends validates against its schema", in the vehicle's version: a run
    through orders, updates, actions, faults and refusals, every state checked."""
    bench = Bench(VehicleConfig(MANUFACTURER, SERIAL, version=version))
    bench.battery = 55.0
    bench.order(order("o", 0, [A, B, C], base=2, node_actions={"b": [action("pick", "p", "HARD", loadId="L")]}))
    bench.reach()
    bench.finish("p")
    bench.order(order("o", 1, [B, C], start=2))
    bench.order(b"not json")
    bench.instant(pause())
    bench.call("on_breakdown")
    bench.call("on_repaired")
    bench.instant(resume())
    bench.reach()
    bench.instant(instant(action("cancelOrder", "x", "NONE")))
    vehicle = bench.vehicle
    sent = [(Topic.STATE, s) for s in bench.states] + [
        (Topic.VISUALIZATION, vehicle.visualization(bench.now, bench.body())),
        (Topic.CONNECTION, vehicle.connection(bench.now, ConnectionState.ONLINE)),
        (Topic.FACTSHEET, vehicle.factsheet(bench.now))]
    assert len(bench.states) >= 10
    for topic, message in sent:
        doc = orjson.loads(codec.encode(message, version))
        assert doc["version"] == version.value
        assert validation.first_problem(validation.outbound(topic, version), doc) is None, (topic, doc)
    if version is Version.V2_0_0:  # 2.0.0's factsheet schema checks little: 2.1.0's checks the same fields
        doc = orjson.loads(codec.encode(vehicle.factsheet(bench.now), version))
        assert validation.first_problem(validation.outbound(Topic.FACTSHEET, Version.V2_1_0), doc) is None


def test_header_ids_count_per_topic_from_the_first_state() -> None:
    bench = Bench()
    assert [s.header.header_id for s in bench.states] == [0]
    bench.order(order("o", 0, [A, B]))
    assert [s.header.header_id for s in bench.states] == [0, 1]
    assert bench.vehicle.visualization(0.0, bench.body()).header.header_id == 0


def test_the_vehicle_starts_by_publishing_factsheet_and_state() -> None:
    bench = Bench()
    assert kinds(bench.effects) == ["PublishFactsheet", "PublishState", "StartTimer"]
    assert bench.effects[1:] == [PublishState(), StartTimer("state", 30.0)]
