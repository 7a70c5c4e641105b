"""docs/contract.md §4 Battery, end to end: scenarios/battery.toml's outcome as derived by hand in docs/robots.md."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from tests.conftest import ROOT, run_scenario
from tests.sim.test_scenarios import FLEET, action, motion
from vcran.core.opil.codec import decode_attribute, encode_attribute
from vcran.core.opil.messages import BatteryState
from vcran.core.opil.plain import from_plain
from vcran.io.scenario_file import load


@pytest.fixture(scope="module")
def battery_run(tmp_path_factory):
    return run_scenario(load(ROOT / "scenarios" / "battery.toml"), tmp_path_factory.mktemp("battery"))


def test_s4_battery_empty_mid_path_stops_at_the_computed_point(battery_run):
    out = battery_run
    # 0.5 Ah at 0.009 Ah/m * 1 m/s + 0.001 Ah/s = 0.01 Ah/s: empty after 50 s, 50 m along +x.
    (empty,) = out.of("battery_empty")
    assert empty["t"] == pytest.approx(50.0, abs=1e-9)
    assert (empty["x"], empty["y"]) == (pytest.approx(50.0, abs=1e-9), 0.0)
    (cancel,) = out.of("task_cancelled")
    assert cancel["task"] == "go" and cancel["reason"] == "battery_empty"
    assert cancel["t"] == empty["t"]
    # 0 % is published at the tick of t = 50; nothing changes while the robot waits for its swap
    rows = [r for r in out.trace() if r["attr"] == "battery_state" and 50 < r["t"] < 80]
    assert rows == []


def test_s4_battery_low_warned_once_at_the_first_tick_below(battery_run):
    (low,) = battery_run.of("battery_low")
    assert low["t"] == 25.0  # 0.255 Ah is crossed at t = 24.5; the tick at 25 s sees 0.25 Ah
    assert low["charge"] == pytest.approx(0.25)
    codes = [r["value"]["code"] for r in battery_run.trace() if r["attr"] == "ran_error"]
    assert codes == ["battery_low", "battery_empty", "battery_empty"]  # low, the stop, the rejected task


def test_s4_empty_robot_takes_no_task_until_swapped(battery_run):
    out = battery_run
    (rejected,) = out.of("rejected")
    assert rejected["t"] == 55.0 and rejected["task"] == "late" and rejected["code"] == "battery_empty"
    (swap,) = out.of("battery_swapped")
    assert swap["t"] == pytest.approx(80.0, abs=1e-9)


def test_s4_charge_at_a_charger_refills_to_full(battery_run):
    out = battery_run
    r = out.robot()
    # swapped full at 80; 10 s idle (0.01 Ah) and 10 m (0.1 Ah) to the charger: 0.89 Ah at t = 100;
    # charging nets 0.011 - 0.001 = 0.01 Ah/s: full after 11 s.
    assert r["completed"] == ["charge_run"]
    (done,) = out.of("task_completed")
    assert done["t"] == pytest.approx(111.0, abs=1e-9)
    assert r["final_pose"] == {"x": 60.0, "y": 0.0, "theta": 0.0}
    assert r["distance"] == pytest.approx(60.0)
    assert r["battery"]["charge"] == pytest.approx(1.0)
    states = [r["value"]["power_supply_status"] for r in out.trace() if r["attr"] == "battery_state"]
    assert 1 in states and states[-1] == 4  # charging, then full (sensor_msgs constants)


def test_s4_battery_published_on_each_percent_step(battery_run):
    rows = [r for r in battery_run.trace() if r["attr"] == "battery_state" and r["t"] <= 50]
    # 0.01 Ah/s of a 1 Ah battery: one percent per second from 50 % at t = 0
    assert [r["t"] for r in rows] == [float(t) for t in range(0, 51)]
    assert rows[10]["value"]["percentage"] == pytest.approx(0.40)
    assert rows[10]["value"]["charge"] == pytest.approx(0.40)


def test_s4_battery_state_codec_round_trip_and_decode_cli(battery_run, tmp_path):
    (first,) = [r for r in battery_run.trace() if r["attr"] == "battery_state"][:1]
    message = from_plain(BatteryState, first["value"])
    encoded = encode_attribute("battery_state", message)
    assert encoded["type"] == "sensor_msgs.BatteryState"
    assert decode_attribute("battery_state", encoded) == message
    entity = tmp_path / "entity.json"
    entity.write_text(json.dumps({"id": "robot_1", "type": "ROBOT", "battery_state": encoded}))
    done = subprocess.run([sys.executable, "-m", "vcran", "decode", str(entity)], capture_output=True, text=True, cwd=ROOT)
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout)["battery_state"]["percentage"] == 0.5


BATTERY = FLEET.replace('max_velocity = 1.0\n', 'max_velocity = 1.0\n[robots.battery]\ncapacity = 1.0\nper_action_second = 0.01\n', 1)


def test_s4_charge_without_a_charger_fails_at_dispatch(run_toml):
    out = run_toml(BATTERY + "\n[[script]]\nrobot = \"robot_1\"\n" + action(1, "C", "C_a1", 1, 1, "charge"))
    (done,) = out.of("action_finished")
    assert done["t"] == 1.0 and done["ok"] is False  # at once, not after a duration (R14)
    (cancel,) = out.of("task_cancelled")
    assert cancel["reason"] == "action_failed"
    assert out.of("failed")[0]["code"] == "no_charger_in_reach"


def test_s4_charge_on_a_robot_without_battery_is_not_capable(run_toml):
    out = run_toml(FLEET + "\n[[script]]\nrobot = \"robot_1\"\n" + action(1, "C", "C_a1", 1, 1, "charge"))
    assert out.of("failed")[0]["code"] == "action_not_capable"


def test_s4_battery_empties_during_an_action(run_toml):
    # 1 Ah at 0.01 Ah/s of action: a 200 s dummy action is cut at t = 1 + 100.
    text = BATTERY.replace("dummy = 1.0", "dummy = 200.0")
    out = run_toml(text + "\n[[script]]\nrobot = \"robot_1\"\n" + action(1, "D", "D_a1", 1, 1, "dummy"))
    (empty,) = out.of("battery_empty")
    assert empty["t"] == pytest.approx(101.0)
    assert out.of("action_finished") == []
    assert out.of("task_cancelled")[0]["reason"] == "battery_empty"


def test_s4_robot_without_battery_publishes_no_battery(run_toml):
    out = run_toml(FLEET + "\n[[script]]\nrobot = \"robot_1\"\n" + motion(1, "A", "A_m1", 1, 1, 3, 0))
    assert not [r for r in out.trace() if r["attr"] == "battery_state"]
    assert "battery" not in out.robot()
