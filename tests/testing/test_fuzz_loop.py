"""Fuzzing the loop (docs/contract.md §9, issue 10 item 7): the properties catch deliberately broken managers, pass
the reference dispatcher, and the search shrinks a failure to a minimal scenario."""

from __future__ import annotations

import re
import tomllib
from dataclasses import replace

import pytest
from hypothesis import given, settings

import vcran
from tests.conftest import ROOT
from tests.testing.loop_managers import ForgetsMotionFailures, NeverReplans, OutOfRange
from vcran.core.scenario import Job
from vcran.io.scenario_file import parse
from vcran.io.scenario_toml import dumps, loop_dict
from vcran.managers import Dispatcher
from vcran.testing.loop import (
    assert_loop_properties,
    check_jobs_ended,
    check_no_idle_while_waiting,
    check_protocol,
    fault_lists,
    fuzz_manager,
    loop_variants,
)

WAREHOUSE = vcran.load_scenario(ROOT / "scenarios" / "warehouse.toml")


def few_jobs(*jobs: Job, empty: tuple[str, ...] = ()) -> vcran.Scenario:
    """The warehouse with listed jobs only, lines in ``empty`` without parts or production, 900 s at most."""
    stations = tuple(replace(s, parts=0, produce_every=0.0) if s.id in empty else s for s in WAREHOUSE.stations)
    return replace(WAREHOUSE, jobs=jobs, job_stream=None, stations=stations,
                   settings=replace(WAREHOUSE.settings, duration=900.0))


TWO = (Job(0.0, "a", "line_1", "dock_1"), Job(5.0, "b", "line_2", "dock_2"))


class _Result:
    """A stand-in for vcran.Result with hand-written events (the idle property, by first principles)."""

    def __init__(self, events: list[dict], sim_time: float, robots=("r1",)) -> None:
        self.events, self.robots, self.summary, self.jobs = events, robots, {"sim_time": sim_time}, ()


def test_out_of_range_sequence_numbers_are_caught_as_protocol_errors():
    result = vcran.simulate(few_jobs(*TWO), manager=OutOfRange)
    problems = check_protocol(result)
    # two jobs, each a motion and an action numbered 3 of 2: four malformed inputs, none applied (R12)
    assert len(problems) == 4, problems
    assert all("ran_error malformed" in p and "sequence_number" in p for p in problems)
    assert check_protocol(vcran.simulate(few_jobs(*TWO), manager=Dispatcher)) == []


def test_a_job_never_replanned_after_a_cancel_is_caught():
    scenario = few_jobs(Job(0.0, "a", "line_1", "dock_1"), empty=("line_1",))  # the load fails: action_failed
    broken = vcran.simulate(scenario, manager=NeverReplans)
    assert broken.job("a").outcome == "open"
    [ended] = check_jobs_ended(broken)
    assert "job a" in ended and "never ended" in ended
    idle = check_no_idle_while_waiting(broken, bound=60.0)
    assert idle and all("while job a waited" in p for p in idle)
    with_retries = vcran.simulate(scenario, manager=Dispatcher)  # tries three times, then reports it failed
    assert with_retries.job("a").outcome == "failed"
    assert check_jobs_ended(with_retries) == []
    assert_loop_properties(with_retries)


def test_idle_while_waiting_counts_only_the_overlap_of_idle_robot_and_waiting_job():
    # r1 idles 0..100 (then works); job j waits from its arrival at 10 until assigned at 100: overlap 90 s
    events = [
        {"t": 10.0, "robot": "", "event": "job_arrived", "job": "j"},
        {"t": 100.0, "robot": "r1", "event": "job_assigned", "job": "j", "task": "t1"},
        {"t": 100.0, "robot": "r1", "event": "state", "from": "WAITING", "to": "TASK"},
        {"t": 150.0, "robot": "r1", "event": "state", "from": "TASK", "to": "WAITING"},
        {"t": 150.0, "robot": "r1", "event": "task_cancelled", "task": "t1", "reason": "action_failed"},
    ]
    # the cancelled task puts j back to waiting at 150, with r1 idle from 150 to the end at 200: 50 s
    assert len(check_no_idle_while_waiting(_Result(events, 200.0), bound=89.0)) == 1
    assert check_no_idle_while_waiting(_Result(events, 200.0), bound=90.0) == []
    late = check_no_idle_while_waiting(_Result(events, 220.0), bound=60.0)  # 150..220: 70 s
    assert len(late) == 2 and "from t=150 to t=220" in late[1]


def test_a_robot_out_of_reach_is_not_idle():
    # r1 idles 0..100 while j waits from 10; its link is down 30..75 and it breaks down 80..90 (docs/contract.md §4): the
    # manager could use it 10..30, 75..80 and 90..100, at most 20 s at a stretch; a fault that applied to
    # nothing, and another robot's outage, cut nothing
    events = [
        {"t": 10.0, "robot": "", "event": "job_arrived", "job": "j"},
        {"t": 30.0, "robot": "r1", "event": "fault", "kind": "link_down", "duration": 45.0},
        {"t": 40.0, "robot": "r2", "event": "fault", "kind": "link_down", "duration": 50.0},
        {"t": 50.0, "robot": "r1", "event": "fault", "kind": "breakdown", "duration": 9.0, "applied": False},
        {"t": 75.0, "robot": "r1", "event": "fault_end", "kind": "link_down"},
        {"t": 80.0, "robot": "r1", "event": "fault", "kind": "breakdown", "duration": 10.0},
        {"t": 90.0, "robot": "r1", "event": "fault_end", "kind": "breakdown"},
        {"t": 90.0, "robot": "r2", "event": "fault_end", "kind": "link_down"},
        {"t": 100.0, "robot": "r1", "event": "job_assigned", "job": "j", "task": "t1"},
        {"t": 100.0, "robot": "r1", "event": "state", "from": "WAITING", "to": "TASK"},
    ]
    assert check_no_idle_while_waiting(_Result(events, 100.0), bound=20.0) == []
    [problem] = check_no_idle_while_waiting(_Result(events, 100.0), bound=19.0)
    assert "r1 idle from t=10 to t=30" in problem
    # r2 idles 0..100 (never assigned) with its link down 40..90: 10..40 is 30 s, 90..100 10 s
    [r2] = check_no_idle_while_waiting(_Result(events, 100.0, robots=("r1", "r2")), bound=29.0)
    assert "r2 idle from t=10 to t=40" in r2
    # a link still down when the run ends (j never assigned) cuts r1's idle time from 30 to the end at 200
    assert check_no_idle_while_waiting(_Result(events[:2], 200.0), bound=20.0) == []
    assert len(check_no_idle_while_waiting(_Result(events[:1], 200.0), bound=20.0)) == 1


def test_an_empty_battery_cuts_a_robots_idle_stretch_until_its_swap():
    """docs/contract.md §4: a robot out of service (its battery empty) is not idle for a job; one never swapped stays out."""
    events = [{"t": 0.0, "robot": "", "event": "job_arrived", "job": "j"},
              {"t": 30.0, "robot": "r1", "event": "battery_empty", "x": 0.0, "y": 0.0},
              {"t": 75.0, "robot": "r1", "event": "battery_swapped"}]
    assert check_no_idle_while_waiting(_Result(events, 100.0), bound=30.0) == []
    assert [p.split(" (")[0] for p in check_no_idle_while_waiting(_Result(events, 100.0), bound=24.0)] == [
        "r1 idle from t=0 to t=30", "r1 idle from t=75 to t=100"]
    assert check_no_idle_while_waiting(_Result(events[:2], 200.0), bound=30.0) == []


def test_rejections_while_a_robots_link_is_down_are_the_outages():
    # r1's link is down 20..65: the manager's writes held meanwhile are judged at 65 against a task that
    # timed out (R9), which it could not know; the same rejection a moment later, or on r2, is its own
    def rejected(t: float, robot: str) -> dict:
        return {"t": t, "robot": robot, "event": "rejected", "code": "task_cancelled", "task": "t1",
                "message": "task t1 was already cancelled, reason timeout"}

    outage = [{"t": 20.0, "robot": "r1", "event": "fault", "kind": "link_down", "duration": 45.0},
              {"t": 65.0, "robot": "r1", "event": "fault_end", "kind": "link_down"}]
    assert check_protocol(_Result([*outage, rejected(40.0, "r1"), rejected(65.0, "r1")], 100.0)) == []
    late = check_protocol(_Result([*outage, rejected(65.5, "r1"), rejected(40.0, "r2")], 100.0))
    assert [p.split(":")[0] for p in late] == ["t=65.5 r1", "t=40 r2"]


def test_a_job_cancelled_out_of_the_managers_sight_waits_from_when_the_link_is_back():
    # j runs on r1 from 5; r1's link is down 20..70 and its task is cancelled at 25, unseen until 70; r2
    # idles throughout and gets j at 100: for the manager j waited 70..100 (30 s), not 25..100 (75 s)
    events = [
        {"t": 0.0, "robot": "", "event": "job_arrived", "job": "j"},
        {"t": 5.0, "robot": "r1", "event": "job_assigned", "job": "j", "task": "t1"},
        {"t": 5.0, "robot": "r1", "event": "state", "from": "WAITING", "to": "TASK"},
        {"t": 20.0, "robot": "r1", "event": "fault", "kind": "link_down", "duration": 50.0},
        {"t": 25.0, "robot": "r1", "event": "state", "from": "TASK", "to": "WAITING"},
        {"t": 25.0, "robot": "r1", "event": "task_cancelled", "task": "t1", "reason": "motion_failed"},
        {"t": 70.0, "robot": "r1", "event": "fault_end", "kind": "link_down"},
        {"t": 100.0, "robot": "r2", "event": "job_assigned", "job": "j", "task": "t2"},
        {"t": 100.0, "robot": "r2", "event": "state", "from": "WAITING", "to": "TASK"},
    ]
    both = ("r1", "r2")
    assert check_no_idle_while_waiting(_Result(events, 100.0, robots=both), bound=30.0) == []
    late = check_no_idle_while_waiting(_Result(events, 100.0, robots=both), bound=29.0)
    assert [p.split(" (")[0] for p in late] == ["r1 idle from t=70 to t=100", "r2 idle from t=70 to t=100"]
    # the same cancel seen at once (no outage): j waits 25..100 and r2 idles all of it
    seen = [e for e in events if e["event"] not in ("fault", "fault_end")]
    assert "r2 idle from t=25 to t=100" in check_no_idle_while_waiting(_Result(seen, 100.0, robots=both), bound=60.0)[-1]


@pytest.mark.slow
@settings(max_examples=8)
@given(loop_variants(WAREHOUSE, max_jobs=4, horizon=120.0, settle=400.0))
def test_the_dispatcher_keeps_the_loop_properties(scenario):
    assert_loop_properties(vcran.simulate(scenario))  # the warehouse's own [manager]: the Dispatcher


@settings(max_examples=20)
@given(loop_variants(replace(WAREHOUSE, settings=replace(WAREHOUSE.settings, duration=20.0)), horizon=300.0))
def test_a_drawn_variant_of_a_short_scenario_saves_to_a_file_that_loads(scenario):
    """Jobs and faults after the run's end are load errors (docs/scenarios.md): the draws stay within a
    base shorter than the horizon, or a saved failing scenario (vcran fuzz) would not load again."""
    assert all(j.t <= 20.0 for j in scenario.jobs) and all(f.t <= 20.0 for f in scenario.faults)
    again = parse(tomllib.loads(dumps(loop_dict(scenario))), "<saved>")
    assert again.jobs == scenario.jobs and again.faults == scenario.faults


def test_the_search_shrinks_a_never_replanning_manager_to_one_job_at_an_empty_line():
    small = replace(WAREHOUSE, robots=WAREHOUSE.robots[:2])  # two robots: the shrinking runs stay cheap
    finding = fuzz_manager(small, NeverReplans, examples=30, seed=1, max_jobs=3, horizon=30.0, settle=90.0)
    assert finding is not None
    [job] = finding.scenario.jobs
    stock = {s.id: s.parts for s in finding.scenario.stations}
    assert stock[job.pickup] == 0 and job.t == 0.0
    assert any("never ended" in p for p in finding.problems)
    # written back as a scenario file, it loads to the same scenario and fails the same way
    text = dumps(loop_dict(finding.scenario))
    again = parse(tomllib.loads(text), "<saved>")
    assert again.jobs == finding.scenario.jobs and again.link == finding.scenario.link
    assert check_jobs_ended(vcran.simulate(again, manager=NeverReplans))


# --- docs/contract.md §4 faults in the loop -------------------------------------------------------------------------------

LANE = parse(tomllib.loads("""
[simulation]
duration = 400.0
[simulation.action_durations]
load = 2.0
unload = 2.0
[[robots]]
id = "robot_1"
pose = [0.0, 0.0, 0.0]
max_velocity = 1.0
[[robots]]
id = "robot_2"
pose = [5.0, 0.0, 0.0]
max_velocity = 1.0
[[stations]]
id = "a"
position = [0.0, 10.0]
produce_every = 1.0
capacity = 100
[[stations]]
id = "b"
position = [0.0, -10.0]
capacity = 100
[manager]
class = "vcran.managers:Dispatcher"
"""), "<lane>")


@pytest.mark.slow
@settings(max_examples=15)
@given(loop_variants(LANE, max_jobs=3, horizon=60.0, settle=300.0, max_faults=4))
def test_s4_drawn_faults_all_happen_and_the_dispatcher_keeps_the_loop_properties(scenario):
    result = vcran.simulate(scenario)
    assert_loop_properties(result)
    due = [f for f in scenario.faults if f.t <= result.summary["sim_time"]]  # an idle run may end before some
    assert len([e for e in result.events if e["event"] == "fault"]) == len(due)


@pytest.mark.slow
def test_s4_the_search_finds_a_manager_that_forgets_a_job_after_a_motion_failure():
    # a part is produced every second, so no load fails for long: only a drawn motion failure (while a
    # robot drives) can leave a job open with this manager
    finding = fuzz_manager(LANE, ForgetsMotionFailures, examples=150, seed=1, max_jobs=2, horizon=30.0, settle=120.0)
    assert finding is not None
    [job] = finding.scenario.jobs
    [fault] = finding.scenario.faults
    assert fault.kind == "motion_failure" and any("never ended" in p for p in finding.problems)
    again = parse(tomllib.loads(dumps(loop_dict(finding.scenario))), "<saved>")  # what vcran fuzz --save writes
    assert again.faults == finding.scenario.faults and check_jobs_ended(vcran.simulate(again, manager=ForgetsMotionFailures))
    assert fuzz_manager(LANE, Dispatcher, examples=150, seed=1, max_jobs=2, horizon=30.0, settle=120.0) is None


@pytest.mark.slow
def test_loop_variants_of_a_path_and_a_negative_bound_are_clear_errors():
    """vcran.simulate takes a path, so a user passes one here too: it was "AttributeError: 'str' object has
    no attribute 'job_stream'" from inside hypothesis. A negative bound listed every robot, over stretches
    'from t=24.81 to t=24.1'."""
    @given(loop_variants("scenarios/warehouse.toml"))  # type: ignore[arg-type]
    def drawn(scenario):
        pass

    with pytest.raises(TypeError, match=r"loop_variants: base must be a vcran.Scenario \(vcran.load_scenario\(path\)\), "
                                        "got str 'scenarios/warehouse.toml'"):
        drawn()
    result = vcran.simulate(ROOT / "scenarios" / "warehouse.toml")
    with pytest.raises(ValueError, match="bound must be a number of seconds >= 0, got -1"):
        check_no_idle_while_waiting(result, bound=-1)


@pytest.mark.parametrize(("strategy", "says"), [
    (lambda base: loop_variants(base, max_jobs=0), "max_jobs must be at least 1, got 0"),
    (lambda base: loop_variants(base, horizon=float("inf")), "horizon must be a finite number of seconds >= 0, got inf"),
    (lambda base: loop_variants(base, horizon=-1.0), "horizon must be a finite number of seconds >= 0, got -1.0"),
    (lambda base: fault_lists(["robot_1"], max_faults=-1), "max_faults must be at least 0, got -1"),
    # settle=nan made the run's duration nan, settle=-1 ended it before the last jobs, max_faults=-1 meant none
    (lambda base: loop_variants(base, settle=float("nan")), "settle must be a finite number of seconds >= 0, got nan"),
    (lambda base: loop_variants(base, settle=-1.0), "settle must be a finite number of seconds >= 0, got -1.0"),
    (lambda base: loop_variants(base, max_faults=-1), "max_faults must be at least 0, got -1"),
    (lambda base: fault_lists(["robot_1"], horizon=float("nan")), "horizon must be a finite number of seconds >= 0, got nan"),
    # finite, but not in tenths of a second: int(horizon * 10) overflowed as inf did
    (lambda base: loop_variants(base, horizon=1e308), "horizon 1e+308 s is too large: instants are drawn at tenths of "
                                                      "a second up to it"),
])
def test_strategy_options_out_of_range_are_clear_errors(strategy, says):
    """``max_jobs=0`` failed inside hypothesis (min_size=1 > max_size=0), ``horizon=inf`` with an
    OverflowError (arrival tenths up to int(horizon * 10)), a negative horizon had nothing to draw from;
    on a scenario without a duration, where the horizon is not cut to it."""
    open_ended = replace(WAREHOUSE, settings=replace(WAREHOUSE.settings, duration=None))

    @settings(max_examples=1, database=None)
    @given(strategy(open_ended))
    def drawn(value):
        pass

    with pytest.raises(ValueError, match=f"^{re.escape(says)}\n"):  # then hypothesis's note
        drawn()


@settings(max_examples=10)
@given(loop_variants(vcran.load_scenario(ROOT / "scenarios" / "warehouse-faults.toml"), horizon=60.0, settle=60.0))
def test_a_variant_keeps_only_the_base_faults_within_its_end(scenario):
    """warehouse-faults pauses robot_8 at 1800 s: a variant of 120 s kept that pause, and vcran.simulate refused
    the variant ('the fault happens at t = 1800, after the run ends'): every example of vcran fuzz crashed."""
    assert all(f.t <= 120.0 for f in scenario.faults) and len(scenario.random_faults) == 4
    again = parse(tomllib.loads(dumps(loop_dict(scenario))), "<saved>")
    assert again.faults == scenario.faults
