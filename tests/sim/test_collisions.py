"""docs/contract.md §4 Footprints and collisions, end to end: scenarios/crossing.toml as derived by hand in docs/robots.md."""

from __future__ import annotations

import tomllib

import pytest

from tests.conftest import ROOT, run_scenario
from vcran.io.scenario_file import ScenarioError, load, parse

CROSSING = ROOT / "scenarios" / "crossing.toml"


def crossing(mode: str, tmp_path):
    text = CROSSING.read_text().replace('collisions = "stop"', f'collisions = "{mode}"')
    return run_scenario(parse(tomllib.loads(text), "<crossing>"), tmp_path / mode)


def test_s4_crossing_robots_collide_at_the_computed_instant_and_place(tmp_path):
    out = run_scenario(load(CROSSING), tmp_path)
    (hit,) = out.of("collision")
    # both 1 m/s from t = 1; 1 m squares first touch with both centres 1 m short of the crossing: t = 10
    assert hit["robot"] == "robot_1" and hit["other"] == "robot_2"
    assert hit["t"] == pytest.approx(10.0, abs=1e-6)
    assert (hit["x"], hit["y"]) == (pytest.approx(-0.5, abs=1e-6), pytest.approx(-0.5, abs=1e-6))


def test_s4_collisions_stop_halts_both_and_cancels_their_tasks(tmp_path):
    out = run_scenario(load(CROSSING), tmp_path)
    assert [(e["robot"], e["task"], e["reason"]) for e in out.of("task_cancelled")] == [
        ("robot_1", "east", "collision"), ("robot_2", "north", "collision")]
    r1, r2 = out.robot("robot_1"), out.robot("robot_2")
    assert (r1["final_pose"]["x"], r1["final_pose"]["y"]) == (pytest.approx(-1.0, abs=1e-6), 0.0)
    assert (r2["final_pose"]["x"], r2["final_pose"]["y"]) == (pytest.approx(0.0, abs=1e-9), pytest.approx(-1.0, abs=1e-6))
    assert r1["collisions"] == r2["collisions"] == 1
    assert [e["code"] for e in out.of("failed")] == ["collision", "collision"]


def test_s4_collisions_report_drives_through_and_reports_once(tmp_path):
    out = crossing("report", tmp_path)
    (hit,) = out.of("collision")  # one contact episode, one event
    assert hit["t"] == pytest.approx(10.0, abs=1e-6)
    assert [e["task"] for e in out.of("task_completed")] == ["east", "north"]  # both arrive at t = 21
    assert out.of("task_completed")[0]["t"] == 21.0
    # an observer only: no ran_error, the wire is what it is with detection off (the original's)
    assert [r for r in out.trace() if r["attr"] == "ran_error"] == []
    assert out.summary["errors"] == 0


def test_s4_collisions_off_detects_nothing(tmp_path):
    out = crossing("off", tmp_path)
    assert out.of("collision") == [] and "collisions" not in out.robot("robot_1")


def test_s4_a_robot_at_rest_is_hit_too(tmp_path):
    # robot_2 never moves: parked on robot_1's path at (3, 0); robot_1's front edge (x + 0.5) meets its
    # back edge (2.5) when robot_1's centre is at 2.0: 12 m from -10 at 1 m/s from t = 1 -> t = 13.
    text = CROSSING.read_text().replace("pose = [0.0, -10.0, 1.5707963267948966]", "pose = [3.0, 0.0, 0.0]")
    text = text[:text.rindex("[[script]]")]
    out = run_scenario(parse(tomllib.loads(text), "<parked>"), tmp_path)
    (hit,) = out.of("collision")
    assert hit["t"] == pytest.approx(13.0, abs=1e-6)
    assert hit["x"] == pytest.approx(2.5, abs=1e-6)
    assert [(e["robot"], e["reason"]) for e in out.of("task_cancelled")] == [("robot_1", "collision")]


def test_s4_unknown_collision_mode_fails_to_load():
    text = CROSSING.read_text().replace('collisions = "stop"', 'collisions = "bounce"')
    with pytest.raises(ScenarioError, match="collisions.*'bounce'"):
        parse(tomllib.loads(text), "<crossing>")


def test_s4_a_robot_is_hit_after_it_comes_to_rest_and_far_along_a_long_leg(tmp_path):
    # robot_1 drives (-10, 0) -> (0, 0) and rests there from t = 11; robot_2 drives (0, -30) -> (0, 70), a
    # 100 m leg whose box spans six grid rows. When robot_2 starts, the pair can only be predicted until
    # robot_1's leg ends (t = 11, no contact yet); the contact must be found when robot_1 comes to rest (its
    # filing kept: its rest box lies inside its leg's cells) and shares one cell of robot_2's long box.
    # robot_2's front edge (y + 0.5) meets robot_1's back edge (-0.5) with its centre at -1: 29 m from -30
    # at 1 m/s from t = 1 -> t = 30, somewhere along robot_1's back edge (y = -0.5, -0.5 <= x <= 0.5).
    text = CROSSING.read_text()
    text = text.replace("pose = [0.0, -10.0, 1.5707963267948966]", "pose = [0.0, -30.0, 1.5707963267948966]")
    text = text.replace("path = [[10.0, 0.0]]", "path = [[0.0, 0.0]]").replace("path = [[0.0, 10.0]]", "path = [[0.0, 70.0]]")
    out = run_scenario(parse(tomllib.loads(text), "<rest-then-hit>"), tmp_path)
    (hit,) = out.of("collision")
    assert (hit["robot"], hit["other"]) == ("robot_1", "robot_2")
    assert hit["t"] == pytest.approx(30.0, abs=1e-6)
    assert -0.5 <= hit["x"] <= 0.5 and hit["y"] == pytest.approx(-0.5, abs=1e-6)
    assert [(e["robot"], e["task"]) for e in out.of("task_completed")] == [("robot_1", "east")]
