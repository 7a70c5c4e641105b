"""scenarios/warehouse-faults.toml (issue 29 item 7, docs/contract.md §4 and §9): the warehouse with batteries, chargers and
faults of every kind in a closed loop. The reference Dispatcher ends every job, completed or failed with
evidence; every count below is derived from the Dispatcher's rules and docs/contract.md §4, not read off a run."""

from __future__ import annotations

from collections import Counter
from dataclasses import replace
from itertools import takewhile

import pytest
from hypothesis import given, settings

import vcran
from tests.conftest import ROOT
from vcran.core.faults import KINDS
from vcran.testing.loop import assert_loop_properties, loop_problems, loop_variants
from vcran.testing.outcomes import check_failures_have_evidence

pytestmark = pytest.mark.slow  # the scenario's hour of simulated time, and variants of it

SCENARIO = vcran.load_scenario(ROOT / "scenarios" / "warehouse-faults.toml")


@pytest.fixture(scope="module")
def run() -> vcran.Result:
    return vcran.simulate(SCENARIO)


def of(result: vcran.Result, name: str) -> list[dict]:
    return [e for e in result.events if e["event"] == name]


def test_it_is_bundled_and_has_batteries_chargers_and_every_kind_of_fault():
    assert replace(vcran.load_scenario("warehouse-faults"), source=SCENARIO.source) == SCENARIO
    assert all(r.battery is not None for r in SCENARIO.robots)
    assert sum(s.charger for s in SCENARIO.stations) == 2
    kinds = {f.kind for f in SCENARIO.faults} | {source.kind for source in SCENARIO.random_faults}
    assert kinds == set(KINDS) - {"trigger"}  # a trigger presses a VDA 5050 vehicle's button: an OPIL scenario refuses it


def test_every_job_ends_completed_or_failed_with_evidence(run):
    assert loop_problems(run) == []  # every property: ended, evidence, feasible (exempt: faults), protocol, idle
    jobs = run.summary["jobs"]
    assert jobs["open"] == 0 and jobs["completed"] + jobs["failed"] == jobs["arrived"]
    assert jobs["arrived"] == sum(1 for _ in SCENARIO.job_stream.jobs())  # every job of the stream reached it
    # what the faults allow: a job fails only after max_tries (3) cancelled tasks of its own
    cancelled = {(e["robot"], e["task"]) for e in of(run, "task_cancelled")}
    for e in of(run, "job_assigned"):
        record = run.job(e["job"])
        lost = sum((r["robot"], r["task"]) in cancelled for r in of(run, "job_assigned") if r["job"] == record.id)
        assert record.outcome == "completed" or lost == 3, record


def test_every_drawn_fault_happens_and_every_cancelled_task_is_a_faults_doing(run):
    end = run.summary["sim_time"]
    drawn = Counter(f.kind for f in SCENARIO.faults if f.t <= end)
    for source in SCENARIO.random_faults:
        for robot in SCENARIO.robots:
            drawn.update(f.kind for f in takewhile(lambda f: f.t <= end, source.stream(SCENARIO.settings.seed, robot.id)))
    assert Counter(e["kind"] for e in of(run, "fault")) == drawn
    # docs/contract.md §4: a motion failure that applied cancels its task motion_failed; an armed action failure fails
    # one action (action_fault) and cancels its task action_failed; nothing else cancels a task here
    applied = Counter(e["kind"] for e in of(run, "fault") if e.get("applied", True))
    reasons = Counter(e["reason"] for e in of(run, "task_cancelled"))
    assert reasons["motion_failed"] == applied["motion_failure"]
    failed = Counter(e["code"] for e in of(run, "failed"))
    assert reasons["action_failed"] == failed["action_fault"] <= applied["action_failure"]
    assert set(reasons) <= {"motion_failed", "action_failed"} and set(failed) <= {"motion_failed", "action_fault"}


def test_a_failed_load_or_unload_moves_nothing_so_the_parts_add_up(run):
    # the docks start empty and produce nothing: they hold one part per completed job. A line holds its 10,
    # plus what it produced, minus one per completed job that picked up there (docs/contract.md §4: a failed load took
    # nothing); every robot ends empty-handed (a failed unload kept its part, delivered by the retry)
    stations = run.summary["stations"]
    done = [r for r in run.jobs if r.outcome == "completed"]
    assert sum(stations[f"dock_{k}"]["parts"] for k in range(1, 5)) == len(done)
    for k in range(1, 5):
        line = f"line_{k}"
        assert stations[line]["parts"] == 10 + stations[line]["produced"] - sum(r.job.pickup == line for r in done)
    assert sum(r["parts_moved"] for r in run.summary["robots"].values()) == len(done)
    assert all(r["carrying"] == 0 for r in run.summary["robots"].values())


def test_robots_charge_and_none_runs_empty(run):
    charges = [e for e in of(run, "task_completed") if e["task"].startswith("charge")]
    assert charges and not of(run, "battery_empty")


def test_it_is_deterministic(run):
    again = vcran.simulate(SCENARIO)
    assert again.events == run.events and again.summary == run.summary and again.jobs == run.jobs


SMALL = replace(SCENARIO, robots=SCENARIO.robots[:3], faults=())  # three robots, the random faults only


@settings(max_examples=4)
@given(loop_variants(SMALL, max_jobs=4, horizon=120.0, settle=400.0))
def test_the_dispatcher_keeps_the_loop_properties_on_variants_of_it(scenario):
    result = vcran.simulate(scenario)
    assert_loop_properties(result)
    assert check_failures_have_evidence(result) == []
