"""The Yard's plain body serves a VDA 5050 vehicle as the simulation's does (issue 31 item 2;
vcran/testing/vda5050/yard.py beside vcran/sim/vda5050/node.py): the charging pair, the battery's low
warning and waitForTrigger, with expectations derived by hand from VDA 5050 2.1.0 §6.8.1/§6.8.2.

The scenario is tests/sim/test_vda5050_body.py's: a 10 Ah battery starting at 1 Ah (10 %), low level 20 %
(2 Ah), charged at 0.125 Ah/s, no draw of its own, a charger where the vehicle stands. The Yard's link takes
0.5 s each way here, so a script entry sent at t reaches the vehicle at t + 0.5; the Yard has no telemetry
tick, so the warning is raised as the vehicle comes up and cleared at the very instant a charge lifts the
battery to the low level (docs/vda5050.md).
"""

from __future__ import annotations

import tomllib

import pytest

from tests.sim.test_vda5050_body import CHARGING, FINE_3S, FINE_AT_A, instant
from vcran.core.vda5050.enums import ActionStatus
from vcran.io.scenario_file import parse
from vcran.testing.vda5050.scripted import ScriptedMaster
from vcran.testing.vda5050.yard import Yard


def yard(text: str) -> Yard:
    scenario = parse(tomllib.loads(text))
    return Yard(scenario, ScriptedMaster(scenario), latency=0.5)


def errors(y: Yard, event: str) -> list[tuple[float, str]]:
    return [(e["t"], e["error"].error_type) for e in y.events if e["event"] == event]


def statuses(y: Yard, action_id: str) -> list[tuple[float, ActionStatus]]:
    return [(e["t"], e["status"]) for e in y.events if e["event"] == "ActionChanged" and e["action_id"] == action_id]


def test_stop_charging_stops_the_charge_and_the_charge_clears_battery_low():
    """startCharging reaches the vehicle at 3.0 and charges from 1 Ah: 2 Ah after 8 s, at 11.0, where
    ``batteryLow`` (raised as the vehicle came up, 10 % < 20 %) clears; stopCharging at 15.0 stops it at
    1 + 0.125 * 12 = 2.5 Ah, 25 %, and the stateRequest at 40.5 still shows 25 %, not charging. §6.8.2: each
    of the pair FINISHED ("the charging process is started", "... is stopped")."""
    y = yard(CHARGING + instant(2.5, "startCharging", "charge") + instant(14.5, "stopCharging", "stop")
             + instant(40.0, "stateRequest", "ask"))
    y.run(100.0)
    assert errors(y, "ErrorRaised") == [(0.0, "batteryLow")]
    assert errors(y, "ErrorCleared") == [(pytest.approx(11.0), "batteryLow")]
    assert statuses(y, "charge")[-1] == (3.0, ActionStatus.FINISHED)
    assert statuses(y, "stop")[-1] == (15.0, ActionStatus.FINISHED)
    last = y.states("7")[-1].battery_state
    assert (last.battery_charge, last.charging) == (pytest.approx(25.0), False)


def test_a_charge_stopped_below_the_low_level_keeps_battery_low():
    """Stopped at 7.0 after 4 s: 1.5 Ah, 15 %, still below the low level, so batteryLow stays."""
    y = yard(CHARGING + instant(2.5, "startCharging", "charge") + instant(6.5, "stopCharging", "stop")
             + instant(40.0, "stateRequest", "ask"))
    y.run(100.0)
    assert errors(y, "ErrorCleared") == []
    last = y.states("7")[-1]
    assert last.battery_state.battery_charge == pytest.approx(15.0)
    assert [e.error_type for e in last.errors] == ["batteryLow"]


def test_wait_for_trigger_runs_until_the_trigger():
    """§6.8.2 waitForTrigger: RUNNING while "AGV is waiting for the trigger", FINISHED when "Trigger has been
    triggered": sent at 1 it runs from 1.5 until the test presses the trigger at 20 (Yard.trigger)."""
    y = yard(CHARGING + instant(1.0, "waitForTrigger", "wait", params='{"key": "triggerType", "value": "button"}'))
    y.call_at(20.0, y.trigger, "7")
    y.run(19.0)
    waiting, running, finished = ActionStatus.WAITING, ActionStatus.RUNNING, ActionStatus.FINISHED
    assert statuses(y, "wait") == [(1.5, waiting), (1.5, running)]  # listed as it arrives, then started
    y.run(100.0)
    assert statuses(y, "wait") == [(1.5, waiting), (1.5, running), (20.0, finished)]


def test_fine_positioning_takes_the_scenarios_duration():
    """``fine_positioning = 3.0``: the HARD finePositioning on a, the order reaching the vehicle at 1.5, is
    FINISHED at 4.5, and the 8 s leg to b (2 s up to 1 m/s, 2 s at it, 2 s down) ends the order at 12.5."""
    y = yard(FINE_3S + FINE_AT_A)
    y.run(100.0)
    assert statuses(y, "fine")[-1] == (4.5, ActionStatus.FINISHED)
    assert [(e["t"], e["how"]) for e in y.events if e["event"] == "OrderEnded"] == [(pytest.approx(12.5), "completed")]
