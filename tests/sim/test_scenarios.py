"""Scenario tests: the original VC-RAN's demo and the behaviours issue "simulation core" asks to see, end to end."""

from __future__ import annotations

import math
import tomllib

import pytest

from tests.conftest import ROOT, run_scenario
from vcran.io.scenario_file import load, parse

FLEET = """
[simulation]
until_idle = true
duration = 500.0
task_timeout = 30.0
[simulation.action_durations]
dummy = 1.0
load = 2.0
unload = 2.0
[[robots]]
id = "robot_1"
pose = [0.0, 0.0, 0.0]
max_velocity = 1.0
[[stations]]
id = "s1"
position = [10.0, 1.0]
parts = 3
"""


def script(*entries: str) -> str:
    return FLEET + "".join(f"\n[[script]]\nrobot = \"robot_1\"\n{e}\n" for e in entries)


def motion(t, task, name, seq, length, x, y, extra=""):
    return f't = {t}\nkind = "motion"\ntask = "{task}"\nid = "{name}"\nseq = [{seq}, {length}]\npoint = [{x}, {y}, 0.0]\n{extra}'


def action(t, task, name, seq, length, what="dummy"):
    return f't = {t}\nkind = "action"\ntask = "{task}"\nid = "{name}"\nseq = [{seq}, {length}]\naction = "{what}"'


def cancel(t, task):
    return f't = {t}\nkind = "cancel"\ntask = "{task}"'


def cycles(events, robot="robot_1"):
    """The R6 state sequence as a string, e.g. 'WAITING>TASK>MOTION>ACTION>WAITING'."""
    seq = [e for e in events if e["event"] == "state" and e["robot"] == robot]
    return ">".join([seq[0]["from"]] + [e["to"] for e in seq]) if seq else ""


def test_demo_moves_the_part_and_returns_home(tmp_path):
    out = run_scenario(load(ROOT / "scenarios" / "demo.toml"), tmp_path)
    r = out.robot()
    assert r["completed"] == ["100", "200", "300"]
    assert r["cancelled"] == []
    assert out.summary["stations"]["conveyor_2"]["parts"] == 1
    assert out.summary["stations"]["conveyor_1"]["parts"] == 0
    assert r["final_pose"] == {"x": 0.0, "y": 0.0, "theta": 0.0}
    assert cycles(out.events) == ">".join(["WAITING"] + ["TASK", "MOTION", "ACTION", "WAITING"] * 3)
    assert out.summary["errors"] == 0
    # distance from the geometry: 2 + 2*sqrt(2) (task 100), 4 + 4 (200), 2 + 2 + 2 (300)
    assert r["distance"] == pytest.approx(2 + 2 * math.sqrt(2) + 4 + 4 + 2 + 2 + 2)


def test_r7_queued_task_times_out_at_first_seen_plus_timeout(run_toml):
    out = run_toml(script(
        motion(1, "A", "A_m1", 1, 2, 20, 0), action(1, "A", "A_a1", 2, 2),  # a 20 s drive
        motion(2, "B", "B_m1", 1, 2, 0, 0),  # B's action never comes
    ))
    (c,) = out.of("task_cancelled")
    # first seen at 2 + 30, plus R14's 1 µs tolerance
    assert c == {"t": 32.000001, "robot": "robot_1", "event": "task_cancelled", "task": "B", "reason": "timeout"}
    assert out.robot()["completed"] == ["A"]


def test_r7_assembled_exactly_at_deadline_is_on_time(run_toml):
    out = run_toml(script(motion(1, "A", "A_m1", 1, 2, 1, 0), action(31, "A", "A_a1", 2, 2)))
    assert out.robot()["completed"] == ["A"]


def test_r8_cancel_mid_path_stops_at_end_of_leg_and_next_task_starts_there(run_toml):
    out = run_toml(script(
        motion(1, "A", "A_m1", 1, 4, 5, 0), motion(1, "A", "A_m2", 2, 4, 5, 5),
        motion(1, "A", "A_m3", 3, 4, 0, 5), action(1, "A", "A_a1", 4, 4),
        motion(2, "B", "B_m1", 1, 2, 5, 8), action(2, "B", "B_a1", 2, 2),
        cancel(7.5, "A"),  # A_m1 ends at 6; A_m2 (6..11) is running
    ))
    finished = [e["motion"] for e in out.of("motion_finished")]
    assert finished == ["A_m1", "A_m2", "B_m1"]  # A_m3 never driven
    (c,) = out.of("task_cancelled")
    assert c["task"] == "A" and c["reason"] == "cancelled" and c["t"] == 11.0
    assert out.robot()["completed"] == ["B"]
    assert out.robot()["final_pose"]["x"] == 5.0 and out.robot()["final_pose"]["y"] == 8.0
    assert out.robot()["distance"] == pytest.approx(5 + 5 + 3)  # B starts from (5, 5)


def test_r2_r3_r10_out_of_order_and_duplicated_assignments(run_toml):
    out = run_toml(script(
        action(1, "A", "A_a1", 3, 3),
        motion(2, "A", "A_m2", 2, 3, 2, 0),
        motion(3, "A", "A_m2", 2, 3, 2, 0),  # duplicate: silent
        motion(4, "A", "A_m1", 1, 3, 1, 0),
        motion(5, "A", "A_m1", 1, 3, 1, 0),  # duplicate after dispatch: still silent
        action(6, "A", "A_a1", 3, 3),
    ))
    assert out.robot()["completed"] == ["A"]
    assert [e["motion"] for e in out.of("motion_finished")] == ["A_m1", "A_m2"]
    assert out.summary["errors"] == 0 and out.of("rejected") == []


def test_r8_cancel_for_task_not_yet_seen(run_toml):
    out = run_toml(script(
        cancel(1, "X"),
        motion(2, "X", "X_m1", 1, 2, 1, 0), action(3, "X", "X_a1", 2, 2),
        motion(4, "Y", "Y_m1", 1, 2, 1, 0), action(5, "Y", "Y_a1", 2, 2),
    ))
    rejected = out.of("rejected")
    assert [(e["code"], e["severity"]) for e in rejected] == [
        ("cancel_unknown_task", "warning"), ("task_cancelled", "error"), ("task_cancelled", "error"),
    ]
    assert out.robot()["completed"] == ["Y"]
    assert not out.of("task_queued", None)[0]["task"] == "X"
    errors = [r for r in out.trace() if r["attr"] == "ran_error"]
    assert [e["value"]["count"] for e in errors] == [1, 2, 3]


def test_r12_target_outside_motion_area_rejected_then_valid_tasks_run(run_toml):
    area = "area = [[-1.0, -1.0], [3.0, -1.0], [3.0, 1.0], [-1.0, 1.0]]"
    out = run_toml(script(
        motion(1, "A", "A_m1", 1, 2, 9, 9, area),  # outside its own area
        motion(2, "B", "B_m1", 1, 2, 2, 0, area), action(3, "B", "B_a1", 2, 2),
    ))
    (r,) = out.of("rejected")
    assert r["code"] == "outside_motion_area" and r["motion"] == "A_m1"
    assert out.robot()["completed"] == ["B"]


def test_failed_load_cancels_task_with_action_failed(run_toml):
    out = run_toml(script(motion(1, "A", "A_m1", 1, 2, 3, 0), action(1, "A", "A_a1", 2, 2, "load")))
    (c,) = out.of("task_cancelled")
    assert c["reason"] == "action_failed"
    (f,) = out.of("failed")
    assert f["code"] == "no_station_in_reach"
    assert out.of("action_finished")[0]["ok"] is False


def test_load_and_unload_move_parts_between_stations(run_toml):
    text = script(
        motion(1, "A", "A_m1", 1, 2, 10, 0), action(1, "A", "A_a1", 2, 2, "load"),
        motion(2, "B", "B_m1", 1, 2, 0, 0), action(2, "B", "B_a1", 2, 2, "unload"),
    ).replace('[[stations]]', '[[stations]]\nid = "home"\nposition = [0.0, 0.5]\n\n[[stations]]', 1)
    out = run_toml(text)
    assert out.robot()["completed"] == ["A", "B"]
    assert out.summary["stations"] == {"home": {"parts": 1, "produced": 0}, "s1": {"parts": 2, "produced": 0}}


def test_telemetry_stamps_and_cadence(run_toml):
    out = run_toml(script(motion(1, "A", "A_m1", 1, 2, 3, 0), action(1, "A", "A_a1", 2, 2)))
    trace = out.trace()
    descriptions = [r["t"] for r in trace if r["attr"] == "robot_description"]
    assert descriptions == [0.0]  # the run ends before 60 s
    statuses = [r for r in trace if r["attr"] == "ran_status"]
    assert statuses[0]["t"] == 0.0 and statuses[0]["value"]["state"] == "WAITING"
    assert all(r["t"] == int(r["t"]) for r in statuses)  # published on ticks only
    assert statuses[-1]["value"]["completed"][0]["description"] == "A"


def raw(t, attribute, value):
    import json as _json

    return f"t = {t}\nkind = \"raw\"\nattribute = \"{attribute}\"\nvalue = '{_json.dumps(value)}'"


def test_r12_malformed_payloads_rejected_then_valid_tasks_run(run_toml):
    from vcran.core.opil.build import motion as build_motion
    from vcran.core.opil.codec import encode_attribute

    good = encode_attribute("motion_assignment", build_motion("A", "A_m1", 1, 2, 1, 0))
    no_seq = {**good, "value": {k: v for k, v in good["value"].items() if k != "sequence"}}
    nan_x = __import__("copy").deepcopy(good)
    nan_x["value"]["point"]["value"]["x"]["value"] = "NaN"
    short_uuid = __import__("copy").deepcopy(good)
    short_uuid["value"]["task_id"]["value"]["uuid"]["value"].pop()
    out = run_toml(script(
        raw(1, "motion_assignment", no_seq), raw(2, "motion_assignment", nan_x),
        raw(3, "motion_assignment", short_uuid), raw(4, "cancel_order", {"type": "x", "value": 42}),
        motion(5, "B", "B_m1", 1, 2, 1, 0), action(5, "B", "B_a1", 2, 2),
    ))
    rejected = out.of("rejected")
    assert [e["code"] for e in rejected] == ["malformed"] * 4
    messages = [e["message"] for e in rejected]
    assert "motion_assignment.value.sequence" in messages[0] and "missing" in messages[0]
    assert "point.value.x" in messages[1]
    assert "task_id.value.uuid" in messages[2] and "16" in messages[2]
    assert messages[3].startswith("cancel_order")
    assert out.robot()["completed"] == ["B"] and out.of("task_queued")[0]["task"] == "B"
    # the rejected payloads are in the trace as raw, so a replay rejects them again
    assert sum(1 for r in out.trace() if r["dir"] == "in" and "raw" in r) == 4


def test_r11_message_for_unknown_entity_is_reported_and_dropped(tmp_path):
    """R11 at run time: a live fleet manager (or a trace) writing to an entity no RanLogic owns."""
    import tomllib

    from transports.base import Transport
    from vcran.core.opil.build import motion as build_motion
    from vcran.core.wire import Inbound
    from vcran.io.scenario_file import parse
    from vcran.runner import run_to
    from vcran.sim.timing import INBOUND, at

    class Stray(Transport):
        done = False

        def attach(self, env, deliver):
            def play(env):
                yield at(env, 2.0, INBOUND)
                deliver(Inbound("robot_9", "motion_assignment", build_motion("A", "A_m1", 1, 1, 1, 0)))
                self.done = True
            env.process(play(env))

        def send(self, out):
            pass

        @property
        def exhausted(self):
            return self.done

    result = run_to(parse(tomllib.loads(FLEET), "<t>"), tmp_path, Stray())
    from tests.conftest import read_lines

    events = [line for line in read_lines(tmp_path / "events.jsonl.zst") if "unknown_robot" in line]
    assert len(events) == 1 and '"robot":"robot_9"' in events[0] and '"t":2.0' in events[0]
    assert result.summary["errors"] == 1 and result.summary["robots"]["robot_1"]["errors"] == 0


def test_r11_scenario_with_differing_agv_and_ranlogic_ids_fails_to_load():
    import tomllib

    from vcran.io.scenario_file import ScenarioError, parse

    text = FLEET.replace('id = "robot_1"', 'id = "robot_1"\nagv_id = "robot_2"')
    with pytest.raises(ScenarioError, match="agv_id.*robot_2.*differs from the robot id.*R11"):
        parse(tomllib.loads(text), "fleet.toml")


def test_r7_timer_of_a_task_id_seen_again_after_history_eviction(run_toml):
    """A task id evicted from the R9 history and seen again gets its own deadline; the old one must not
    consume it (review finding)."""
    text = script(
        motion(0, "A", "A_m1", 1, 2, 1, 0), cancel(1, "A"),
        motion(2, "B", "B_m1", 1, 2, 1, 0), action(2, "B", "B_a1", 2, 2),  # B ends: A leaves the history
        motion(8, "A", "A_m1", 1, 2, 1, 0),  # A again, never assembled: deadline 38, after A's old 30
    ).replace("task_timeout = 30.0", "task_timeout = 30.0\nhistory_limit = 1")
    out = run_toml(text)
    timeouts = [(e["t"], e["task"]) for e in out.of("task_cancelled") if e["reason"] == "timeout"]
    assert timeouts == [(38.000001, "A")]  # 8 + 30, plus R14's 1 µs tolerance


def test_raw_payloads_orjson_cannot_write_are_rejected_and_replay(run_toml, tmp_path):
    """Deep nesting, a 100-digit integer and NaN in raw input (R12): rejected, recorded, replayed (docs/contract.md §6)."""
    from vcran.cli import main

    deep: object = 1
    for _ in range(300):
        deep = [deep]
    out = run_toml(script(
        raw(1, "motion_assignment", {"type": "x", "value": deep}),
        raw(2, "motion_assignment", {"type": "x", "value": {"task_id": 10**100}}),
        't = 3\nkind = "raw"\nattribute = "cancel_order"\nvalue = \'{"type": "x", "value": NaN}\'',
        motion(4, "B", "B_m1", 1, 2, 1, 0), action(4, "B", "B_a1", 2, 2),
    ))
    assert [e["code"] for e in out.of("rejected")] == ["malformed"] * 3
    assert out.robot()["completed"] == ["B"]
    assert main(["replay", str(out.dir), "--out", str(tmp_path / "rep"), "--verify", "--quiet"]) == 0


def test_r12_lone_surrogate_in_a_raw_value_is_rejected_recorded_and_replayed(run_toml, tmp_path):
    """JSON can carry a lone UTF-16 surrogate ("\\udc00"), which no UTF-8 file can hold: the RAN rejects
    it (R12), the trace records it (escaped) and a replay rejects it again (docs/contract.md §6); nothing crashes."""
    from vcran.cli import main
    from vcran.core.opil.build import cancel as build_cancel
    from vcran.core.opil.codec import encode_attribute

    bad = encode_attribute("cancel_order", build_cancel("T"))
    bad["value"]["task_id"]["value"]["description"]["value"] = "\udc00"
    out = run_toml(script(raw(1, "cancel_order", bad), motion(2, "B", "B_m1", 1, 2, 1, 0), action(2, "B", "B_a1", 2, 2)))
    [rejected] = out.of("rejected")
    assert rejected["code"] == "malformed" and "surrogate" in rejected["message"]
    assert out.robot()["completed"] == ["B"]
    [recorded] = [r for r in out.trace() if r["dir"] == "in" and "raw" in r]
    assert recorded["raw"]["value"]["task_id"]["value"]["description"]["value"] == "\udc00"
    assert main(["replay", str(out.dir), "--out", str(tmp_path / "rep"), "--verify", "--quiet"]) == 0


def test_raw_value_that_is_not_json_fails_to_load():
    import tomllib

    from vcran.io.scenario_file import ScenarioError, parse

    text = script('t = 1\nkind = "raw"\nattribute = "cancel_order"\nvalue = {when = 1979-05-27T07:32:00}')
    with pytest.raises(ScenarioError, match="script\\[0\\].*field 'value': not a JSON value"):
        parse(tomllib.loads(text), "x.toml")


def test_scripted_transport_holds_the_final_entity_state_like_orion(tmp_path):
    from transports.scripted import ScriptedTransport
    from vcran.runner import run_to

    scenario = load(ROOT / "scenarios" / "demo.toml")
    transport = ScriptedTransport(scenario.messages())
    run_to(scenario, tmp_path, transport)
    status = transport.latest[("robot_1", "ran_status")]
    assert status.state == "WAITING" and [i.description for i in status.completed] == ["100", "200", "300"]
    assert transport.last_frame is not None and transport.last_frame.t == 57.0
    assert transport.counts["current_motion"] == 58  # one per tick, t = 0 .. 57
    assert transport.counts["robot_description"] == 1


def test_a_transport_that_wants_no_frames_gets_none_and_the_files_are_the_same(tmp_path, monkeypatch):
    """docs/contract.md §6: frames are sampled only for a consumer; a folder's files never depended on them."""
    from transports.scripted import ScriptedTransport
    from vcran.core.motion import FleetKinematics
    from vcran.runner import run_to

    scenario = load(ROOT / "scenarios" / "demo.toml")
    with_frames = ScriptedTransport(scenario.messages())
    run_to(scenario, tmp_path / "a", with_frames)
    sampled: list[float] = []
    original = FleetKinematics.sample
    monkeypatch.setattr(FleetKinematics, "sample", lambda self, t: sampled.append(t) or original(self, t))
    without = ScriptedTransport(scenario.messages(), frames=False)
    run_to(scenario, tmp_path / "b", without)
    # never: not the 58 ticks, and the summary's final poses (docs/contract.md §8) are read robot by robot (pose())
    assert sampled == [] and without.last_frame is None and "current_motion" not in without.counts
    assert without.latest == with_frames.latest  # the statuses published are the same
    for name in ("trace.jsonl.zst", "legs.npy", "events.jsonl.zst", "summary.json"):
        assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "b" / name).read_bytes(), name


def test_telemetry_of_a_busy_fleet_is_the_same_vectorised_and_leg_by_leg(tmp_path, monkeypatch):
    """docs/contract.md §6: the telemetry reproduced from the leg log is bit for bit the same whether the sweep runs in numpy
    (from 24 moving robots on, its leg table updated only for the robots that started a leg since the last
    tick) or leg by leg in Python, over a fleet whose legs start and end all the time."""
    import numpy as np

    import vcran.core.sampling as sampling
    from transports.scripted import ScriptedTransport
    from vcran.io.gen import generate
    from vcran.io.trace import samples
    from vcran.runner import run_to

    path = tmp_path / "fleet.toml"
    path.write_text(generate(40, 0.1, 3))
    scenario = load(path)
    run_to(scenario, tmp_path / "out", ScriptedTransport(scenario.messages(), frames=False))
    vectorised = samples(tmp_path / "out")
    monkeypatch.setattr(sampling, "SCALAR_BELOW", 10**9)
    leg_by_leg = samples(tmp_path / "out")
    assert vectorised.shape == (361, 1 + 40 * 5)
    assert np.array_equal(vectorised.view(np.uint64), leg_by_leg.view(np.uint64))
    assert len(np.unique(vectorised[:, 1])) > 2  # robot 1 was somewhere else at different ticks


@pytest.mark.parametrize("robots", [1, 2, 50, 51])
def test_the_shortest_fleet_vcran_gen_prints_loads(robots):
    """vcran gen refuses --hours too short for its fleet's first cycles; what it accepts loads."""
    from vcran.io.gen import generate

    latest = 1.0 + (min(robots, 50) - 1) * 0.02
    with pytest.raises(ValueError, match="the fleet's first cycles start until"):
        generate(robots, math.nextafter(latest, 0.0) / 3600.0, 0)
    hours = next(h for h in (latest / 3600.0, math.nextafter(latest / 3600.0, 1.0)) if h * 3600.0 >= latest)
    parse(tomllib.loads(generate(robots, hours, 0)), "<gen>")
