"""Behaviours no test pinned down before issue 13 (a mutation run could break each without a failing
test): the speed and turn limits of a leg (docs/contract.md §4), what AgvAction does at stations, the original VC-RAN's action
codes, tie orders, a ran_error's stamp, parts_moved. Every expectation is worked out by hand.

One robot at the origin facing +x with no acceleration or turn limits unless a test says otherwise, so a
leg of d metres at v m/s takes d / v seconds; dummy, load and unload take 1, 2 and 3 s.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import replace

import pytest

from tests.conftest import run_scenario
from vcran.core.opil.build import motion as build_motion
from vcran.core.opil.messages import Twist, Vector3
from vcran.core.scenario import ScriptEntry
from vcran.io.scenario_file import parse


def fleet(robot: str = "", stations: str = "") -> str:
    return f"""
[simulation]
until_idle = true
duration = 500.0
[simulation.action_durations]
dummy = 1.0
load = 2.0
unload = 3.0
[[robots]]
id = "robot_1"
pose = [0.0, 0.0, 0.0]
max_velocity = 1.0
{robot}
{stations}
"""


def entry(t, kind, task, name, seq, length, body):
    return (f'\n[[script]]\nrobot = "robot_1"\nt = {t}\nkind = "{kind}"\ntask = "{task}"\nid = "{name}"\n'
            f"seq = [{seq}, {length}]\n{body}\n")


def go(t, task, name, seq, length, x, y, extra=""):
    return entry(t, "motion", task, name, seq, length, f"point = [{x}, {y}, 0.0]\n{extra}")


def act(t, task, name, seq, length, what="dummy"):
    body = f"category = 0\ncode = {what}" if isinstance(what, int) else f'action = "{what}"'
    return entry(t, "action", task, name, seq, length, body)


def station(name, x, y, extra=""):
    return f'\n[[stations]]\nid = "{name}"\nposition = [{x}, {y}]\n{extra}\n'


def motion_done(out):
    return [(e["t"], e["motion"]) for e in out.of("motion_finished")]


def action_done(out):
    return [(e["t"], e["action"], e["ok"]) for e in out.of("action_finished")]


def parts(out):
    return {name: s["parts"] for name, s in out.summary["stations"].items()}


# --- docs/contract.md §4: a leg's limits ------------------------------------------------------------------------------------


def test_s4_speed_is_the_assignments_capped_by_the_robots(run_toml):
    out = run_toml(fleet() + go(1, "A", "A_m1", 1, 1, 4, 0, "max_velocity = 2.0")  # asks 2, robot does 1
                   + go(1, "B", "B_m1", 1, 1, 0, 0, "max_velocity = 0.5"))  # asks less than the robot
    assert motion_done(out) == [(5.0, "A_m1"), (13.0, "B_m1")]  # 4 m at 1 m/s from 1; 4 m at 0.5 m/s from 5


def test_s4_an_assignments_acceleration_limits_braking_too(run_toml):
    """10 m at 1 m/s with 0.5 m/s² each way: 2 s (1 m) up, 8 s cruising, 2 s (1 m) down: 12 s."""
    out = run_toml(fleet() + go(1, "A", "A_m1", 1, 1, 10, 0, "max_acceleration = 0.5"))
    assert motion_done(out) == [(13.0, "A_m1")]


def test_s4_the_robots_lower_deceleration_stays(run_toml):
    """Robot 1 m/s² up, 0.25 m/s² down; the assignment asks 0.5: up at min(1, 0.5) = 0.5 (2 s, 1 m), down at
    min(0.25, 0.5) = 0.25 (4 s, 2 m), 7 m cruising in between: 13 s."""
    robot = "max_acceleration = 1.0\nmax_deceleration = 0.25"
    out = run_toml(fleet(robot) + go(1, "A", "A_m1", 1, 1, 10, 0, "max_acceleration = 0.5"))
    assert motion_done(out) == [(14.0, "A_m1")]


@pytest.mark.parametrize(("asked", "turn"), [(0.5, math.pi), (2.0, math.pi / 2), (0.0, math.pi / 2)])
def test_s4_the_turn_rate_is_the_assignments_capped_by_the_robots(tmp_path, asked, turn):
    """A quarter turn to face +y, then 4 m: the robot turns at 1 rad/s, the assignment may ask less
    (0.5: π s) but not more (2: π/2 s); 0 means the robot's own rate."""
    scenario = parse(tomllib.loads(fleet("max_angular_velocity = 1.0")), "<test>")
    m = build_motion("A", "A_m1", 1, 1, 0, 4)
    m = replace(m, max_velocity=Twist(Vector3(), Vector3(0.0, 0.0, asked)))
    out = run_scenario(replace(scenario, script=(ScriptEntry(1.0, "robot_1", "motion_assignment", m),)), tmp_path)
    ((t, _),) = motion_done(out)
    assert t == pytest.approx(1 + turn + 4)


# --- docs/contract.md §4: actions at stations -------------------------------------------------------------------------------

STATION = station("s1", 4, 0.5, "parts = 3")


def test_s4_the_seeds_action_codes_0_1_2_are_dummy_load_unload(run_toml):
    """Category 0 (undefined) falls back to the original VC-RAN's codes: 1 load (2 s), 2 unload (3 s), 0 dummy (1 s)."""
    out = run_toml(fleet(stations=STATION) + go(1, "A", "A_m1", 1, 4, 4, 0, "is_waypoint = false")
                   + act(1, "A", "A_a2", 2, 4, 1) + act(1, "A", "A_a3", 3, 4, 2) + act(1, "A", "A_a4", 4, 4, 0))
    assert action_done(out) == [(7.0, "A_a2", True), (10.0, "A_a3", True), (11.0, "A_a4", True)]
    assert parts(out) == {"s1": 3}  # one part taken, one put back
    assert out.robot()["parts_moved"] == 1  # an unload moves a part; a load does not count


def test_s8_parts_moved_counts_unloads_only(run_toml):
    """docs/outputs.md: ``parts_moved`` is the number of successful unloads. A robot that can carry 2
    loads twice and unloads once: one part moved (two loads and a dummy count nothing), and a count
    of loads would say 2. Times: 4 m from 1 (at 5), loads 5-7 and 7-9, unload 9-12, dummy 12-13."""
    out = run_toml(fleet("capacity = 2", STATION) + go(1, "A", "A_m1", 1, 5, 4, 0, "is_waypoint = false")
                   + act(1, "A", "A_a2", 2, 5, "load") + act(1, "A", "A_a3", 3, 5, "load")
                   + act(1, "A", "A_a4", 4, 5, "unload") + act(1, "A", "A_a5", 5, 5, "dummy"))
    assert action_done(out) == [(7.0, "A_a2", True), (9.0, "A_a3", True), (12.0, "A_a4", True),
                                (13.0, "A_a5", True)]
    assert parts(out) == {"s1": 2} and out.robot()["carrying"] == 1  # 3 - 2 + 1 on the station
    assert out.robot()["parts_moved"] == 1


def test_s4_an_action_the_robot_is_not_capable_of_fails_and_changes_nothing(run_toml):
    text = fleet('actions = ["dummy", "unload"]', STATION)
    out = run_toml(text + go(1, "A", "A_m1", 1, 2, 4, 0, "is_waypoint = false") + act(1, "A", "A_a2", 2, 2, "load"))
    (f,) = out.of("failed")
    assert f["code"] == "action_not_capable"
    assert parts(out) == {"s1": 3} and out.robot()["carrying"] == 0


def test_s4_an_unload_onto_a_full_station_fails(run_toml):
    text = fleet("carrying = 1", station("s1", 4, 0.5, "parts = 2\ncapacity = 2"))
    out = run_toml(text + go(1, "A", "A_m1", 1, 2, 4, 0, "is_waypoint = false") + act(1, "A", "A_a2", 2, 2, "unload"))
    (f,) = out.of("failed")
    assert f["code"] == "station_full"
    assert parts(out) == {"s1": 2} and out.robot()["carrying"] == 1 and out.robot()["parts_moved"] == 0


def test_s4_a_full_station_skips_its_production(run_toml):
    """One part a second from t = 1, room for 2: the run's 10 s would make 10."""
    text = fleet(stations=station("p", 20, 20, "produce_every = 1.0\ncapacity = 2")).replace(
        "until_idle = true\nduration = 500.0", "duration = 10.0")
    out = run_toml(text)
    assert out.summary["stations"]["p"] == {"parts": 2, "produced": 2}


@pytest.mark.parametrize("where", [
    'reach = 1.0',  # the robot at (4, 0) is exactly 1 m from (4, 1)
    'area = [[3.0, 0.0], [5.0, 0.0], [5.0, 2.0], [3.0, 2.0]]',  # the robot is on the polygon's lower edge
])
def test_s4_a_robot_exactly_on_a_stations_boundary_is_in_reach(run_toml, where):
    text = fleet(stations=station("s1", 4, 1, f"parts = 1\n{where}"))
    out = run_toml(text + go(1, "A", "A_m1", 1, 2, 4, 0, "is_waypoint = false") + act(1, "A", "A_a2", 2, 2, "load"))
    assert action_done(out) == [(7.0, "A_a2", True)]
    assert parts(out) == {"s1": 0}


@pytest.mark.parametrize(("first", "second", "taken"), [
    ((4, 0.8), (4, -0.3), "second"),  # the nearer one, though listed second
    ((4, 0.5), (4, -0.5), "first"),  # equally near: the first in scenario order
])
def test_s4_of_two_stations_in_reach_the_nearest_serves(run_toml, first, second, taken):
    text = fleet(stations=station("first", *first, "parts = 1") + station("second", *second, "parts = 1"))
    out = run_toml(text + go(1, "A", "A_m1", 1, 2, 4, 0, "is_waypoint = false") + act(1, "A", "A_a2", 2, 2, "load"))
    assert parts(out) == {"first": 1, "second": 1} | {taken: 0}


# --- docs/contract.md §5: what is published ---------------------------------------------------------------------------------


def test_s5_statuses_of_one_tick_go_out_in_fleet_order(run_toml):
    """Robots listed zeta, then alpha (not alphabetical): every tick publishes zeta's statuses first."""
    text = fleet().replace('id = "robot_1"', 'id = "zeta"') + '\n[[robots]]\nid = "alpha"\npose = [0.0, 5.0, 0.0]\n'
    for robot in ("alpha", "zeta"):  # alpha's messages come first in the script
        text += go(1.5, "A", "A_m1", 1, 1, 2, 5 if robot == "alpha" else 0).replace("robot_1", robot)
    out = run_toml(text)
    ticks: dict[float, list[str]] = {}
    for r in out.trace():
        if r["attr"] == "ran_status":
            ticks.setdefault(r["t"], []).append(r["robot"])
    assert ticks[0.0] == ticks[2.0] == ["zeta", "alpha"]  # at 2 both are driving: both changed


def test_s5_a_ran_error_is_stamped_with_the_instant_of_the_rejection(run_toml):
    out = run_toml(fleet() + go(2.25, "A", "A_m1", 1, 2, 1, 0) + go(2.25, "A", "A_x", 1, 2, 2, 0))
    (r,) = [r for r in out.trace() if r["attr"] == "ran_error"]
    assert r["t"] == 2.25
    assert r["value"]["stamp"] == {"secs": 2, "nsecs": 250_000_000}
    assert (r["value"]["code"], r["value"]["count"]) == ("position_taken", 1)
