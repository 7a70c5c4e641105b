"""Reports (issue 6): KPIs of the demo from first principles, the data the figures draw, the files written,
and the error paths of ``vcran report``."""

from __future__ import annotations

import csv
import json
import math
import shutil
import sys
import tomllib
from collections.abc import Callable
from pathlib import Path

import pytest

from tests.conftest import ROOT, Outputs, read_lines, run_scenario, write_lines
from tests.sim.test_scenarios import FLEET
from vcran.cli import main
from vcran.io.gen import generate
from vcran.io.scenario_file import load, parse
from vcran.io.trace import lines
from vcran.report import read_run, write_report
from vcran.report import timeline as timeline_module
from vcran.report.kpi import kpis
from vcran.report.layout import corners_by_robot, path_pieces
from vcran.report.spans import TaskSpan, histories
from vcran.report.tables import csv_text, markdown
from vcran.report.timeline import lanes, pages

DEMO_DISTANCE = 2 + 2 * math.sqrt(2) + 4 + 4 + 2 + 2 + 2  # 100: (0,0)-(2,0)-(4,2); 200: -(0,2)-(-4,2); 300: back home

#: test_scenarios' one-robot fleet, plus a second robot and a station with an area.
MIXED = FLEET + """
[[robots]]
id = "robot_2"
pose = [0.0, -5.0, 0.0]
max_velocity = 1.0
[[stations]]
id = "bay"
position = [8.0, -5.0]
area = [[7.0, -6.0], [9.0, -6.0], [9.0, -4.0], [7.0, -4.0]]
"""


def entry(t: float, robot: str, kind: str, task: str, **fields: object) -> str:
    body = "".join(f"{k} = {json.dumps(v)}\n" for k, v in fields.items())
    return f'\n[[script]]\nt = {t}\nrobot = "{robot}"\nkind = "{kind}"\ntask = "{task}"\n{body}'


#: robot_1: A cancelled mid-path (reason cancelled), B completed, T never assembled (timeout), F unloads
#: nothing (action_failed); robot_2: M inside a motion area, loads from an empty bay (action_failed).
MIXED_SCRIPT = MIXED + "".join([
    entry(1, "robot_1", "motion", "A", id="A_m1", seq=[1, 3], point=[5.0, 0.0, 0.0]),
    entry(1, "robot_1", "motion", "A", id="A_m2", seq=[2, 3], point=[5.0, 5.0, 0.0]),
    entry(1, "robot_1", "action", "A", id="A_a1", seq=[3, 3], action="dummy"),
    entry(2, "robot_1", "motion", "B", id="B_m1", seq=[1, 2], point=[5.0, 8.0, 0.0]),
    entry(2, "robot_1", "action", "B", id="B_a1", seq=[2, 2], action="dummy"),
    entry(3, "robot_1", "motion", "T", id="T_m1", seq=[1, 2], point=[1.0, 1.0, 0.0]),
    entry(7.5, "robot_1", "cancel", "A"),
    entry(40, "robot_1", "motion", "F", id="F_m1", seq=[1, 2], point=[10.0, 8.0, 0.0]),
    entry(40, "robot_1", "action", "F", id="F_a1", seq=[2, 2], action="unload"),
    entry(2, "robot_2", "motion", "M", id="M_m1", seq=[1, 3], point=[4.0, -5.0, 0.0],
          area=[[-1.0, -7.0], [6.0, -7.0], [6.0, -3.0], [-1.0, -3.0]]),
    entry(2, "robot_2", "motion", "M", id="M_m2", seq=[2, 3], point=[7.5, -5.0, 0.0]),
    entry(2, "robot_2", "action", "M", id="M_a1", seq=[3, 3], action="load"),
])


@pytest.fixture(scope="module")
def demo(tmp_path_factory: pytest.TempPathFactory) -> Outputs:
    return run_scenario(load(ROOT / "scenarios" / "demo.toml"), tmp_path_factory.mktemp("demo"))


@pytest.fixture(scope="module")
def mixed(tmp_path_factory: pytest.TempPathFactory) -> Outputs:
    return run_scenario(parse(tomllib.loads(MIXED_SCRIPT), "<mixed>"), tmp_path_factory.mktemp("mixed"))


def at(out: Outputs, name: str, task: str) -> float:
    (event,) = [e for e in out.events if e["event"] == name and e.get("task") == task]
    return float(event["t"])


# --- KPIs ---------------------------------------------------------------------------------------------


def test_demo_kpis_from_first_principles(demo: Outputs) -> None:
    run = read_run(demo.dir)
    robot, fleet = kpis(run, histories(run))
    assert robot.robot == "robot_1" and fleet.robot == "fleet"
    assert robot.completed == 3
    assert robot.cancelled == {"timeout": 0, "cancelled": 0, "action_failed": 0, "battery_empty": 0, "motion_failed": 0, "collision": 0,
                               "deadlock": 0}
    assert robot.distance == pytest.approx(DEMO_DISTANCE, abs=1e-9)
    assert robot.parts_moved == 1 and robot.errors == 0
    # The script sends the tasks at 1, 4 and 7 s; latency runs from there to each completion.
    done = [at(demo, "task_completed", task) for task in ("100", "200", "300")]
    assert robot.latency == pytest.approx(((done[0] - 1) + (done[1] - 4) + (done[2] - 7)) / 3)
    # WAITING until task 100 arrives at 1 s and after task 300 completes; every other WAITING lasts no time
    # (the next task starts at the same instant), so the robot is busy from 1 s to the last completion.
    sim_time = demo.summary["sim_time"]
    assert robot.busy_share == pytest.approx((done[2] - 1.0) / sim_time)
    assert robot.busy_share + robot.idle_share == pytest.approx(1.0)
    assert (fleet.completed, fleet.distance, fleet.busy_share, fleet.latency, fleet.parts_moved) == (
        robot.completed, robot.distance, robot.busy_share, robot.latency, robot.parts_moved)


def test_busy_share_is_the_time_outside_waiting_in_the_state_events(mixed: Outputs) -> None:
    run = read_run(mixed.dir)
    rows = {k.robot: k for k in kpis(run, histories(run))}
    sim_time = mixed.summary["sim_time"]
    for rid in ("robot_1", "robot_2"):
        waiting, since, state = 0.0, 0.0, "WAITING"
        for e in mixed.of("state", rid):
            waiting += (e["t"] - since) if state == "WAITING" else 0.0
            since, state = e["t"], e["to"]
        waiting += (sim_time - since) if state == "WAITING" else 0.0
        assert rows[rid].idle_share == pytest.approx(waiting / sim_time)
    # The fleet's share weighs every robot-second alike.
    assert rows["fleet"].busy_share == pytest.approx((rows["robot_1"].busy_share + rows["robot_2"].busy_share) / 2)


def test_cancellations_are_counted_by_reason(mixed: Outputs) -> None:
    run = read_run(mixed.dir)
    rows = {k.robot: k for k in kpis(run, histories(run))}
    assert rows["robot_1"].cancelled == {"timeout": 1, "cancelled": 1, "action_failed": 1, "battery_empty": 0, "motion_failed": 0, "collision": 0,
                                          "deadlock": 0}
    assert rows["robot_2"].cancelled == {"timeout": 0, "cancelled": 0, "action_failed": 1, "battery_empty": 0, "motion_failed": 0, "collision": 0,
                                          "deadlock": 0}
    assert rows["fleet"].cancelled == {"timeout": 1, "cancelled": 1, "action_failed": 2, "battery_empty": 0, "motion_failed": 0, "collision": 0,
                                          "deadlock": 0}
    assert rows["robot_1"].latency == pytest.approx(at(mixed, "task_completed", "B") - 2.0)
    assert rows["robot_2"].completed == 0 and rows["robot_2"].latency is None
    assert rows["fleet"].errors == mixed.summary["errors"] == 2


# --- what the figures draw ----------------------------------------------------------------------------


def test_task_spans_follow_r1_the_head_of_the_queue_becomes_current(mixed: Outputs) -> None:
    run = read_run(mixed.dir)
    spans = {s.task: s for s in histories(run)["robot_1"].tasks}
    assert [s.task for s in histories(run)["robot_1"].tasks] == ["A", "B", "T", "F"]
    assert (spans["A"].queued, spans["A"].started, spans["A"].outcome) == (1.0, 1.0, "cancelled")
    # A ends when its running leg does; B, queued at 2 s, is current from then to its completion.
    assert spans["B"].queued == 2.0 and spans["B"].started == spans["A"].end == at(mixed, "task_cancelled", "A")
    assert spans["B"].outcome == "completed" and spans["B"].end == at(mixed, "task_completed", "B")
    # T, first seen at 3 s, times out at 3 + 30 s and R14's 1 µs (an input at 33.0 would still be on time)
    assert spans["T"].started == spans["B"].end and spans["T"].outcome == "timeout" and spans["T"].end == 33.000001
    assert spans["F"].started == 40.0 and spans["F"].outcome == "action_failed"


def test_demo_paths_bend_at_the_targets_and_add_up_to_the_distance(demo: Outputs) -> None:
    run = read_run(demo.dir)
    history = histories(run)["robot_1"]
    pieces = path_pieces(run, 0, history, corners_by_robot(run)["robot_1"])
    assert [span.task for span, _ in pieces if span is not None] == ["100", "200", "300"]
    assert all(span is not None for span, _ in pieces)  # the robot never moved outside a task
    ends = [(tuple(p[0]), tuple(p[-1])) for _, p in pieces]
    assert ends == [((0, 0), (4, 2)), ((4, 2), (-4, 2)), ((-4, 2), (0, 0))]
    length = sum(float(math.fsum(math.dist(a, b) for a, b in zip(p[:-1], p[1:]))) for _, p in pieces)
    assert length == pytest.approx(DEMO_DISTANCE, abs=1e-9)


def test_a_corner_between_two_ticks_is_not_cut(run_toml) -> None:  # type: ignore[no-untyped-def]
    # Reaches (1.1, 0) at 2.1 s, turns 45 degrees in 0.79 s and is on its way before the 3 s tick.
    robot = '[[robots]]\nid = "robot_1"\npose = [0.0, 0.0, 0.0]\nmax_velocity = 1.0\nmax_angular_velocity = 1.0\n'
    out = run_toml("[simulation]\nuntil_idle = true\nduration = 60.0\n" + robot
                   + entry(1, "robot_1", "motion", "K", id="K_m1", seq=[1, 2], point=[1.1, 0.0, 0.0])
                   + entry(1, "robot_1", "motion", "K", id="K_m2", seq=[2, 2], point=[3.1, 2.0, 0.0]))
    run = read_run(out.dir)
    history = histories(run)["robot_1"]

    def length(corners: list[tuple[float, float, float]]) -> float:
        pieces = path_pieces(run, 0, history, corners)
        return sum(math.dist(a, b) for _, p in pieces for a, b in zip(p[:-1], p[1:]))

    assert length(corners_by_robot(run)["robot_1"]) == pytest.approx(out.robot()["distance"], abs=1e-9)
    assert length([]) < out.robot()["distance"] - 0.01  # the telemetry ticks alone cut the corner


def test_raw_inbound_records_of_a_live_run_are_decoded(demo: Outputs, tmp_path: Path) -> None:
    from vcran.core.opil.codec import encode_attribute
    from vcran.core.opil.messages import MotionAssignment
    from vcran.core.opil.plain import from_plain

    run_dir = tmp_path / "live"
    shutil.copytree(demo.dir, run_dir)
    path = run_dir / "trace.jsonl.zst"
    written = read_lines(path)
    for n, _, record in lines(path):  # records in full (format 2 writes what changed)
        if record.get("attr") == "motion_assignment":
            raw = encode_attribute("motion_assignment", from_plain(MotionAssignment, record.pop("value")))
            written[n - 1] = json.dumps({**record, "raw": raw})
    write_lines(path, written)
    assert read_run(run_dir).targets == read_run(demo.dir).targets != {}


def test_motion_areas_and_targets_come_from_the_inbound_assignments(mixed: Outputs) -> None:
    run = read_run(mixed.dir)
    (area,) = run.motion_areas
    assert area.robot == "robot_2" and area.points == ((-1.0, -7.0), (6.0, -7.0), (6.0, -3.0), (-1.0, -3.0))
    assert run.targets["robot_1", "B_m1"] == [(2.0, 5.0, 8.0)]
    s1, bay = run.stations
    assert (s1.id, s1.area, bay.id, bay.area[0]) == ("s1", (), "bay", (7.0, -6.0))


def test_overlapping_tasks_get_separate_lanes() -> None:
    def span(queued: float, end: float) -> TaskSpan:
        return TaskSpan("r", f"{queued}", queued, queued, end, "completed")

    # 0-10 and 2-5 overlap; 5-8 fits after 2-5; 10-12 fits after 0-10 (touching is not overlapping).
    assert lanes([span(0, 10), span(2, 5), span(5, 8), span(10, 12)]) == [0, 1, 1, 0]


def test_pages_hold_twenty_robots_up_to_the_limit() -> None:
    robots = tuple(f"r{i}" for i in range(45))
    assert [len(p) for p in pages(robots, 5)] == [20, 20, 5]
    assert [len(p) for p in pages(robots, 2)] == [20, 20]
    assert pages(robots[:3], 1) == [robots[:3]]


# --- files ---------------------------------------------------------------------------------------------


def test_report_of_the_demo_writes_figures_and_tables(demo: Outputs, tmp_path: Path,
                                                      capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["report", str(demo.dir), "--out", str(tmp_path / "rep")]) == 0
    names = sorted(p.name for p in (tmp_path / "rep").iterdir())
    assert names == ["kpi.csv", "kpi.md", "layout.png", "timeline.png"]
    for png in ("layout.png", "timeline.png"):
        data = (tmp_path / "rep" / png).read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 20_000  # a drawn figure, not a blank canvas
    rows = list(csv.DictReader((tmp_path / "rep" / "kpi.csv").open()))
    assert [r["robot"] for r in rows] == ["robot_1", "fleet"]
    assert rows[0]["completed"] == "3" and rows[0]["parts_moved"] == "1"
    assert float(rows[0]["distance_m"]) == pytest.approx(DEMO_DISTANCE, abs=1e-4)
    stdout = capsys.readouterr().out
    assert "| robot_1 " in stdout and "18.83" in stdout and "layout.png" in stdout
    assert (tmp_path / "rep" / "kpi.md").read_text().startswith("# KPIs: demo")


@pytest.mark.slow
def test_svg_format_and_the_same_run_gives_the_same_files(demo: Outputs, tmp_path: Path) -> None:
    report = write_report(demo.dir, tmp_path / "a", "svg")
    assert [f.name for f in report.files[:2]] == ["layout.svg", "timeline.svg"]
    assert all(f.read_text()[:200].lstrip().startswith("<?xml") for f in report.files[:2])
    again = write_report(demo.dir, tmp_path / "b", "svg")
    assert [f.read_bytes() for f in report.files] == [f.read_bytes() for f in again.files]


def test_tables_show_a_missing_latency_as_a_dash_and_an_empty_cell(mixed: Outputs) -> None:
    run = read_run(mixed.dir)
    rows = kpis(run, histories(run))
    robot_2 = markdown(rows).splitlines()[3]
    assert robot_2.startswith("| robot_2") and "–" in robot_2
    (record,) = [r for r in csv.DictReader(csv_text(rows).splitlines()) if r["robot"] == "robot_2"]
    assert record["mean_latency_s"] == "" and record["cancelled_action_failed"] == "1"


@pytest.mark.slow
def test_ten_robot_generated_run_is_paged(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    scenario = parse(tomllib.loads(generate(10, 0.05, 3)), "<gen>")
    out = run_scenario(scenario, tmp_path / "run")
    report = write_report(out.dir, tmp_path / "one-page")
    assert [f.name for f in report.files] == ["layout.png", "timeline.png", "kpi.md", "kpi.csv"]
    assert report.kpis[-1].completed == sum(len(r["completed"]) for r in out.summary["robots"].values()) > 0
    monkeypatch.setattr(timeline_module, "ROBOTS_PER_PAGE", 4)
    report = write_report(out.dir, tmp_path / "paged", timeline_pages=2)
    assert [f.name for f in report.files if f.name.startswith("timeline")] == ["timeline-01.png", "timeline-02.png"]
    assert report.robots_not_drawn == 2
    assert len(report.kpis) == 11  # every robot is in the tables, drawn or not


@pytest.mark.filterwarnings("error")
def test_a_run_where_nothing_happens_still_reports(run_toml) -> None:  # type: ignore[no-untyped-def]
    out = run_toml('[simulation]\nuntil_idle = true\nduration = 10.0\n[[robots]]\nid = "r"\npose = [0.0, 0.0, 0.0]\n')
    assert out.summary["sim_time"] == 0.0
    report = write_report(out.dir, out.dir / "report")
    (robot, _fleet) = report.kpis
    assert (robot.completed, robot.busy_share, robot.idle_share, robot.latency) == (0, 0.0, 1.0, None)


def test_run_with_report_flag_writes_into_the_run_folder(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["run", str(ROOT / "scenarios" / "demo.toml"), "--out", str(tmp_path), "--report", "--quiet"]) == 0
    assert {"layout.png", "timeline.png", "kpi.md", "kpi.csv"} <= {p.name for p in (tmp_path / "report").iterdir()}
    assert capsys.readouterr().out == ""


# --- errors --------------------------------------------------------------------------------------------


def report_error(args: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    assert main(["report", *args]) == 2
    captured = capsys.readouterr()
    assert "Traceback" not in captured.err and captured.out == ""
    return captured.err


def test_missing_folder(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    err = report_error([str(tmp_path / "nope"), "--out", str(tmp_path / "r")], capsys)
    assert "nope: no such folder" in err and err.startswith("vcran report: ")


@pytest.mark.parametrize(("damage", "expected"), [
    (lambda d: (d / "events.jsonl.zst").unlink(), "missing events.jsonl.zst"),
    (lambda d: (d / "legs.npy").write_bytes(b"\0" * 12), "legs.npy: not a vcran leg log"),
    (lambda d: (d / "trace.jsonl.zst").unlink(), "not a complete run folder, missing trace.jsonl.zst"),
    (lambda d: (d / "summary.json").write_text("{"), "summary.json: unreadable"),
    (lambda d: (d / "summary.json").write_text('{"sim_time": 1, "errors": 0, "robots": {"robot_1": {}}}'),
     "summary.json: unreadable (missing field 'final_pose')"),
    (lambda d: write_lines(d / "trace.jsonl.zst", ['{"format": "other"}']), "not a vcran trace"),
    (lambda d: write_lines(d / "events.jsonl.zst", ['{"t": 1, "robot": "r", "event": "task_queued", "task": "A"}', '[1]']),
     "events.jsonl.zst:2: not an event"),
    (lambda d: write_lines(d / "events.jsonl.zst", ["{oops"]), "events.jsonl.zst:1: not JSON"),
    # a report of the events before the cut (0 tasks done where the demo does 3), or exit 70 (ZstdError)
    (lambda d: (d / "events.jsonl.zst").write_bytes((d / "events.jsonl.zst").read_bytes()[:300]),
     "events.jsonl.zst: cut off: the zstd stream ends before its end"),
    (lambda d: (d / "events.jsonl.zst").write_bytes(b"hello"), "events.jsonl.zst: not a zstd stream"),
    # the report drew the motion targets and areas of the records before the cut
    (lambda d: (d / "trace.jsonl.zst").write_bytes((d / "trace.jsonl.zst").read_bytes()[:-20]),
     "trace.jsonl.zst: cut off: the zstd stream ends before its end"),
    (lambda d: write_lines(d / "events.jsonl.zst", ['{"t": 1, "robot": "robot_1", "event": "state", "from": "WAITING"}']),
     "events.jsonl.zst:1: state event without to"),
])
def test_damaged_run_folder(demo: Outputs, tmp_path: Path, capsys: pytest.CaptureFixture[str],
                            damage: Callable[[Path], object], expected: str) -> None:
    broken = tmp_path / "run"
    shutil.copytree(demo.dir, broken)
    damage(broken)
    assert expected in report_error([str(broken), "--out", str(tmp_path / "r")], capsys)


def test_missing_matplotlib_says_how_to_install_it(demo: Outputs, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.setitem(sys.modules, "matplotlib", None)  # import matplotlib now raises ImportError
    err = report_error([str(demo.dir), "--out", str(tmp_path / "r")], capsys)
    assert "pip install 'vcran[report]'" in err
    assert not (tmp_path / "r").exists()


def test_run_with_report_and_no_matplotlib_refuses_before_simulating(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                                      capsys: pytest.CaptureFixture[str]) -> None:
    """`vcran run --report` without the extra says so at once, not after a long run (issue 16)."""
    monkeypatch.setitem(sys.modules, "matplotlib", None)
    assert main(["run", str(ROOT / "scenarios" / "demo.toml"), "--out", str(tmp_path / "o"), "--report"]) == 2
    captured = capsys.readouterr()
    assert (captured.out, captured.err) == ("", "vcran run: figures need matplotlib, which is not installed: "
                                                "pip install 'vcran[report]'\n")
    assert not (tmp_path / "o").exists()


def test_vcran_run_never_imports_matplotlib(tmp_path: Path) -> None:
    """Startup time: the figures' dependency is loaded only when a report is asked for."""
    import subprocess

    code = ("import sys; from vcran.cli import main; "
            f"main(['run', {str(ROOT / 'scenarios' / 'demo.toml')!r}, '--out', {str(tmp_path)!r}, '--quiet']); "
            "sys.exit('matplotlib' in sys.modules)")
    assert subprocess.run([sys.executable, "-c", code], cwd=ROOT).returncode == 0
