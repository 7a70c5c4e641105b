"""VDA 5050 vehicles in the simulation (issue 31, the SimPy glue: vcran/sim/vda5050/): the bundled ``vda5050``
runs with ``vcran run`` to the demo's outcome, its states valid against the official schema, deterministic,
and its replay verifies.

Every expected figure is derived by hand from vcran/scenarios/vda5050.toml: the vehicle starts at home (0, 0)
facing +x, drives at 1 m/s with 0.5 m/s^2 up and down, turns in place at 1 rad/s; a pick or drop takes 5 s.
A leg of d >= 2 m from rest to rest takes 4 s for the 2 m of speeding up and slowing down plus d - 2 s at
1 m/s; a turn of a radians takes a s. Scripted orders reach the vehicle at their script times (no link).
"""

from __future__ import annotations

import json
import math
from datetime import UTC, datetime, timedelta

import pytest

from vcran.cli import main
from vcran.core.vda5050 import validation
from vcran.core.vda5050.enums import Topic, Version
from vcran.io.trace import event_records, read_header, trace_in, trace_records


def leg(d: float) -> float:
    """Seconds of a straight leg of ``d`` metres (d >= 2) from rest to rest."""
    return 4.0 + (d - 2.0)


# Order 100 at t = 1: home -> n1 (2, 0): a 2 m leg, no turn; n1 -> dock_1 (4, 2): a 45° turn, a 2√2 m leg;
# dock_1's theta π/2: a 45° turn; then the HARD pick, 5 s.
END_100 = 1.0 + leg(2.0) + math.pi / 4 + leg(2 * math.sqrt(2)) + math.pi / 4 + 5.0
# Order 200 at t = 20, facing +y on dock_1: a 90° turn to -x, dock_1 -> n2 (0, 2) and n2 -> dock_2 (-4, 2), 4 m
# each; dock_2's theta π/2: a 90° turn; the drop, 5 s.
END_200 = 20.0 + math.pi / 2 + 2 * leg(4.0) + math.pi / 2 + 5.0
# Order 300 at t = 45, facing +y on dock_2 (-4, 2): to n3 (-2, 2), n4 (-2, 0) and home (0, 0), three 2 m
# legs, each after a 90° turn; home's theta 0 is the heading of the last leg (no turn there).
END_300 = 45.0 + 3 * (math.pi / 2 + leg(2.0))


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("vda") / "run"
    assert main(["run", "vda5050", "--out", str(out), "--quiet"]) == 0
    return out


def test_vcran_run_vda5050_moves_the_part_as_the_demo_does(run):
    """The demo's outcome (docs/demo.md): conveyor_1's one part (produced at t = 10) is on conveyor_2, the
    vehicle home at (0, 0) facing +x, the three orders completed, no error."""
    summary = json.loads((run / "summary.json").read_text())
    robot = summary["robots"]["robot_1"]
    assert robot["completed"] == ["100", "200", "300"] and robot["cancelled"] == []
    assert robot["parts_moved"] == 1 and robot["carrying"] == 0 and robot["errors"] == 0 == summary["errors"]
    assert summary["stations"] == {"conveyor_1": {"parts": 0, "produced": 1}, "conveyor_2": {"parts": 1, "produced": 0}}
    assert robot["final_pose"] == pytest.approx({"x": 0.0, "y": 0.0, "theta": 0.0}, abs=1e-9)
    # home -> n1 -> dock_1: 2 + 2√2; dock_1 -> dock_2: 8; dock_2 -> home: 2 + 2 + 2
    assert robot["distance"] == pytest.approx(2 + 2 * math.sqrt(2) + 8 + 6)


def test_orders_end_when_the_legs_and_actions_say(run):
    """VDA 5050 §6.6: each order ends (its last node traversed, its actions FINISHED) at the times derived
    by hand above; the pick and drop run 5 s on their nodes (HARD: the vehicle stands, §6.12)."""
    events = [e for e in event_records(run / "events.jsonl.zst")]
    ended = [(e["t"], e["order_id"], e["how"]) for e in events if e["event"] == "order_ended"]
    assert [(o, h) for _, o, h in ended] == [("100", "completed"), ("200", "completed"), ("300", "completed")]
    assert [t for t, _, _ in ended] == pytest.approx([END_100, END_200, END_300])
    running = {e["action_id"]: e["t"] for e in events if e["event"] == "action_changed" and e["status"] == "RUNNING"}
    assert running == pytest.approx({"100_pick": END_100 - 5.0, "200_drop": END_200 - 5.0})


def test_every_state_in_the_trace_validates_against_the_official_schema(run):
    """Every state and factsheet the vehicle published is in the trace as sent, valid against the official
    2.1.0 schema (issue 31 item 1); headerIds count up by one per topic (§6.4); the last state shows the
    last order done: lastNodeId home (sequenceId 6), nothing left to traverse, not driving."""
    records = [r for r in trace_records(run) if r.get("dir") == "out"]
    assert {r["attr"] for r in records} == {"state", "factsheet"}
    for topic in ("state", "factsheet"):
        docs = [r["raw"] for r in records if r["attr"] == topic]
        assert [d["headerId"] for d in docs] == list(range(len(docs)))
        for doc in docs:
            assert validation.first_problem(validation.outbound(Topic(topic), Version.V2_1_0), doc) is None, doc
    last = [r["raw"] for r in records if r["attr"] == "state"][-1]
    assert (last["orderId"], last["lastNodeId"], last["lastNodeSequenceId"]) == ("300", "home", 6)
    assert last["nodeStates"] == last["edgeStates"] == [] and last["driving"] is False and last["errors"] == []
    assert [a["actionStatus"] for a in last["actionStates"]] == []  # order 300 has no actions; 100's and 200's went with their orders
    assert last["agvPosition"]["x"] == pytest.approx(0.0, abs=1e-9) and last["agvPosition"]["y"] == pytest.approx(0.0, abs=1e-9)


def test_the_orders_are_recorded_as_sent_and_states_answer_each_event(run):
    """The three scripted orders are in the trace as a master sends them, at their script times; a state
    follows at the same instant (§6.10: on receipt of an order)."""
    records = trace_records(run)
    orders = [r for r in records if r.get("attr") == "order"]
    assert [(r["t"], r["dir"], r["raw"]["orderId"]) for r in orders] == [(1.0, "in", "100"), (20.0, "in", "200"), (45.0, "in", "300")]
    for order in orders:
        assert validation.first_problem(validation.outbound(Topic.ORDER, Version.V2_1_0), order["raw"]) is None
        after = records[records.index(order) + 1]
        assert (after["t"], after["attr"], after["raw"]["orderId"]) == (order["t"], "state", order["raw"]["orderId"])


def test_a_vda5050_run_is_deterministic_and_its_replay_verifies(run, tmp_path, capsys):
    """docs/contract.md §5: the same scenario twice gives byte-identical files; ``vcran replay --verify`` re-runs the
    recorded orders (fed raw, decoded and validated by the vehicle as a broker's would be) to the same
    outbound records, legs and events."""
    again = tmp_path / "again"
    assert main(["run", "vda5050", "--out", str(again), "--quiet"]) == 0
    for name in ("summary.json", "trace.jsonl.zst", "events.jsonl.zst", "legs.npy"):
        assert (again / name).read_bytes() == (run / name).read_bytes(), name
    assert main(["replay", str(run), "--verify", "--quiet"]) == 0


def test_a_scripted_order_is_recorded_as_the_script_wrote_it(tmp_path):
    """docs/vda5050.md, "What a VDA 5050 run records": a script's order is in the trace as its master sends it,
    the header vcran stamped and then the message's keys in the file's order, numbers as written (``x = 2``
    an integer, ``mapId`` before ``y``), not re-encoded from the decoded order in the model's order; the
    replay decodes that text as it would a broker's and verifies."""
    path = tmp_path / "odd.toml"
    path.write_text(ONE_VEHICLE + """
[[script]]
t = 1.0
robot = "agv"
kind = "order"
message = '{"orderUpdateId": 0, "orderId": "o1", "edges": [{"edgeId": "a-b", "sequenceId": 1, "released": true, "startNodeId": "a", "endNodeId": "b", "actions": []}], "nodes": [{"nodeId": "a", "sequenceId": 0, "released": true, "nodePosition": {"x": 0, "mapId": "map", "y": 0.0}, "actions": []}, {"sequenceId": 2, "nodeId": "b", "released": true, "nodePosition": {"mapId": "map", "x": 2, "y": 0.0}, "actions": []}]}'
""")
    out = tmp_path / "run"
    assert main(["run", str(path), "--out", str(out), "--quiet"]) == 0
    with trace_in(out).open("rb") as f:
        import zstandard

        lines = zstandard.ZstdDecompressor().stream_reader(f).read().decode().splitlines()
    (line,) = [x for x in lines if '"dir":"in"' in x]
    assert line == (
        '{"t":1.0,"dir":"in","robot":"agv","attr":"order","raw":{"headerId":0,"timestamp":"1970-01-01T00:00:01.00Z",'
        '"version":"2.1.0","manufacturer":"acme","serialNumber":"7","orderUpdateId":0,"orderId":"o1","edges":[{"edgeId":'
        '"a-b","sequenceId":1,"released":true,"startNodeId":"a","endNodeId":"b","actions":[]}],"nodes":[{"nodeId":"a",'
        '"sequenceId":0,"released":true,"nodePosition":{"x":0,"mapId":"map","y":0.0},"actions":[]},{"sequenceId":2,'
        '"nodeId":"b","released":true,"nodePosition":{"mapId":"map","x":2,"y":0.0},"actions":[]}]}}')
    ended = [(e["order_id"], e["how"]) for e in event_records(out / "events.jsonl.zst") if e["event"] == "order_ended"]
    assert ended == [("o1", "completed")]
    assert main(["replay", str(out), "--verify", "--quiet"]) == 0


def order(t: float, robot: str, order_id: str, nodes: list[tuple[str, float]]) -> str:
    """A script entry: an order along the x axis through ``nodes`` ((nodeId, x)), all released."""
    node_rows = ",\n".join(
        f'  {{ nodeId = "{n}", sequenceId = {2 * i}, released = true, nodePosition = {{ x = {x}, y = 0.0, mapId = "map" }}, actions = [] }}'
        for i, (n, x) in enumerate(nodes))
    edge_rows = ",\n".join(
        f'  {{ edgeId = "{a}-{b}", sequenceId = {2 * i + 1}, released = true, startNodeId = "{a}", endNodeId = "{b}", actions = [] }}'
        for i, ((a, _), (b, _)) in enumerate(zip(nodes, nodes[1:])))
    return f"""
[[script]]
t = {t}
robot = "{robot}"
kind = "order"
message.orderId = "{order_id}"
message.orderUpdateId = 0
message.nodes = [
{node_rows},
]
message.edges = [
{edge_rows},
]
"""


def instant(t: float, robot: str, action_type: str, action_id: str, blocking: str) -> str:
    return f"""
[[script]]
t = {t}
robot = "{robot}"
kind = "instantActions"
message = '{{"actions": [{{"actionType": "{action_type}", "actionId": "{action_id}", "blockingType": "{blocking}"}}]}}'
"""


ONE_VEHICLE = """
[simulation]
protocol = "vda5050"
until_idle = true
duration = 100.0

[[robots]]
id = "agv"
manufacturer = "acme"
serial_number = "7"
pose = [0.0, 0.0, 0.0]
max_velocity = 1.0
max_acceleration = 0.5
"""

LINE = ONE_VEHICLE + order(1.0, "agv", "o1", [("a", 0.0), ("b", 6.0)]) + instant(3.0, "agv", "startPause", "pause_1", "HARD") + """
[[script]]
t = 4.0
robot = "agv"
kind = "order"
payload = '{"orderId": "bad"}'
""" + instant(7.0, "agv", "stopPause", "resume_1", "HARD") + order(20.0, "agv", "o2", [("b", 6.0), ("c", 12.0), ("d", 18.0)]) \
    + instant(22.0, "agv", "cancelOrder", "cancel_1", "NONE")


def test_pause_a_refused_payload_and_a_cancel_reach_the_body(tmp_path):
    """The glue carries the Vehicle's effects out on the shared body (docs/protocols.md's mapping table):
    - startPause at 3 and stopPause at 7 hold the 6 m leg a to b (8 s from 1) for 4 s: b at 13 (Hold, Release);
    - a payload that fails the schema at 4 is refused with a validationError in the state (§6.6.4.1), the
      order going on;
    - cancelOrder at 22 while driving b to c (8 s from 20) lets the leg end on c at 28 and drops d
      (§6.6.3: "the AGV stops as soon as possible ... on the next node"; StopAfterLeg), the order cancelled."""
    path = tmp_path / "line.toml"
    path.write_text(LINE)
    out = tmp_path / "run"
    assert main(["run", str(path), "--out", str(out), "--quiet"]) == 0
    events = list(event_records(out / "events.jsonl.zst"))
    ended = [(e["t"], e["order_id"], e["how"]) for e in events if e["event"] == "order_ended"]
    assert [(o, h) for _, o, h in ended] == [("o1", "completed"), ("o2", "cancelled")]
    assert [t for t, _, _ in ended] == pytest.approx([1.0 + 8.0 + 4.0, 28.0])
    summary = json.loads((out / "summary.json").read_text())["robots"]["agv"]
    assert summary["final_pose"]["x"] == pytest.approx(12.0) and summary["distance"] == pytest.approx(12.0)
    assert summary["completed"] == ["o1"] and summary["cancelled"] == [{"task": "o2", "reason": "cancelled"}]
    states = [r for r in trace_records(out) if r.get("attr") == "state"]
    for s in states:
        assert validation.first_problem(validation.outbound(Topic.STATE, Version.V2_1_0), s["raw"]) is None
    paused = [s["raw"]["paused"] for s in states if 3.0 <= s["t"] < 7.0]
    assert paused and all(paused)
    refused = next(s["raw"] for s in states if s["t"] == 4.0)
    assert [e["errorType"] for e in refused["errors"]] == ["validationError"] and refused["orderId"] == "o1"
    assert main(["replay", str(out), "--verify", "--quiet"]) == 0


CORRIDOR = """
[simulation]
protocol = "vda5050"
duration = 60.0

[traffic]
field = { margin = 2.0 }
deadlock_bound = 30.0
on_deadlock = "cancel"
""" + "".join(f"""
[[robots]]
id = "{name}"
manufacturer = "acme"
serial_number = "{name}"
pose = [{x0}, 0.0, {theta}]
max_velocity = 1.0
max_acceleration = 0.5
footprint = [[0.5, 0.5], [-0.5, 0.5], [-0.5, -0.5], [0.5, -0.5]]
""" + order(0.0, name, f"{name}_go", [(f"{name}0", x0), (f"{name}1", x1)])
              for name, x0, x1, theta in (("A", 0.0, 20.0, 0.0), ("B", 20.0, 0.0, math.pi)))


def test_safety_fields_show_as_field_violation_and_a_deadlock_cancel_gives_the_orders_up(tmp_path):
    """docs/contract.md §12 on VDA 5050 vehicles (vcran/sim/vda5050/traffic.py): the bundled corridor, derived by hand in
    its file, as orders sent at t = 0: the fields touch the other vehicle at t = 9 (A at 8, B at 12), both
    report ``safetyState.fieldViolation`` (§6.10.6) and brake 1 m in 2 s, to 9 and 11; at t = 11 they are
    deadlocked and, with ``on_deadlock = "cancel"``, stop for good: each order given up (``deadlock``), a
    deadlock warning in each state."""
    path = tmp_path / "corridor.toml"
    path.write_text(CORRIDOR)
    out = tmp_path / "run"
    assert main(["run", str(path), "--out", str(out), "--quiet"]) == 0
    states = [r for r in trace_records(out) if r.get("attr") == "state"]
    for robot in ("A", "B"):
        mine = [(s["t"], s["raw"]) for s in states if s["robot"] == robot]
        violated = [t for t, s in mine if s["safetyState"]["fieldViolation"]]
        assert violated and violated[0] == pytest.approx(9.0)
        last = mine[-1][1]
        assert [e["errorType"] for e in last["errors"]] == ["deadlock"] and last["nodeStates"] == []
        for _, s in mine:
            assert validation.first_problem(validation.outbound(Topic.STATE, Version.V2_1_0), s) is None
    events = list(event_records(out / "events.jsonl.zst"))
    ended = {e["robot"]: (e["t"], e["how"]) for e in events if e["event"] == "order_ended"}
    assert ended == {"A": (pytest.approx(11.0), "deadlock"), "B": (pytest.approx(11.0), "deadlock")}
    poses = {r: p["final_pose"]["x"] for r, p in json.loads((out / "summary.json").read_text())["robots"].items()}
    assert poses == pytest.approx({"A": 9.0, "B": 11.0})


FAULTY = ONE_VEHICLE + """
[[faults]]
t = 3.0
robot = "agv"
kind = "breakdown"
duration = 4.0

[[faults]]
t = 10.0
robot = "agv"
kind = "pause"

[[faults]]
t = 12.0
robot = "agv"
kind = "resume"
""" + order(1.0, "agv", "o1", [("a", 0.0), ("b", 6.0)]) + instant(20.0, "agv", "startPause", "pause_1", "NONE")


def test_spec_4_faults_reach_the_vehicle(tmp_path):
    """docs/contract.md §4 on a VDA 5050 vehicle (docs/vda5050.md, "Choices"): a breakdown from 3 to 7 holds the 6 m leg
    (8 s from 1) and is a FATAL ``breakdown`` error while it lasts; the pause fault at 10 and the resume at 12
    are the pause button (``paused`` true between, no actionState); b is reached 4 + 2 s late, at 15. A
    startPause after that is an instant action as usual (FINISHED)."""
    path = tmp_path / "faulty.toml"
    path.write_text(FAULTY)
    out = tmp_path / "run"
    assert main(["run", str(path), "--out", str(out), "--quiet"]) == 0
    events = list(event_records(out / "events.jsonl.zst"))
    assert [(e["t"], e["how"]) for e in events if e["event"] == "order_ended"] == [(pytest.approx(15.0), "completed")]
    states = [(r["t"], r["raw"]) for r in trace_records(out) if r.get("attr") == "state"]
    levels = {t: [(e["errorType"], e["errorLevel"]) for e in s["errors"]] for t, s in states}
    assert levels[3.0] == [("breakdown", "FATAL")] and levels[7.0] == []
    assert [s["paused"] for t, s in states if t in (10.0, 12.0)] == [True, False]
    assert all(s["actionStates"] == [] for t, s in states if t < 20.0)


def test_a_scenario_epoch_is_the_calendar_of_every_timestamp_and_the_replay_keeps_it(tmp_path):
    """``[simulation] epoch`` (docs/scenarios.md, docs/vda5050.md "Timestamps"): every message of the run, the
    script's order and the vehicle's states and factsheet, is stamped epoch + t (§6.4: ISO 8601, UTC), cut to
    the hundredth. By hand, from 23:59:58.5 on 1 March 2026: the factsheet and first state at t = 0 are
    23:59:58.50; the order at 1 and the state answering it 23:59:59.50; b, 6 m on from rest (8 s, as above),
    reached at 9: 00:00:07.50 on 2 March. The trace header records the epoch as written, so the replay stamps
    the same bytes."""
    path = tmp_path / "dated.toml"
    path.write_text(ONE_VEHICLE.replace("duration", 'epoch = "2026-03-01T23:59:58.5Z"\nduration')
                    + order(1.0, "agv", "o1", [("a", 0.0), ("b", 6.0)]))
    out = tmp_path / "run"
    assert main(["run", str(path), "--out", str(out), "--quiet"]) == 0
    records = trace_records(out)
    stamps = [(r["t"], r["attr"], r["raw"]["timestamp"]) for r in records]
    assert stamps[:2] == [(0.0, "factsheet", "2026-03-01T23:59:58.50Z"), (0.0, "state", "2026-03-01T23:59:58.50Z")]
    assert (1.0, "order", "2026-03-01T23:59:59.50Z") in stamps and (1.0, "state", "2026-03-01T23:59:59.50Z") in stamps
    at_b = next(r for r in records if r["attr"] == "state" and r["raw"]["lastNodeId"] == "b")
    assert (at_b["t"], at_b["raw"]["timestamp"]) == (pytest.approx(9.0), "2026-03-02T00:00:07.50Z")
    # Every other one alike: the epoch plus the record's time, cut to the hundredth (datetime's arithmetic).
    epoch = datetime(2026, 3, 1, 23, 59, 58, 500_000, tzinfo=UTC)
    for t, _, stamp in stamps:
        at = epoch + timedelta(microseconds=round(t * 1e6))
        assert stamp == f"{at:%Y-%m-%dT%H:%M:%S}.{at.microsecond // 10_000:02d}Z"
    assert read_header(trace_in(out))["fleet"]["simulation"]["epoch"] == "2026-03-01T23:59:58.5Z"
    assert main(["replay", str(out), "--verify", "--quiet"]) == 0


def test_the_factsheet_describes_the_body_that_drives(run):
    """§6.15.1: the factsheet's physicalParameters and footprint envelope are the scenario's robot, so a master
    planning with them plans with the body that drives (they said 1 m/s and 0.5 m/s^2 whatever the robot). By
    hand from scenarios/vda5050.toml: max_velocity 1.0, max_acceleration 0.5 and no max_deceleration (the
    acceleration's); the default footprint (docs/scenarios.md) spans x -0.87 .. 0.27 and y -0.35 .. 0.35."""
    sheet = next(r["raw"] for r in trace_records(run) if r.get("dir") == "out" and r["attr"] == "factsheet")
    body = sheet["physicalParameters"]
    assert (body["speedMax"], body["accelerationMax"], body["decelerationMax"]) == (1.0, 0.5, 0.5)
    assert body["length"] == pytest.approx(1.14) and body["width"] == pytest.approx(0.7)
    outline = sheet["agvGeometry"]["envelopes2d"][0]["polygonPoints"]
    assert [(p["x"], p["y"]) for p in outline] == [(0.27, 0.35), (-0.87, 0.35), (-0.87, -0.35), (0.27, -0.35)]


def test_a_faster_robot_says_so_in_its_factsheet(tmp_path):
    """The same for a robot of its own limits: 1.5 m/s, 0.75 m/s^2 up, 0.25 m/s^2 down, a 1 m x 0.5 m outline."""
    scenario = tmp_path / "fast.toml"
    fast = ONE_VEHICLE.replace("max_velocity = 1.0\nmax_acceleration = 0.5\n", "max_velocity = 1.5\nmax_acceleration = 0.75\n"
                               "max_deceleration = 0.25\nfootprint = [[0.5, 0.25], [-0.5, 0.25], [-0.5, -0.25], [0.5, -0.25]]\n")
    assert fast != ONE_VEHICLE
    scenario.write_text(fast)
    out = tmp_path / "run"
    assert main(["run", str(scenario), "--out", str(out), "--quiet"]) == 0
    sheet = next(r["raw"] for r in trace_records(out) if r.get("dir") == "out" and r["attr"] == "factsheet")
    body = sheet["physicalParameters"]
    assert (body["speedMax"], body["accelerationMax"], body["decelerationMax"]) == (1.5, 0.75, 0.25)
    assert (body["length"], body["width"]) == (1.0, 0.5)
    assert validation.first_problem(validation.outbound(Topic.FACTSHEET, Version.V2_1_0), sheet) is None
