"""``vcran view``'s model of a run folder (docs/contract.md §13, issue 33 item 2): where the robots are at any instant,
what each was doing, carrying and reporting, the stations' parts, the jobs and the incidents, for every
kind of folder vcran writes. Expectations come from docs/demo.md's geometry worked by hand, the scenario
files, or vcran's other readers (telemetry_table, trace_records), never from the view's own code."""

from __future__ import annotations

import base64
import json
import math
import struct
import tomllib
import zlib

import numpy as np
import pytest

import vcran
from tests.conftest import ROOT, read_lines, write_lines
from tests.view.runs import bundled, generated, managed, still_running
from vcran.io.trace import EVENTS_FILE
from vcran.view import ViewError, page_html
from vcran.view.build import build_model
from vcran.view.folder import read_folder
from vcran.view.model import Steps
from vcran.view.pack import packed, payload
from vcran.view.parts import productions
from vcran.view.poses import Poses

pytestmark = pytest.mark.slow  # every bundled scenario and a generated fleet run once for the module


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    base = tmp_path_factory.mktemp("runs")
    out = {name: bundled(name, base / name) for name in ("demo", "warehouse", "faults", "battery", "crossing", "corridor")}
    out["generated"] = generated(6, 0.25, base / "generated")
    out["manage"] = managed(out["warehouse"], base / "manage")
    return out


def value_at(steps: Steps, owner: int, t: float, initial):
    """The step series' value of ``owner`` at ``t`` (the last change at or before it)."""
    lo, hi = int(steps.offsets[owner]), int(steps.offsets[owner + 1])
    k = int(np.searchsorted(steps.t[lo:hi], t, side="right"))
    return initial if k == 0 else steps.value[lo + k - 1].item()


@pytest.mark.parametrize("name", ["demo", "warehouse", "faults", "battery", "crossing", "generated"])
def test_poses_at_every_tick_are_the_telemetry_bit_for_bit(runs, name):
    """docs/contract.md §13: what the page draws at t is what the run's telemetry says; the rule of vcran/view/poses.py
    (and of fleet.js, which the browser tests check) against vcran.telemetry_table, every robot, every tick."""
    files = read_folder(runs[name])
    poses = Poses([tuple(r["pose"]) for r in files.header["fleet"]["robots"]], files.legs)
    table = vcran.telemetry_table(runs[name])
    index = {rid: i for i, rid in enumerate(files.robots)}
    got = np.array([poses.pose(index[row["robot"]], float(row["t"])) for row in table])
    assert np.array_equal(got, np.column_stack([table["x"], table["y"], table["theta"]]))


def test_demo_states_tasks_loads_and_parts_as_docs_demo_derives_them(runs):
    """docs/demo.md by hand: task 100 is current from its first message (t = 1) and assembled at t = 3; it
    drives (0,0)->(2,0) in 4 s (2 m at 1 m/s with 0.5 m/s² ramps: a triangle reaching 1 m/s), turns pi/4,
    drives 2√2 m (4 s of ramps + (2√2 - 2) s cruising), turns pi/4 to face conveyor 1 and loads for 5 s:
    the part is on the robot from 14 + pi/2 + 2√2 ≈ 18.40 s. Conveyor 1 makes its one part at t = 10
    (produce_every 10, limit 1). Task 200 unloads on conveyor 2 at ≈ 38.54 s (events)."""
    model = build_model(read_folder(runs["demo"]))
    loaded = 14 + math.pi / 2 + 2 * math.sqrt(2)
    names = model.state_names
    task = lambda t: value_at(model.current, 0, t, -1)  # noqa: E731
    label = lambda t: model.tasks.labels[model.tasks.label[task(t)]] if task(t) >= 0 else None  # noqa: E731
    assert [label(t) for t in (0.5, 1.0, 18.0, loaded + 0.01, 56.0, 57.0)] == [None, "100", "100", "200", "300", None]
    assert [names[value_at(model.states, 0, t, 0)] for t in (0.5, 2.0, 5.0, 15.0)] == ["WAITING", "TASK", "MOTION", "ACTION"]
    assert value_at(model.loads, 0, loaded - 0.01, 0) == 0 and value_at(model.loads, 0, loaded + 1e-9, 0) == 1
    unload = next(e["t"] for e in read_events(runs["demo"]) if e["event"] == "action_finished" and e["task"] == "200")
    assert value_at(model.loads, 0, unload - 0.01, 0) == 1 and value_at(model.loads, 0, unload, 0) == 0

    def parts(station: str, t: float) -> int:
        s = [st.id for st in model.stations].index(station)
        lo, hi = int(model.parts.offsets[s]), int(model.parts.offsets[s + 1])
        k = lo + int(np.searchsorted(model.parts.t[lo:hi], t, side="right")) - 1
        since = float(model.parts.t[k])
        return int(model.parts.value[k]) + min(int(model.parts_room[k]), productions(model.stations[s], since, t))

    assert [parts("conveyor_1", t) for t in (9.99, 10.0, 18.0, loaded + 0.01, 57.0)] == [0, 1, 1, 0, 0]
    assert [parts("conveyor_2", t) for t in (0.0, unload - 0.01, unload, 57.0)] == [0, 0, 1, 1]
    assert model.notes == [] and model.source == "scripted" and model.geometry


def read_events(run):
    return [json.loads(line) for line in read_lines(run / EVENTS_FILE)]


def test_productions_count_the_instants_in_the_half_open_interval():
    """A station producing every 10 s from t = 5 produces at 5, 15, 25, ...: in (after, until]."""
    from vcran.view.model import Station

    s = Station("s", (0.0, 0.0), 1.0, (), 100, 10.0, 5.0)
    assert [productions(s, -1.0, t) for t in (4.9, 5.0, 14.9, 15.0, 100.0)] == [0, 1, 1, 2, 10]
    assert productions(s, 5.0, 15.0) == 1 and productions(s, 5.0, 14.0) == 0 and productions(s, 15.0, 15.0) == 0
    assert productions(Station("idle", (0.0, 0.0), 1.0, (), 100, 0.0, 0.0), -1.0, 1e6) == 0


def test_faults_scenario_incidents_are_its_faults_failures_and_cancels(runs):
    """scenarios/faults.toml: each injected fault that finds something to act on is an incident at its
    time, on its robot; the failures they cause and the cancelled tasks are incidents too."""
    faults = tomllib.loads((ROOT / "scenarios" / "faults.toml").read_text())["faults"]
    model = build_model(read_folder(runs["faults"]))
    robots = [r.id for r in model.robots]
    got = [(i.t, robots[i.robot]) for i in model.incidents if i.kind == "fault" and "ends" not in i.text]
    assert sorted(got) == sorted((float(f["t"]), f["robot"]) for f in faults)
    events = read_events(runs["faults"])
    assert sum(i.kind == "failure" for i in model.incidents) == sum(e["event"] == "failed" for e in events) > 0
    assert sum(i.kind == "cancel" for i in model.incidents) == sum(e["event"] == "task_cancelled" for e in events) > 0
    assert [i.t for i in model.incidents] == sorted(i.t for i in model.incidents)
    # the last error at the cursor: robot_2's motion failure from its instant on
    failed = next(e for e in events if e["event"] == "failed" and e["robot"] == "robot_2")
    k = robots.index("robot_2")
    assert value_at(model.errors, k, failed["t"] - 0.01, -1) == -1
    assert model.error_texts[value_at(model.errors, k, failed["t"], -1)].startswith(failed["code"] + ": ")


def test_the_corridors_blocks_and_deadlock_are_incidents(runs):
    """docs/robots.md derives the corridor by hand (docs/contract.md §12): A and B block each other at 9, and
    A's deadlock with B is raised at 11; the page lists them as incidents of their own kinds."""
    model = build_model(read_folder(runs["corridor"]))
    robots = [r.id for r in model.robots]
    got = [(i.t, i.kind, robots[i.robot], i.text) for i in model.incidents if i.kind in ("block", "deadlock")]
    assert [(t, kind, robot) for t, kind, robot, _ in got] == [
        (pytest.approx(9.0), "block", "A"), (pytest.approx(9.0), "block", "B"), (pytest.approx(11.0), "deadlock", "A")]
    assert got[0][3].startswith("A blocked by B") and got[2][3].startswith("A: deadlock with B")


def test_the_corridors_roadmap_is_drawn_from_its_scenario_file(runs):
    """The page's roadmap (nodes as [x, y], edges as node indices) is scenarios/corridor.toml's, read from the
    file here, not from the run."""
    road = tomllib.loads((ROOT / "scenarios" / "corridor.toml").read_text())["roadmap"]
    model = build_model(read_folder(runs["corridor"]))
    assert model.roadmap is not None
    ids = [n["id"] for n in road["nodes"]]
    assert model.roadmap["nodes"] == [[float(n["x"]), float(n["y"])] for n in road["nodes"]]
    assert model.roadmap["edges"] == [[ids.index(e["from"]), ids.index(e["to"])] for e in road["edges"]]
    assert build_model(read_folder(runs["demo"])).roadmap is None


def test_battery_levels_are_the_published_battery_states(runs):
    """docs/contract.md §4: the page's battery at t is the last battery_state the robot published at or before t."""
    model = build_model(read_folder(runs["battery"]))
    published = [(r["t"], r["value"]["percentage"]) for r in vcran.trace_records(runs["battery"])
                 if r["attr"] == "battery_state"]
    assert published
    for t, pct in published:
        assert value_at(model.batteries, 0, t, None) == pytest.approx(pct, abs=1e-4)  # float32 in the page


def test_warehouse_jobs_have_their_robot_tasks_and_lead_times(runs):
    """docs/contract.md §9: every job of the closed loop, its robot from job_assigned, its tasks (the dispatcher names them
    JOB_pick1, JOB_drop1), and a lead time from arrival to completion (docs/outputs.md)."""
    model = build_model(read_folder(runs["warehouse"]))
    summary = json.loads((runs["warehouse"] / "summary.json").read_text())
    assert len(model.jobs) == summary["jobs"]["arrived"]
    assert sum(j.status == "completed" for j in model.jobs) == summary["jobs"]["completed"]
    assigned = {}
    for e in read_events(runs["warehouse"]):
        if e["event"] == "job_assigned":
            assigned.setdefault(e["job"], []).append(e["robot"])
    robots = [r.id for r in model.robots]
    for job in model.jobs:
        assert [robots[i] for i in job.robots] == list(dict.fromkeys(assigned[job.id]))
        labels = [model.tasks.labels[model.tasks.label[k]] for k in job.tasks]
        assert labels and all(label.startswith(job.id + "_") for label in labels)
        if job.status == "completed":
            assert job.lead_time == pytest.approx(job.ended - job.arrived)
    assert model.source == "loop" and model.notes == []


def test_a_manage_folder_shows_its_jobs_and_says_what_cannot_be_drawn(runs):
    """vcran manage --out holds job events and a summary, no trace (docs/live.md): the page has the jobs and a
    note that the floor cannot be drawn, rather than an error."""
    model = build_model(read_folder(runs["manage"]))
    assert not model.geometry and model.source == "manage"
    assert any("no trace.jsonl.zst" in note for note in model.notes)
    assert len(model.jobs) == json.loads((runs["manage"] / "summary.json").read_text())["jobs"]["arrived"]
    assert {r.id for r in model.robots} == {e["robot"] for e in read_events(runs["manage"]) if e["robot"]}
    assert "no fleet to draw" in page_html(runs["manage"])


def test_a_run_still_being_written_is_read_up_to_its_last_whole_line(runs, tmp_path):
    """A live run's folder while it runs (<out>.incomplete: no summary, no end record, a leg log whose header
    counts no rows): read as far as it goes, marked incomplete, poses still the telemetry's."""
    run = still_running(runs["warehouse"], tmp_path / "live.incomplete", cut=400)
    files = read_folder(run)
    assert not files.complete and files.legs is not None and len(files.legs) > 0
    last = json.loads(read_lines(run / "trace.jsonl.zst")[-1])["t"]
    assert files.end == max(last, max(e["t"] for e in files.events))
    assert files.end < json.loads((runs["warehouse"] / "summary.json").read_text())["sim_time"]
    model = build_model(files)
    assert not model.complete and model.notes == []


def test_a_replayed_run_is_shown_as_the_recording(runs, tmp_path):
    """vcran replay writes the same files: the page's model is the recording's, its source 'replay'."""
    from vcran.cli import main

    assert main(["replay", str(runs["demo"]), "--out", str(tmp_path / "replay")]) == 0
    replayed, recorded = build_model(read_folder(tmp_path / "replay")), build_model(read_folder(runs["demo"]))
    assert replayed.source == "replay"
    assert replayed.legs.tobytes() == recorded.legs.tobytes()  # NaN columns: compared as bytes
    assert np.array_equal(replayed.current.t, recorded.current.t)


def test_the_payload_is_aligned_columns_and_the_same_bytes_every_time(runs, tmp_path):
    """vcran/view/pack.py's layout: uint32 length, JSON, columns at multiples of 8; a second run of the same
    scenario gives a byte-identical page (docs/contract.md §5)."""
    model = build_model(read_folder(runs["warehouse"]))
    raw = zlib.decompress(base64.b64decode(payload(model)))
    assert raw == packed(model)
    n = struct.unpack("<I", raw[:4])[0]
    meta = json.loads(raw[4:4 + n])
    base = -(-(4 + n) // 8) * 8
    assert meta["format"] == "vcran-view" and meta["columns"]
    for name, (_, offset, _) in meta["columns"].items():
        assert offset % 8 == 0, name
    code, offset, length = meta["columns"]["legs.t"]
    legs_t = np.frombuffer(raw, dtype="<f8", count=length, offset=base + offset)
    assert np.array_equal(np.sort(legs_t), np.sort(read_folder(runs["warehouse"]).legs["t"]))
    again = build_model(read_folder(bundled("warehouse", tmp_path / "again")))
    assert again.title != model.title  # it names the folder
    again.title = model.title
    assert packed(again) == packed(model)
    assert page_html(runs["demo"]) == page_html(runs["demo"])


def test_folders_that_cannot_be_shown_are_one_clear_error(runs, tmp_path):
    with pytest.raises(ViewError, match="no such folder"):
        read_folder(tmp_path / "missing")
    (tmp_path / "empty").mkdir()
    with pytest.raises(ViewError, match="not a run folder"):
        read_folder(tmp_path / "empty")
    broken = tmp_path / "broken"
    managed(runs["warehouse"], broken)
    write_lines(broken / EVENTS_FILE, ['{"t": 1.0, "robot": "r"}'])
    with pytest.raises(ViewError, match=r"events.jsonl.zst:1: not an event"):
        read_folder(broken)


def test_a_format_1_recording_is_shown_with_a_note_that_its_robots_stay_put():
    """tests/data/v1-demo (format 1: telemetry.bin, no leg log): tasks and states shown, robots not moving."""
    model = build_model(read_folder(ROOT / "tests" / "data" / "v1-demo"))
    assert any("format 1" in note for note in model.notes)
    assert model.legs is None and model.geometry
    assert [model.tasks.labels[k] for k in model.tasks.label] == ["100", "200", "300"]
