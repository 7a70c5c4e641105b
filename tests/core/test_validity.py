"""Issue 30 item 3: every rule a scenario must satisfy lives on the model (:func:`vcran.core.validity.validate`).

Each family of rules is broken twice, once in a scenario file's table and once in a Scenario built in code
(``dataclasses.replace`` of the loaded one): the file is refused with ``<file>: `` and the message, the model
with the same message, and ``vcran.simulate`` refuses the model with ``<source> (as given): `` and it,
without writing the scenario back to TOML. The expected messages are the reader's wording from before
issue 30 (pinned by tests/io, tests/commands/test_cli_errors.py, tests/test_api.py); their figures are
worked out from the bundled scenarios by hand in the comments.
"""

from __future__ import annotations

import copy
import math
import tomllib
from collections.abc import Callable
from dataclasses import replace
from typing import Any

import pytest

import vcran
from tests.conftest import ROOT
from vcran.core.battery import BatteryConfig
from vcran.core.faults import FaultSpec, RandomFaults
from vcran.core.scenario import Cycle, Job, ManagerSpec, Scenario
from vcran.core.validity import Problem, validate
from vcran.io.scenario_file import ScenarioError, parse

Data = dict[str, Any]


def data(name: str) -> Data:
    with (ROOT / "scenarios" / f"{name}.toml").open("rb") as f:
        return tomllib.load(f)


def model(name: str) -> Scenario:
    return vcran.load_scenario(ROOT / "scenarios" / f"{name}.toml")


def refused(d: Data) -> str:
    """What the reader says of the file ``d``, without the file's name."""
    with pytest.raises(ScenarioError) as caught:
        parse(d, "<file>")
    text = str(caught.value)
    assert text.startswith("<file>: ")
    return text[len("<file>: "):]


def told(sc: Scenario) -> str:
    problems = validate(sc)
    assert problems, "the model took the mistake"
    return str(problems[0])


def _set(*path: Any, value: Any) -> Callable[[Data], None]:
    def change(d: Data) -> None:
        for key in path[:-1]:
            d = d[key]
        d[path[-1]] = value
    return change


def _robot(i: int, **kw: Any) -> Callable[[Scenario], Scenario]:
    return lambda s: replace(s, robots=(*s.robots[:i], replace(s.robots[i], **kw), *s.robots[i + 1:]))


def _station(i: int, **kw: Any) -> Callable[[Scenario], Scenario]:
    return lambda s: replace(s, stations=(*s.stations[:i], replace(s.stations[i], **kw), *s.stations[i + 1:]))


def _settings(**kw: Any) -> Callable[[Scenario], Scenario]:
    return lambda s: replace(s, settings=replace(s.settings, **kw))


def _add_job(d: Data, **kw: Any) -> None:
    d.setdefault("jobs", []).append({"t": 1.0, "id": "j", "pickup": "line_1", "dropoff": "dock_1", **kw})


WAREHOUSE_STATIONS = "line_1, line_2, line_3, line_4, dock_1, dock_2, dock_3, dock_4"

# (name, bundled scenario, the file's change, the model's change, the message)
CASES: list[tuple[str, str, Callable[[Data], Any], Callable[[Scenario], Scenario], str]] = [
    # settings: a field's bound, a choice told its own way, the action durations' sub-table
    ("settings-bound", "warehouse", _set("simulation", "task_timeout", value=-1.0), _settings(task_timeout=-1.0),
     "simulation: field 'task_timeout': must be positive, got -1.0"),
    ("settings-seed-type", "warehouse", _set("simulation", "seed", value=1.5), _settings(seed=1.5),
     "simulation: field 'seed': expected an integer, got 1.5"),
    ("settings-collisions", "warehouse", _set("simulation", "collisions", value="boom"), _settings(collisions="boom"),
     "simulation: field 'collisions': expected one of 'report', 'stop', 'off', got 'boom'"),
    ("action-durations", "warehouse", _set("simulation", "action_durations", "load", value=-5.0),
     _settings(durations={"dummy": 1.0, "load": -5.0, "unload": 5.0}),
     "simulation.action_durations: field 'load': must be at least 0.0, got -5.0"),
    # robots: bounds, Orion's id rules, the charge hint, geometry, a relation between fields, uniqueness
    ("robot-bound", "warehouse", _set("robots", 2, "max_velocity", value=0.0), _robot(2, max_velocity=0.0),
     "robots[2]: field 'max_velocity': must be positive, got 0.0"),
    ("robot-orion-id", "warehouse", _set("robots", 2, "id", value="robot 3"), _robot(2, id="robot 3"),
     "robots[2]: field 'id': Invalid characters in entity id: robot ids are Orion entity ids"),
    ("robot-charge", "warehouse", _set("robots", 0, "actions", value=["load", "charge"]),
     _robot(0, actions=("load", "charge")),
     "robots[0]: field 'actions': 'charge' is not listed among a robot's actions: a robot with [robots.battery] "
     "can charge (docs/contract.md §4, docs/robots.md); the actions listed here are dummy, load, unload"),
    ("robot-footprint", "warehouse",  # a bow tie: its first and third edges cross at the origin
     _set("robots", 0, "footprint", value=[[0.5, 0.5], [-0.5, -0.5], [-0.5, 0.5], [0.5, -0.5]]),
     _robot(0, footprint=((0.5, 0.5), (-0.5, -0.5), (-0.5, 0.5), (0.5, -0.5))),
     "robots[0]: field 'footprint': its edges [0.5, 0.5]-[-0.5, -0.5] and [-0.5, 0.5]-[0.5, -0.5] cross or "
     "touch: not a simple polygon (docs/contract.md §4: a footprint is a simple polygon)"),
    ("robot-carrying", "warehouse", _set("robots", 0, "carrying", value=2), _robot(0, carrying=2),
     "robots[0]: field 'carrying': 2 exceeds capacity 1"),  # capacity defaults to 1
    ("robot-duplicate", "warehouse", _set("robots", 3, "id", value="robot_2"), _robot(3, id="robot_2"),
     "robots[3]: field 'id': duplicate id 'robot_2'"),
    ("battery", "warehouse", _set("robots", 1, "battery", value={"capacity": 1.0, "initial": 2.0}),
     _robot(1, battery=BatteryConfig(1.0, initial=2.0)),
     "robots[1].battery: field 'initial': 2.0 exceeds capacity 1.0"),
    ("battery-low", "warehouse", _set("robots", 1, "battery", value={"capacity": 1.0, "low": 1.0}),
     _robot(1, battery=BatteryConfig(1.0, low=1.0)),
     "robots[1].battery: field 'low': a fraction of capacity below 1 is needed, got 1.0"),
    # stations: line_2 holds up to 20 parts; its position is (-20, 4), its reach 1.2 m: a dock at (-17, 4) is 3 m off
    ("station-parts", "warehouse", _set("stations", 1, "parts", value=21), _station(1, parts=21),
     "stations[1]: field 'parts': 21 exceeds capacity 20"),
    ("station-dock", "warehouse", _set("stations", 1, "dock", value=[-17.0, 4.0]), _station(1, dock=(-17.0, 4.0, None)),
     "stations[1]: field 'dock': [-17, 4] is 3 m from the station's position [-20, 4], beyond its reach 1.2: a "
     "robot standing there cannot load or unload"),
    ("station-duplicate", "warehouse", _set("stations", 1, "id", value="line_1"), _station(1, id="line_1"),
     "stations[1]: field 'id': duplicate id 'line_1'"),
    ("station-roadmap", "warehouse", _set("stations", 0, "dock", value="N1"), _station(0, dock=None, dock_node="N1"),
     "stations[0]: field 'dock': names the roadmap node 'N1', but the scenario has no [roadmap]"),
    # the closed loop: the link, the manager, listed jobs, the job stream
    ("link", "warehouse", _set("link", "latency", value=-1.0), lambda s: replace(s, link=replace(s.link, latency=-1.0)),
     "link: field 'latency': must be positive, got -1.0"),
    ("link-inbound", "warehouse", _set("link", "inbound", value="pigeon"),
     lambda s: replace(s, link=replace(s.link, inbound="pigeon")),
     "link: field 'inbound': unknown inbound 'pigeon'; known: subscription, polling"),
    ("manager", "warehouse", _set("manager", "class", value="no colon"),
     lambda s: replace(s, manager=ManagerSpec("no colon")),
     "manager: field 'class': expected 'module:Class' (e.g. 'vcran.managers:Dispatcher'), got 'no colon'"),
    ("job-station", "warehouse", lambda d: _add_job(d, pickup="nowhere"),
     lambda s: replace(s, jobs=(Job(1.0, "j", "nowhere", "dock_1"),)),
     f"jobs[0]: field 'pickup': no station 'nowhere' in this scenario; stations: {WAREHOUSE_STATIONS}"),
    ("job-deadline", "warehouse", lambda d: _add_job(d, t=10.0, deadline=10.0),
     lambda s: replace(s, jobs=(Job(10.0, "j", "line_1", "dock_1", deadline=10.0),)),
     "jobs[0]: field 'deadline': 10.0 is not after the job's time 10.0 (a deadline is an absolute time)"),
    ("job-late", "warehouse", lambda d: _add_job(d, t=3600.5),  # the run lasts 3600 s
     lambda s: replace(s, jobs=(Job(3600.5, "j", "line_1", "dock_1"),)),
     "jobs[0]: field 't': the job arrives at t = 3600.5, after the run ends (duration = 3600)"),
    ("stream-rate", "warehouse", _set("job_stream", "rate", value=0.0),
     lambda s: replace(s, job_stream=replace(s.job_stream, rate=0.0)),
     "job_stream: field 'rate': must be positive, got 0.0"),
    ("stream-station", "warehouse", _set("job_stream", "pickup", value=["nowhere"]),
     lambda s: replace(s, job_stream=replace(s.job_stream, pickups=(("nowhere", 1.0),))),
     f"job_stream: field 'pickup': no station 'nowhere' in this scenario; stations: {WAREHOUSE_STATIONS}"),
    ("stream-prefix", "warehouse", lambda d: _add_job(d, id="job_3"),  # the stream names its jobs job_1, job_2, ...
     lambda s: replace(s, jobs=(Job(1.0, "job_3", "line_1", "dock_1"),)),
     "job_stream: field 'prefix': the stream names its jobs job_1, job_2, ...; [[jobs]] id 'job_3' would clash"),
    # faults: the fleet is robot_1 .. robot_4, the run 300 s
    ("fault-kind", "faults", _set("faults", 0, "kind", value="meteor"),
     lambda s: replace(s, faults=(FaultSpec(0.5, "robot_3", "meteor"), *s.faults[1:])),
     "faults[0]: field 'kind': unknown fault 'meteor'; known: breakdown, motion_failure, action_failure, pause, "
     "resume, trigger, link_down"),
    ("random-mean", "warehouse-faults", _set("random_faults", 0, "mtbf", value=1e-9),
     lambda s: replace(s, random_faults=(replace(s.random_faults[0], mtbf=1e-9), *s.random_faults[1:])),
     "random_faults[0]: field 'mtbf': must be at least 1e-06 s (R14: instants closer than 1 µs are one instant), "
     "got 1e-09"),
    ("random-robot", "warehouse-faults", _set("random_faults", 0, "robots", value=["ghost"]),
     lambda s: replace(s, random_faults=(RandomFaults("breakdown", 900.0, 30.0, ("ghost",)), *s.random_faults[1:])),
     "random_faults[0]: field 'robots': no robot 'ghost' in this scenario"),
    # the script: demo's first entry is a motion for robot_1 at t = 1
    ("script-robot", "demo", _set("script", 0, "robot", value="ghost"),
     lambda s: replace(s, script=(replace(s.script[0], robot="ghost"), *s.script[1:])),
     "script[0]: field 'robot': no robot 'ghost' in this scenario (R11); robots: robot_1"),
    # the whole scenario: how it ends, who plays the fleet manager's part
    ("no-end", "demo", lambda d: d["simulation"].update(until_idle=False) or d["simulation"].pop("duration"),
     _settings(until_idle=False, duration=None), "[simulation]: set duration, or until_idle = true"),
    ("script-and-loop", "demo", lambda d: _add_job(d, pickup="conveyor_1", dropoff="conveyor_2"),
     lambda s: replace(s, jobs=(Job(1.0, "j", "conveyor_1", "conveyor_2"),)),
     "[[script]] and a closed loop ([[jobs]], [job_stream], [manager]) exclude each other: a script plays the "
     "fleet manager's part, jobs go to a fleet manager"),
    ("paused-forever", "faults",  # without a duration, robot_3's pause at t = 3 must be resumed: drop the resume
     lambda d: d["simulation"].pop("duration") and d.update(faults=[f for f in d["faults"] if f["kind"] != "resume"]),
     lambda s: replace(s, settings=replace(s.settings, duration=None),
                       faults=tuple(f for f in s.faults if f.kind != "resume")),
     "[[faults]]: robot_3 is paused at t = 3 and never resumed, and [simulation] has no duration: with until_idle "
     "the run would never end once the robot has work; add a resume or a duration"),
]


@pytest.mark.parametrize(("name", "scenario", "in_file", "in_code", "message"),
                         CASES, ids=[c[0] for c in CASES])
def test_a_scenario_built_in_code_is_told_what_its_file_is_told(name: str, scenario: str, in_file: Any,
                                                                 in_code: Any, message: str) -> None:
    d = copy.deepcopy(data(scenario))
    in_file(d)
    assert refused(d) == message
    assert told(in_code(model(scenario))) == message


def test_simulate_refuses_a_scenario_built_in_code_without_writing_it_back(monkeypatch: pytest.MonkeyPatch) -> None:
    """vcran.simulate checked a Scenario by writing it back as TOML and reading that; no more."""
    import vcran.io.scenario_toml as writer

    def never(*_: Any) -> None:
        raise AssertionError("the scenario was written back to TOML")

    monkeypatch.setattr(writer, "loop_dict", never)
    monkeypatch.setattr(writer, "scenario_dict", never)
    for _, scenario, _, in_code, message in CASES:
        sc = in_code(model(scenario))
        with pytest.raises(ScenarioError) as caught:
            vcran.simulate(sc)
        assert str(caught.value) == f"{sc.source} (as given): {message}"


def test_a_path_names_the_entry_as_the_file_lists_it() -> None:
    """The model holds faults, jobs and script entries in time order and a task's messages one entry each;
    a file is told its own [[section]] index. faults.toml lists its faults at t = 8, 10, 0.5, 3, 6, 0.5: in
    time order (equal times in file order) 0.5 (file 2), 0.5 (5), 3 (3), 6 (4), 8 (0), 10 (1)."""
    d = data("faults")
    d["faults"][0]["robot"] = "ghost"
    robots = "robots: robot_1, robot_2, robot_3, robot_4"
    assert refused(d) == f"faults[0]: field 'robot': no robot 'ghost' in this scenario; {robots}"
    s = model("faults")
    assert [f.t for f in s.faults] == [0.5, 0.5, 3.0, 6.0, 8.0, 10.0]
    ghost = replace(s, faults=(*s.faults[:4], replace(s.faults[4], robot="ghost"), s.faults[5]))
    assert told(ghost) == f"faults[4]: field 'robot': no robot 'ghost' in this scenario; {robots}"
    # the last [[script]] entry is a task: several messages of the model, one entry of the file
    d = data("faults")
    last = len(d["script"]) - 1
    assert d["script"][last]["kind"] == "task"
    d["script"][last]["robot"] = "ghost"
    assert refused(d) == f"script[{last}]: field 'robot': no robot 'ghost' in this scenario (R11); {robots}"
    # a cycle is the model's cycles[k], the file's [[script]] entry
    d = data("demo")
    d["script"].append({"t": 1.0, "robot": "robot_1", "kind": "cycle", "every": 10.0, "tasks": []})
    assert refused(d) == f"script[{len(d['script']) - 1}]: field 'tasks': a cycle needs at least one task"
    cycle = Cycle(1.0, "robot_1", 10.0, math.inf, "robot_1", ())
    assert told(replace(model("demo"), cycles=(cycle,))) == "cycles[0]: field 'tasks': a cycle needs at least one task"


def test_a_late_script_entry_is_told_of_the_file_entry_or_of_the_script() -> None:
    """A file's entry is one table (a task ends at its last message); the model's script is one sequence.
    demo.toml's sixth entry (script[5]) is its first after t = 5, an action sent at t = 6."""
    d = data("demo")
    d["simulation"]["duration"] = 5.0
    assert refused(d) == "script[5]: field 't': the entry is sent at t = 6, after the run ends (duration = 5)"
    demo = model("demo")
    assert told(replace(demo, settings=replace(demo.settings, duration=5.0))) == (
        "script: an entry is sent at t = 6, after the run ends (duration = 5)")


@pytest.mark.parametrize(("section", "change"), [
    ("jobs", lambda s: replace(s, job_stream=None, jobs=(Job(20.0, "a", "line_1", "dock_1"),
                                                         Job(5.0, "b", "line_2", "dock_2")))),
    ("faults", lambda s: replace(s, faults=tuple(reversed(s.faults)))),
])
def test_a_model_out_of_time_order_is_refused_not_run(section: str, change: Any) -> None:
    """A file's reader sorts them; in code, a job or fault listed after a later one fell due in the past
    mid-run (ValueError: time 5.0 is in the past (now 20.0)). faults.toml's in time order are at 0.5, 0.5, 3,
    6, 8, 10: reversed, the second (8) is the first before the one ahead of it (10)."""
    sc = change(model("warehouse" if section == "jobs" else "faults"))
    expected = {"jobs": "jobs[1]: field 't': 5 is before the time of jobs[0] (20): jobs are listed in time order",
                "faults": "faults[1]: field 't': 8 is before the time of faults[0] (10): faults are listed in time "
                          "order"}
    assert told(sc) == expected[section]
    with pytest.raises(ScenarioError, match="listed in time order"):
        vcran.simulate(sc)


def test_parts_of_the_wrong_kind_are_named_not_crashed_on() -> None:
    w = model("warehouse")
    a_dict: Any = {"id": "r"}
    assert told(replace(w, robots=(a_dict,))) == "robots[0]: expected a RobotConfig, got dict"
    assert told(replace(w, link=None)) == "field 'link': expected a LinkSettings, got NoneType"  # a part: a field
    assert told(replace(w, robots=(replace(w.robots[0], pose=(1.0, 2.0)),))) == (
        "robots[0]: field 'pose': expected [x, y, theta], got [1.0, 2.0]")


def test_the_bundled_scenarios_have_no_problem() -> None:
    for path in sorted((ROOT / "scenarios").glob("*.toml")):
        assert validate(vcran.load_scenario(path)) == [], path.name


@pytest.mark.parametrize(("problem", "line"), [
    (Problem("robots[2].battery.capacity", "must be positive, got 0"),
     "robots[2].battery: field 'capacity': must be positive, got 0"),
    (Problem("roadmap.edges[2]", "zero length"), "roadmap.edges[2]: zero length"),  # a whole entry
    (Problem("", "[simulation]: set duration"), "[simulation]: set duration"),  # the whole scenario
    (Problem("seed", "x"), "field 'seed': x"),
])
def test_a_problem_is_told_as_one_line(problem: Problem, line: str) -> None:
    assert str(problem) == line
    assert tuple(problem) == (problem.path, problem.message)
