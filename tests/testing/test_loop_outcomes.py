"""docs/contract.md §9's job-outcome properties (issue 29 item 6): a job is reported failed only with evidence, and
without faults a feasible workload completes every job. A manager that gives up, or never sends a task,
fails them; the reference Dispatcher keeps them."""

from __future__ import annotations

from dataclasses import replace

import pytest

import vcran
from tests.conftest import ROOT
from tests.sim.test_dispatcher import job, resting
from tests.testing.loop_managers import GivesUpAfterThePickup, GiveUp, NeverSends
from vcran.cli import main
from vcran.core.faults import FaultSpec
from vcran.core.scenario import Job
from vcran.io.scenario_toml import dumps, loop_dict
from vcran.managers import Dispatcher
from vcran.testing.loop import check_jobs_ended, check_no_idle_while_waiting, check_protocol, loop_problems
from vcran.testing.outcomes import check_failures_have_evidence, check_feasible_jobs_completed, infeasible

WAREHOUSE = vcran.load_scenario(ROOT / "scenarios" / "warehouse.toml")
TWO = (Job(0.0, "a", "line_1", "dock_1"), Job(5.0, "b", "line_2", "dock_2"))


def warehouse(*jobs: Job, duration: float = 900.0) -> vcran.Scenario:
    """The warehouse with listed jobs only (its lines hold 10 parts each at the start)."""
    return replace(WAREHOUSE, jobs=jobs, job_stream=None, settings=replace(WAREHOUSE.settings, duration=duration))


def test_a_manager_that_gives_up_on_every_job_breaks_only_the_new_properties():
    """It passed every property before (issue 29 item 6): each job ended (failed), no protocol error, no
    job ever waited."""
    result = vcran.simulate(warehouse(*TWO), manager=GiveUp)
    assert check_jobs_ended(result) == check_protocol(result) == check_no_idle_while_waiting(result) == []
    assert check_failures_have_evidence(result) == [
        f"job {j} reported failed (unassignable) at t={t:g} without evidence: no task was sent for it, and a robot "
        "could serve it" for j, t in (("a", 0.0), ("b", 5.0))]
    assert [p.split(" (")[0] for p in check_feasible_jobs_completed(result)] == ["job a", "job b"]


def test_a_manager_that_never_sends_a_task_leaves_feasible_jobs_open():
    result = vcran.simulate(warehouse(*TWO), manager=NeverSends)
    assert result.summary["sim_time"] == 900.0 and check_failures_have_evidence(result) == []
    [a, b] = check_feasible_jobs_completed(result)
    assert "job a (line_1 -> dock_1) arrived at t=0 and was not completed by the end at t=900" in a
    # the margin: b arrived 895 s before the end, a 900 s
    assert [p.split(" (")[0] for p in check_feasible_jobs_completed(result, margin=897.5)] == ["job a"]
    assert check_feasible_jobs_completed(result, margin=900.5) == []


def test_a_task_that_completed_is_no_evidence():
    result = vcran.simulate(warehouse(TWO[0]), manager=GivesUpAfterThePickup)
    [problem] = check_failures_have_evidence(result)
    assert problem.startswith("job a reported failed (cancelled) at t=")
    assert "none of its 1 task(s) (a_pick1) had ended without success by then" in problem


def test_a_failed_task_of_the_job_is_evidence_and_an_empty_line_makes_the_workload_infeasible():
    empty = replace(warehouse(TWO[0]), stations=tuple(replace(s, parts=0, produce_every=0.0) if s.id == "line_1" else s
                                                      for s in WAREHOUSE.stations))
    result = vcran.simulate(empty, manager=Dispatcher)  # three loads fail: action_failed, then the job fails
    assert result.job("a").outcome == "failed" and check_failures_have_evidence(result) == []
    assert infeasible(empty, result.jobs) == ["line_1 holds 0 part(s) at the start for 1 pickup(s)"]
    assert check_feasible_jobs_completed(result) == []


def test_infeasible_workloads_by_hand():
    # line_1 holds 10 parts: 11 pickups there are one too many; dock_1 holds 0 of capacity 2: room for 2
    eleven = tuple(Job(float(k), f"j{k}", "line_1", "dock_2") for k in range(11))
    stations = tuple(replace(s, capacity=2) if s.id == "dock_1" else s for s in WAREHOUSE.stations)
    three = tuple(Job(float(k), f"d{k}", "line_2", "dock_1") for k in range(3))
    records = [vcran.JobRecord(j) for j in eleven + three]
    assert infeasible(replace(WAREHOUSE, stations=stations), records) == [
        "line_1 holds 10 part(s) at the start for 11 pickup(s)",
        "dock_1 has room for 2 part(s) for 3 drop-off(s), after what it holds at the start and may produce"]
    # a line produces: without a produce_limit it may be full; with one, its parts to come take room
    to_lines = [vcran.JobRecord(Job(0.0, "x", "line_1", "line_3"))]
    assert infeasible(WAREHOUSE, to_lines) == ["line_3 produces parts without limit, so it may be full for 1 drop-off(s)"]
    limited = tuple(replace(s, produce_limit=10) if s.id == "line_3" else s for s in WAREHOUSE.stations)
    assert infeasible(replace(WAREHOUSE, stations=limited), to_lines) == [
        "line_3 has room for 0 part(s) for 1 drop-off(s), after what it holds at the start and may produce"]  # line_3: 20 - 10 held - 10 to come = 0
    robots = (replace(WAREHOUSE.robots[0], carrying=1), *(replace(r, actions=("load", "dummy")) for r in WAREHOUSE.robots[1:]))
    assert infeasible(replace(WAREHOUSE, robots=robots), records[:1]) == ["robot_1 starts with 1 part(s) on board"]
    assert infeasible(replace(WAREHOUSE, robots=robots[1:]), records[:1]) == ["no robot is configured to load and unload"]
    assert infeasible(WAREHOUSE, records[:10]) == []


def test_giving_up_is_right_when_no_robot_can_serve_the_job():
    # no robot configured to unload: a job no robot can serve, and giving up at once is right
    unable = replace(warehouse(*TWO), robots=tuple(replace(r, actions=("load", "dummy")) for r in WAREHOUSE.robots))
    assert check_failures_have_evidence(vcran.simulate(unable, manager=GiveUp)) == []
    # one robot, whose battery runs empty at rest at t = 5 (0.05 Ah, 0.01 Ah/s) and is never swapped: it is
    # lost for good, so a job arriving at 10 cannot be served; one arriving at 0 could have been
    lost = vcran.simulate(resting(job(10, "j")), manager=GiveUp)
    assert [e["t"] for e in lost.events if e["event"] == "battery_empty"] == [5.0]
    assert check_failures_have_evidence(lost) == []
    assert len(check_failures_have_evidence(vcran.simulate(resting(job(0, "j")), manager=GiveUp))) == 1
    # swapped after 30 s, the robot is only waiting: it could still serve the job
    swapped = vcran.simulate(resting(job(10, "j"), swap_after=30.0), manager=GiveUp)
    assert len(check_failures_have_evidence(swapped)) == 1


def test_a_fault_exempts_the_run_from_the_feasibility_property_one_that_did_nothing_does_not():
    # a motion failure at rest (t = 0.01, before any task landed) does nothing: applied false
    idle = replace(warehouse(*TWO), faults=(FaultSpec(0.01, "robot_1", "motion_failure"),))
    result = vcran.simulate(idle, manager=GiveUp)
    assert [e.get("applied") for e in result.events if e["event"] == "fault"] == [False]
    assert len(check_feasible_jobs_completed(result)) == 2
    paused = replace(idle, faults=(FaultSpec(0.01, "robot_1", "breakdown", 1.0),))
    assert check_feasible_jobs_completed(vcran.simulate(paused, manager=GiveUp)) == []


def test_the_checks_need_the_scenario_the_result_came_from():
    class Bare:
        events, jobs, summary = [], (), {"sim_time": 0.0}

    with pytest.raises(TypeError, match="check_failures_have_evidence: the result carries no scenario"):
        check_failures_have_evidence(Bare())
    with pytest.raises(ValueError, match="margin must be a number of seconds >= 0, got -1"):
        check_feasible_jobs_completed(vcran.simulate(warehouse(*TWO), manager=GiveUp), margin=-1)


def test_the_dispatcher_keeps_every_loop_property_on_the_warehouse():
    assert loop_problems(vcran.simulate(warehouse(*TWO))) == []


@pytest.mark.parametrize(("manager", "says"), [("GiveUp", "without evidence"), ("NeverSends", "never ended")])
def test_vcran_fuzz_fails_a_manager_that_gives_up_or_never_sends_a_task(manager, says, tmp_path):
    """``vcran fuzz warehouse --manager ...:GiveUp --examples 50`` exited 0 (issue 29 item 6). A manager that
    never sends a task leaves its jobs open; the search shrinks the stock to empty lines, which makes the
    workload infeasible, so it is the "every job ended" property that names it."""
    small = replace(WAREHOUSE, robots=WAREHOUSE.robots[:1], settings=replace(WAREHOUSE.settings, duration=30.0))
    scenario = tmp_path / "small.toml"
    scenario.write_text(dumps(loop_dict(small)))
    path = f"tests.testing.loop_managers:{manager}"
    assert main(["fuzz", str(scenario), "--manager", path, "--examples", "3", "--seed", "1", "--jobs", "1",
                 "--horizon", "10", "--save", str(tmp_path / "fail.toml")]) == 1
    assert says in (tmp_path / "fail.toml").read_text()
