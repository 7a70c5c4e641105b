"""How the simulated body serves a VDA 5050 vehicle (issue 31 item 2; vcran/sim/vda5050/node.py around the shared
body): the charging pair, the battery's low warning, waitForTrigger and finePositioning, with expectations
derived by hand from VDA 5050 2.1.0 §6.8.1/§6.8.2 and the scenario's battery below.

The battery (``[robots.battery]``): 10 Ah, starting at 1 Ah (10 %), low level 20 % (2 Ah), charged at
0.125 Ah/s, no draw of its own (every ``per_*`` 0), so the level only moves while charging:
``level(t) = 1 + 0.125 * (seconds charged)``. The telemetry tick (``telemetry_period`` 1 s, at whole
seconds) watches the low level: it warns at t = 0 (10 % < 20 %, not charging) and, once a charge has lifted
the level to 2 Ah or more, the first tick after that clears the warning (docs/vda5050.md).
"""

from __future__ import annotations

import pytest

from tests.sim.test_vda5050_glue import ONE_VEHICLE
from vcran.cli import main
from vcran.io.trace import event_records, trace_records

CHARGING = ONE_VEHICLE + """battery = { capacity = 10.0, initial = 1.0, charge_rate = 0.125, low = 0.2 }

[[stations]]
id = "charger"
position = [0.0, 0.0]
charger = true
"""


def instant(t: float, action_type: str, action_id: str, blocking: str = "NONE", params: str = "") -> str:
    parameters = f', "actionParameters": [{params}]' if params else ""
    return f"""
[[script]]
t = {t}
robot = "agv"
kind = "instantActions"
message = '{{"actions": [{{"actionType": "{action_type}", "actionId": "{action_id}", "blockingType": "{blocking}"{parameters}}}]}}'
"""


def run(tmp_path, text: str) -> tuple[list[dict], list[tuple[float, dict]]]:
    path = tmp_path / "scenario.toml"
    path.write_text(text)
    out = tmp_path / "run"
    assert main(["run", str(path), "--out", str(out), "--quiet"]) == 0
    assert main(["replay", str(out), "--verify", "--quiet"]) == 0
    events = list(event_records(out / "events.jsonl.zst"))
    states = [(r["t"], r["raw"]) for r in trace_records(out) if r.get("attr") == "state"]
    return events, states


def action_states(state: dict) -> dict[str, str]:
    return {a["actionId"]: a["actionStatus"] for a in state["actionStates"]}


def test_stop_charging_ends_the_bodys_charge_and_the_charge_lifts_battery_low(tmp_path):
    """§6.8.2: startCharging is FINISHED when "the charging process is started" (charging true), stopCharging
    when "the charging process is stopped" (charging false). startCharging at 2.5 charges from 1 Ah; the level
    reaches the low level, 2 Ah, after 1 / 0.125 = 8 s, at 10.5, so the tick at 11 clears ``batteryLow``;
    stopCharging at 14.5 stops it at 1 + 0.125 * 12 = 2.5 Ah (25 %), where it stays: the stateRequest at 40
    shows 25 %, not charging (a charge running on would show 1 + 0.125 * 37.5 = 5.6875 Ah, 56.875 %)."""
    events, states = run(tmp_path, CHARGING + instant(2.5, "startCharging", "charge") + instant(14.5, "stopCharging", "stop")
                         + instant(40.0, "stateRequest", "ask"))
    at = dict(states)
    assert action_states(at[2.5]) == {"charge": "FINISHED"} and at[2.5]["batteryState"]["charging"] is True
    assert action_states(at[14.5])["stop"] == "FINISHED" and at[14.5]["batteryState"]["charging"] is False
    assert at[14.5]["batteryState"]["batteryCharge"] == pytest.approx(25.0)
    assert at[40.0]["batteryState"] == {"batteryCharge": pytest.approx(25.0), "charging": False}
    raised = [(e["t"], e["error"]["errorType"]) for e in events if e["event"] == "error_raised"]
    cleared = [(e["t"], e["error"]["errorType"]) for e in events if e["event"] == "error_cleared"]
    assert raised == [(0.0, "batteryLow")] and cleared == [(11.0, "batteryLow")]
    assert [e["errorType"] for e in at[2.5]["errors"]] == ["batteryLow"] and at[14.5]["errors"] == []


def test_start_and_stop_charging_in_one_message_leave_the_vehicle_not_charging(tmp_path):
    """One instantActions message carrying startCharging then stopCharging: its actions are performed in
    order (§6.9, the message's ``actions`` array; §6.8.2), so the charge is started, then stopped. Both are
    FINISHED and the vehicle does not charge (``batteryState.charging`` false, §6.8.2 stopCharging); no time
    passes between them, so the battery keeps its 1 Ah (10 %): the stateRequest at 30 shows 10 %, not the
    1 + 0.125 * 27.5 = 4.4375 Ah (44.375 %) of a charge left running, nor the full battery it would reach."""
    both = instant(2.5, "startCharging", "charge").replace(
        '"blockingType": "NONE"}]', '"blockingType": "NONE"}, {"actionType": "stopCharging", "actionId": "stop", '
        '"blockingType": "NONE"}]')
    assert both.count("stopCharging") == 1
    _, states = run(tmp_path, CHARGING + both + instant(30.0, "stateRequest", "ask"))
    at = dict(states)
    assert action_states(at[30.0]) == {"charge": "FINISHED", "stop": "FINISHED", "ask": "FINISHED"}
    assert at[30.0]["batteryState"] == {"batteryCharge": pytest.approx(10.0), "charging": False}
    assert all(s["batteryState"]["charging"] is False for t, s in states if t > 2.5), \
        [(t, s["batteryState"]) for t, s in states]


def test_a_charge_stopped_below_the_low_level_keeps_battery_low(tmp_path):
    """Stopped at 6.5 after 4 s of charging, the battery holds 1 + 0.125 * 4 = 1.5 Ah (15 %), still below the
    low level: ``batteryLow`` stays; the run ends idle without charging on (the final state says 15 %)."""
    events, states = run(tmp_path, CHARGING + instant(2.5, "startCharging", "charge") + instant(6.5, "stopCharging", "stop")
                         + instant(30.0, "stateRequest", "ask"))
    at = dict(states)
    assert at[30.0]["batteryState"] == {"batteryCharge": pytest.approx(15.0), "charging": False}
    assert [e["errorType"] for e in at[30.0]["errors"]] == ["batteryLow"]
    assert not [e for e in events if e["event"] == "error_cleared"]


def test_a_charge_to_full_ends_charging_and_battery_low(tmp_path):
    """Not stopped, the charge runs to full, 9 Ah at 0.125 Ah/s: 72 s, to 74.5, where charging ends on its own
    (§6.8.1 stopCharging: "interrupted by the vehicle ... if the battery is full"); batteryLow was cleared at 11."""
    events, states = run(tmp_path, CHARGING + instant(2.5, "startCharging", "charge"))
    ended = [(t, s) for t, s in states if t > 2.5 and not s["batteryState"]["charging"]]
    assert ended[0][0] == pytest.approx(74.5) and ended[0][1]["batteryState"]["batteryCharge"] == pytest.approx(100.0)
    assert [(e["t"], e["error"]["errorType"]) for e in events if e["event"] == "error_cleared"] == [(11.0, "batteryLow")]


def test_start_charging_without_a_charger_in_reach_fails(tmp_path):
    """§6.8.2 startCharging FAILED: "The charging process could not be started for some reason (e.g., not
    aligned to charger). Charging problems should correspond with an error": the charger is 5 m away, so the
    action is FAILED with an ``actionFailed`` warning and the vehicle does not charge."""
    far = CHARGING.replace("position = [0.0, 0.0]", "position = [5.0, 0.0]")
    _, states = run(tmp_path, far + instant(2.5, "startCharging", "charge"))
    at = dict(states)
    assert action_states(at[2.5]) == {"charge": "FAILED"} and at[2.5]["batteryState"]["charging"] is False
    assert "actionFailed" in [e["errorType"] for e in at[2.5]["errors"]]


WAIT_AT_A = """
[[script]]
t = 1.0
robot = "agv"
kind = "order"
message.orderId = "o1"
message.orderUpdateId = 0
message.nodes = [
  { nodeId = "a", sequenceId = 0, released = true, nodePosition = { x = 0.0, y = 0.0, mapId = "map" }, actions = [
    { actionType = "waitForTrigger", actionId = "wait", blockingType = "HARD", actionParameters = [{ key = "triggerType", value = "button" }] },
  ] },
  { nodeId = "b", sequenceId = 2, released = true, nodePosition = { x = 6.0, y = 0.0, mapId = "map" }, actions = [] },
]
message.edges = [
  { edgeId = "a-b", sequenceId = 1, released = true, startNodeId = "a", endNodeId = "b", actions = [] },
]
"""

TRIGGER = """
[[faults]]
t = 10.0
robot = "agv"
kind = "trigger"
"""


def action_events(events: list[dict], action_id: str) -> list[tuple[float, str]]:
    return [(e["t"], e["status"]) for e in events if e["event"] == "action_changed" and e["action_id"] == action_id]


def test_wait_for_trigger_holds_the_order_until_the_trigger_fault(tmp_path):
    """§6.8.2 waitForTrigger: RUNNING while "AGV is waiting for the trigger", FINISHED when "Trigger has been
    triggered". The HARD waitForTrigger on a, where the order starts at 1, keeps the vehicle there (§6.12) until
    the scenario's ``trigger`` fault at 10; then the 6 m leg to b takes 2 s up to 1 m/s, 2 s at it and 2 s down
    (0.5 m/s^2): 8 s, b at 18, the order completed. finePositioning, sent at 2, is FINISHED at 2
    (docs/vda5050.md: the body stands exactly on its node already)."""
    events, _ = run(tmp_path, ONE_VEHICLE + WAIT_AT_A + TRIGGER + instant(2.0, "finePositioning", "fine", "SOFT"))
    assert action_events(events, "wait") == [(1.0, "RUNNING"), (10.0, "FINISHED")]
    assert action_events(events, "fine")[-1] == (2.0, "FINISHED")
    assert [(e["t"], e["how"]) for e in events if e["event"] == "order_ended"] == [(pytest.approx(18.0), "completed")]


def test_wait_for_trigger_fails_when_the_order_is_cancelled(tmp_path):
    """§6.8.2: "waitForTrigger fails, if order has been canceled": cancelOrder at 5 (no trigger comes) makes it
    FAILED at 5 and the order ends cancelled there, the vehicle still on a."""
    events, _ = run(tmp_path, ONE_VEHICLE + WAIT_AT_A + instant(5.0, "cancelOrder", "cancel"))
    assert action_events(events, "wait") == [(1.0, "RUNNING"), (5.0, "FAILED")]
    assert [(e["t"], e["how"]) for e in events if e["event"] == "order_ended"] == [(5.0, "cancelled")]


@pytest.mark.parametrize(("text", "problem"), [
    # An OPIL robot has no trigger to press: the fault would do nothing, silently.
    ("[simulation]\nduration = 10.0\n[[robots]]\nid = \"agv\"\n" + TRIGGER, "trigger"),
    # until_idle without a duration: the HARD wait on a keeps the order open, the run never idle, for ever.
    (ONE_VEHICLE.replace("duration = 100.0\n", "") + WAIT_AT_A, "waitForTrigger"),
])
def test_a_trigger_without_a_vehicle_or_a_wait_without_an_end_is_refused(tmp_path, capsys, text, problem):
    """The scenario fails to load, one clear line naming the fault or the action (docs/vda5050.md)."""
    path = tmp_path / "scenario.toml"
    path.write_text(text)
    assert main(["run", str(path), "--out", str(tmp_path / "run"), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert problem in err and "Traceback" not in err
    assert not (tmp_path / "run").exists()


def test_a_wait_a_trigger_or_a_cancel_ends_loads(tmp_path):
    """The same wait without a duration loads when a trigger fault or a later cancelOrder ends it."""
    from vcran.io.scenario_file import load

    bare = ONE_VEHICLE.replace("duration = 100.0\n", "") + WAIT_AT_A
    for ending in (TRIGGER, instant(5.0, "cancelOrder", "cancel")):
        path = tmp_path / "scenario.toml"
        path.write_text(bare + ending)
        load(path)


def test_a_swapped_battery_clears_battery_low_and_battery_empty(tmp_path):
    """A swap lifts the battery too (docs/contract.md §4): drawing 0.25 Ah/s at rest, the 1 Ah run out at 4
    (``batteryEmpty``, FATAL, §6.10.6 errors), the swap 3 s later gives a full battery at 7, the vehicle is in
    service again (batteryEmpty cleared) and the tick at 7, after the swap in that instant (faults before
    telemetry, docs/determinism.md), finds 10 Ah >= 2 Ah: batteryLow cleared at 7."""
    drawing = CHARGING.replace("charge_rate = 0.125, low = 0.2", "per_idle_second = 0.25, low = 0.2, swap_after = 3.0")
    events, _ = run(tmp_path, drawing + instant(20.0, "stateRequest", "ask"))
    raised = [(e["t"], e["error"]["errorType"]) for e in events if e["event"] == "error_raised"]
    cleared = [(e["t"], e["error"]["errorType"]) for e in events if e["event"] == "error_cleared"]
    assert raised == [(0.0, "batteryLow"), (4.0, "batteryEmpty")]
    assert cleared == [(7.0, "batteryEmpty"), (7.0, "batteryLow")]


FINE_AT_A = WAIT_AT_A.replace(
    '{ actionType = "waitForTrigger", actionId = "wait", blockingType = "HARD", actionParameters = [{ key = "triggerType", value = "button" }] }',
    '{ actionType = "finePositioning", actionId = "fine", blockingType = "HARD", actionParameters = [] }')
FINE_3S = ONE_VEHICLE.replace("[[robots]]", "[simulation.action_durations]\nfine_positioning = 3.0\n\n[[robots]]", 1)


def test_fine_positioning_takes_the_scenarios_duration_and_pauses_with_the_vehicle(tmp_path):
    """With ``[simulation.action_durations] fine_positioning = 3.0`` the HARD finePositioning on a runs 3 s of
    work (§6.8.2 RUNNING: "AGV positions itself exactly on a target"); the pause fault at 2 and the resume at 5
    stop it for 3 s (§6.8.2 PAUSED: "After removing the violation, the fine positioning continues"), so it is
    FINISHED at 1 + 3 + 3 = 7, and the 8 s leg to b ends at 15."""
    pause = '\n[[faults]]\nt = 2.0\nrobot = "agv"\nkind = "pause"\n\n[[faults]]\nt = 5.0\nrobot = "agv"\nkind = "resume"\n'
    events, _ = run(tmp_path, FINE_3S + FINE_AT_A + pause)
    assert action_events(events, "fine") == [(1.0, "RUNNING"), (7.0, "FINISHED")]
    assert [(e["t"], e["how"]) for e in events if e["event"] == "order_ended"] == [(pytest.approx(15.0), "completed")]


def test_fine_positioning_durations_are_a_vda5050_vehicles(tmp_path, capsys):
    """An OPIL robot has no finePositioning: the duration would do nothing, so the file fails to load."""
    path = tmp_path / "scenario.toml"
    path.write_text("[simulation]\nduration = 10.0\n[simulation.action_durations]\nfine_positioning = 3.0\n"
                    "[[robots]]\nid = \"agv\"\n")
    assert main(["run", str(path), "--out", str(tmp_path / "run"), "--quiet"]) == 2
    assert "fine_positioning" in capsys.readouterr().err
