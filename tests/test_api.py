"""``vcran.simulate`` and its ``Result`` (docs/contract.md §9, "The API"): in memory or into a run folder, the same run;
how a fleet manager is named; clear errors for scenarios and managers that cannot run."""

from __future__ import annotations

import json
import os
import re
import sys
import tomllib
from dataclasses import replace

import numpy as np
import pytest

import vcran
from tests.conftest import ROOT
from vcran.io.scenario_file import parse
from vcran.managers import Dispatcher

DEMO = ROOT / "scenarios" / "demo.toml"
WAREHOUSE = ROOT / "scenarios" / "warehouse.toml"

SMALL = """
[simulation]
duration = 200.0
until_idle = true
[[robots]]
id = "robot_1"
pose = [0.0, 0.0, 0.0]
max_velocity = 1.0
[[robots]]
id = "robot_2"
pose = [0.0, 3.0, 0.0]
[[stations]]
id = "a"
position = [5.0, 0.0]
parts = 2
[[stations]]
id = "b"
position = [-5.0, 0.0]
[[jobs]]
t = 1.0
id = "j1"
pickup = "a"
dropoff = "b"
"""


def small(extra: str = "") -> vcran.Scenario:
    return parse(tomllib.loads(SMALL + extra), "<small>")


def test_in_memory_and_folder_runs_give_the_same_result(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    memory = vcran.simulate(small(), manager=Dispatcher())
    assert os.listdir(tmp_path) == []  # nothing written without out
    folder = vcran.simulate(small(), manager=Dispatcher(), out=tmp_path / "run")
    assert memory.out is None and folder.out == tmp_path / "run"
    assert memory.summary == folder.summary == json.loads((tmp_path / "run" / "summary.json").read_text())
    assert memory.events == folder.events and len(memory.events) == memory.event_count > 0
    assert np.array_equal(memory.telemetry, folder.telemetry)
    assert memory.jobs == folder.jobs


def test_a_vda5050_run_in_memory_has_the_telemetry_of_its_folder_run(tmp_path):
    """VDA 5050 vehicles publish no telemetry frame (docs/vda5050.md): an in-memory run's telemetry is evaluated
    from its legs as a folder run's is, bit for bit. By hand (tests/sim/test_vda5050_visualization.py's
    derivation): the bundled vda5050 vehicle takes order 100 at t = 1 and speeds up at 0.5 m/s² from home
    along +x, so at t = 2, 3, 4 it is 0.25, 1.0, 1.75 m along at 0.5, 1.0, 0.5 m/s."""
    memory = vcran.simulate("vda5050")
    folder = vcran.simulate("vda5050", out=tmp_path / "run")
    assert len(memory.telemetry) == int(memory.summary["sim_time"]) + 1  # one vehicle, one row a second from 0
    assert np.array_equal(memory.telemetry, folder.telemetry)
    early = memory.telemetry[1:5]
    assert list(early["t"]) == [1.0, 2.0, 3.0, 4.0]
    assert list(early["x"]) == pytest.approx([0.0, 0.25, 1.0, 1.75], abs=1e-9)
    assert list(early["v"]) == pytest.approx([0.0, 0.5, 1.0, 0.5], abs=1e-9)


def test_a_vda5050_closed_loop_in_memory_has_the_telemetry_of_its_folder_run(tmp_path):
    """The same in the closed loop, where the master (MasterControl, which hears states only) is sent no
    visualization: the telemetry comes from the legs either way."""
    from vcran.managers.vda5050 import MasterControl

    scenario = vcran.load_scenario("vda5050-warehouse")
    short = replace(scenario, settings=replace(scenario.settings, duration=300.0))
    memory = vcran.simulate(short, manager=MasterControl())
    folder = vcran.simulate(short, manager=MasterControl(), out=tmp_path / "run")
    assert memory.summary == folder.summary and memory.summary["jobs"]["completed"] > 0
    assert len(memory.telemetry) == len(scenario.robots) * (int(memory.summary["sim_time"]) + 1) > 0
    assert np.array_equal(memory.telemetry, folder.telemetry)


def test_telemetry_is_one_named_row_per_tick_and_robot():
    result = vcran.simulate(small(), manager=Dispatcher())
    tel = result.telemetry
    assert tel.dtype.names == ("t", "robot", "x", "y", "theta", "v", "w")
    ticks = int(result.summary["sim_time"]) + 1  # one frame a second from t = 0
    assert len(tel) == 2 * ticks
    assert list(tel["robot"][:4]) == ["robot_1", "robot_2", "robot_1", "robot_2"]
    first = tel[tel["t"] == 0.0]
    assert [(r["x"], r["y"]) for r in first] == [(0.0, 0.0), (0.0, 3.0)]
    final = result.summary["robots"]["robot_1"]["final_pose"]
    last = tel[(tel["robot"] == "robot_1")][-1]
    assert (last["x"], last["y"]) == pytest.approx((final["x"], final["y"]))


def test_job_records_and_kpis():
    result = vcran.simulate(small(), manager=Dispatcher())
    (record,) = result.jobs
    assert record is result.job("j1") and record.outcome == "completed" and record.robot == "robot_1"
    jobs = result.summary["jobs"]
    assert (jobs["arrived"], jobs["completed"], jobs["failed"], jobs["open"]) == (1, 1, 0, 0)
    assert jobs["lead_time"]["mean"] == jobs["lead_time"]["p95"] == record.lead_time
    assert jobs["done_per_hour"] == pytest.approx(3600.0 / result.summary["sim_time"])
    util = result.summary["utilisation"]
    assert util["robots"]["robot_2"] == 0.0 and 0.0 < util["robots"]["robot_1"] < 1.0
    assert util["fleet"] == pytest.approx(util["robots"]["robot_1"] / 2)
    with pytest.raises(KeyError, match="no job 'nope'"):
        result.job("nope")


@pytest.mark.parametrize("manager", ["vcran.managers:Dispatcher", Dispatcher, Dispatcher()])
def test_a_manager_is_an_instance_a_class_or_a_module_path(manager):
    assert vcran.simulate(small(), manager=manager).summary["jobs"]["completed"] == 1


def test_the_scenario_may_name_its_manager_and_options():
    extra = "\n[manager]\nclass = 'vcran.managers:Dispatcher'\noptions = { max_tries = 1 }\n"
    result = vcran.simulate(small(extra))
    assert result.summary["jobs"]["completed"] == 1
    empty = parse(tomllib.loads((SMALL + extra).replace("parts = 2", "parts = 0")), "<small>")
    assert vcran.simulate(empty).job("j1").tasks == ("j1_pick1",)  # max_tries = 1: no second try


def test_a_scripted_scenario_runs_its_script_unchanged(tmp_path):
    result = vcran.simulate(DEMO, out=tmp_path)
    assert "jobs" not in result.summary and result.jobs == ()
    assert result.summary["robots"]["robot_1"]["completed"] == ["100", "200", "300"]


@pytest.mark.parametrize("manager, message", [
    ("nowhere_at_all:X", "cannot import nowhere_at_all"),
    ("vcran.managers:Nope", "has no attribute 'Nope'"),
    ("vcran.managers", "expected 'module:Class'"),
    ("json:dumps", "is not a vcran.FleetManager subclass"),
])
def test_a_manager_that_cannot_be_found_is_a_manager_error(manager, message):
    with pytest.raises(vcran.ManagerError, match=message):
        vcran.simulate(small(), manager=manager)


class Misspelt(vcran.FleetManager):
    attributes = frozenset({"ran_stauts"})


class AString(vcran.FleetManager):
    attributes = "ran_status"  # type: ignore[assignment]


class AnInbound(vcran.FleetManager):
    attributes = frozenset({"motion_assignment"})


class OldNames(vcran.FleetManager):
    """Written before vcran took OPIL's own attribute names (docs/contract.md §2: a real OPIL planner reads these)."""

    attributes = frozenset({"assignment_status", "battery", "ran_status"})


@pytest.mark.parametrize("manager, message", [
    # in simulated time it was never told anything; under vcran manage the same class subscribed with an
    # empty condition, and Orion notified it of everything
    (Misspelt, r"attributes names 'ran_stauts', which no robot publishes \(robot_description, current_motion, "
               r"assignment_state, ran_status, ran_error, battery_state\)"),
    (AnInbound, "attributes names 'motion_assignment', which no robot publishes"),
    (OldNames, r"attributes names 'assignment_status', 'battery', which no robot publishes \(.*\); "
               r"'assignment_status' is now 'assignment_state' \(OPIL's own name\); 'battery' is now 'battery_state'"),
    (AString, "attributes must be a set of attribute names or None, got the string 'ran_status'"),
])
def test_attributes_a_robot_does_not_publish_are_a_manager_error(tmp_path, manager, message):
    for given in (manager, manager()):
        with pytest.raises(vcran.ManagerError, match=f"fleet manager [a-z_.]*test_api:{manager.__name__}: {message}"):
            vcran.simulate(small(), manager=given, out=tmp_path / "run")
    assert list(tmp_path.iterdir()) == []  # refused before the folder exists


def test_parse_scenario_of_toml_text_says_it_takes_a_table():
    with pytest.raises(vcran.ScenarioError, match=r"^<text>: expected the scenario as a table \(a dict, as "
                                                  r"tomllib.loads\(text\) gives\), got str$"):
        vcran.parse_scenario(SMALL, "<text>")


def test_manager_options_the_class_does_not_take_are_a_manager_error():
    with pytest.raises(vcran.ManagerError, match=r"cannot build fleet manager vcran.managers.dispatcher:Dispatcher"):
        vcran.simulate(small("\n[manager]\nclass = 'vcran.managers:Dispatcher'\noptions = { colour = 1 }\n"))


def test_scenarios_that_cannot_run_this_way_are_scenario_errors():
    with pytest.raises(vcran.ScenarioError, match="has jobs but no fleet manager"):
        vcran.simulate(small())
    with pytest.raises(vcran.ScenarioError, match="has a \\[\\[script\\]\\]"):
        vcran.simulate(DEMO, manager=Dispatcher())
    no_duration = SMALL.replace("duration = 200.0\n", "")
    with pytest.raises(vcran.ScenarioError, match="needs a duration"):
        vcran.simulate(parse(tomllib.loads(no_duration), "<small>"), manager=Dispatcher())


class Broken(vcran.FleetManager):
    def on_job(self, job) -> None:
        raise RuntimeError("boom")


def test_an_exception_in_the_manager_propagates_saying_where_and_when():
    with pytest.raises(RuntimeError, match="boom") as err:
        vcran.simulate(small(), manager=Broken())
    assert "in fleet manager Broken: on_job at t=1.0" in err.value.__notes__


@pytest.mark.slow
def test_warehouse_every_job_completes_and_the_run_replays_byte_for_byte(tmp_path):
    from vcran.cli import main

    result = vcran.simulate(WAREHOUSE, out=tmp_path / "run")
    jobs = result.summary["jobs"]
    assert len(result.summary["robots"]) == 10
    assert jobs["arrived"] > 150 and jobs["completed"] == jobs["arrived"] and jobs["failed"] == jobs["open"] == 0
    assert result.summary["errors"] == 0
    assert all(r.lead_time is not None and r.lead_time > 0 for r in result.jobs)
    assert main(["replay", str(tmp_path / "run" / "trace.jsonl.zst"), "--verify", "--quiet"]) == 0  # as docs/library.md


@pytest.mark.parametrize("module_text, message", [
    ("def broken(:\n", r"cannot import vcran_review_broken: SyntaxError: .*line 1"),
    ("raise RuntimeError('no database here')\n", r"cannot import vcran_review_broken: RuntimeError: no database here"),
])
def test_a_manager_module_that_fails_to_import_is_a_manager_error(tmp_path, monkeypatch, module_text, message):
    """The user's module, not vcran, is at fault: a ManagerError (exit 2), not an internal error (exit 70)."""
    (tmp_path / "vcran_review_broken.py").write_text(module_text)
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.delitem(sys.modules, "vcran_review_broken", raising=False)
    with pytest.raises(vcran.ManagerError, match=message):
        vcran.simulate(small(), manager="vcran_review_broken:Manager")


def test_manager_options_the_class_refuses_are_a_manager_error():
    """The Dispatcher checks its options with ValueError: max_tries = 0 in [manager] is bad input."""
    with pytest.raises(vcran.ManagerError, match=r"options \{'max_tries': 0\}: ValueError: max_tries must be at least 1"):
        vcran.simulate(small("\n[manager]\nclass = 'vcran.managers:Dispatcher'\noptions = { max_tries = 0 }\n"))


def test_a_scenario_changed_in_code_is_checked_as_its_file_would_be(tmp_path):
    # docs/library.md varies scenarios with dataclasses.replace; a value the loader refuses failed deep in
    # SimPy (a negative latency), with a ZeroDivisionError (rate 0) or not at all (seed 1.5)
    from dataclasses import replace

    w = vcran.load_scenario(ROOT / "scenarios" / "warehouse.toml")
    assert w.job_stream is not None
    for changed, message in [
        (replace(w, link=replace(w.link, latency=-1.0)), "link: field 'latency': must be positive, got -1.0"),
        (replace(w, link=replace(w.link, latency="0.1")), "link: field 'latency': expected a finite number"),
        (replace(w, job_stream=replace(w.job_stream, rate=0.0)), "field 'rate': must be positive"),
        (replace(w, settings=replace(w.settings, seed=1.5)), "simulation: field 'seed': expected an integer, got 1.5"),
    ]:
        with pytest.raises(vcran.ScenarioError, match=re.escape(message)):
            vcran.simulate(changed, out=tmp_path / "out")
        assert not (tmp_path / "out").exists() and not (tmp_path / "out.incomplete").exists()
    demo = vcran.load_scenario(DEMO)
    with pytest.raises(vcran.ScenarioError, match=re.escape("script: an entry is sent at t = 6, after the run ends (duration = 5)")):
        vcran.simulate(replace(demo, settings=replace(demo.settings, duration=5.0)))
    with pytest.raises(TypeError, match="scenario must be a path or a vcran.Scenario, got int"):
        vcran.simulate(42)  # type: ignore[arg-type]
    (tmp_path / "notes").mkdir()
    (tmp_path / "notes" / "todo.txt").write_text("mine")
    with pytest.raises(vcran.RunFolderError, match="not a vcran run folder"):
        vcran.simulate(DEMO, out=tmp_path / "notes")
    assert [p.name for p in (tmp_path / "notes").iterdir()] == ["todo.txt"]


@pytest.mark.slow
def test_runs_in_a_loop_do_not_keep_the_garbage_of_earlier_runs():
    # a sweep's worker, a fuzzing campaign and docs/library.md's hypothesis test run run after run in one
    # process; the collector freeze of each run (vcran.runner._quiet_collector) hid earlier runs' cycles from
    # full collections: 0.3 MB a demo run, gigabytes over the nightly fuzz profile. In a fresh process:
    code = (
        "import gc, vcran\n"
        "vcran.simulate('scenarios/demo.toml'); gc.collect()\n"
        "base = len(gc.get_objects())\n"
        "for _ in range(200):\n"
        "    vcran.simulate('scenarios/demo.toml')\n"
        "print(len(gc.get_objects()) - base)\n"
    )
    import subprocess

    grown = int(subprocess.run([sys.executable, "-c", code], cwd=ROOT, check=True, capture_output=True,
                               text=True).stdout)
    assert grown < 30_000  # GC_GROWTH (20,000) and a run's worth; without the amortised collection ~54,000
