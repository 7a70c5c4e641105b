"""The reference fleet manager, vcran.managers.Dispatcher (SPEC §9): nearest idle robot, priority then FIFO,
two tasks per job, a retry after a cancelled task, failure after max_tries."""

from __future__ import annotations

import tomllib

import vcran
from vcran.io.scenario_file import parse
from vcran.managers import Dispatcher

FLEET = """
[simulation]
duration = 1000.0
until_idle = true
[simulation.action_durations]
load = 2.0
unload = 2.0
[[robots]]
id = "robot_1"
pose = [0.0, 0.0, 0.0]
max_velocity = 1.0
{robot_2}
[[stations]]
id = "a"
position = [0.0, 10.0]
parts = {parts}
[[stations]]
id = "b"
position = [0.0, -10.0]
"""

ROBOT_2 = '[[robots]]\nid = "robot_2"\npose = [1.0, 9.0, 0.0]\nmax_velocity = 1.0'


def scenario(jobs: str, *, parts: int = 5, two_robots: bool = False) -> vcran.Scenario:
    text = FLEET.format(robot_2=ROBOT_2 if two_robots else "", parts=parts) + jobs
    return parse(tomllib.loads(text), "<test>")


def job(t, id, pickup="a", dropoff="b", priority=0):
    return f'\n[[jobs]]\nt = {t}\nid = "{id}"\npickup = "{pickup}"\ndropoff = "{dropoff}"\npriority = {priority}\n'


def of(result: vcran.Result, name: str) -> list[dict]:
    return [e for e in result.events if e["event"] == name]


def test_a_job_is_a_pickup_task_then_a_dropoff_task_and_moves_one_part():
    result = vcran.simulate(scenario(job(0, "j1")), manager=Dispatcher())
    assert [(e["robot"], e["task"]) for e in of(result, "job_assigned")] == [("robot_1", "j1_pick1"),
                                                                              ("robot_1", "j1_drop1")]
    assert result.summary["robots"]["robot_1"]["completed"] == ["j1_pick1", "j1_drop1"]
    assert result.summary["stations"]["a"]["parts"] == 4 and result.summary["stations"]["b"]["parts"] == 1
    record = result.job("j1")
    assert (record.outcome, record.robot, record.tasks) == ("completed", "robot_1", ("j1_pick1", "j1_drop1"))
    # 10 m there and 20 m on at 1 m/s, 2 s load and 2 s unload: at least 34 s, plus link and tick delays
    assert 34.0 < record.lead_time < 40.0
    assert result.summary["jobs"]["completed"] == 1 and result.summary["jobs"]["lead_time"]["p50"] == record.lead_time


def test_the_idle_robot_nearest_to_the_pickup_gets_the_job():
    result = vcran.simulate(scenario(job(0, "j1"), two_robots=True), manager=Dispatcher())
    assert {e["robot"] for e in of(result, "job_assigned")} == {"robot_2"}  # 1.4 m from a, robot_1 10 m


def test_waiting_jobs_go_by_priority_then_arrival():
    jobs = job(0, "first") + job(1, "low") + job(2, "high", priority=5) + job(3, "low2")
    result = vcran.simulate(scenario(jobs), manager=Dispatcher())
    picks = [e["job"] for e in of(result, "job_assigned") if e["task"].endswith("_pick1")]
    assert picks == ["first", "high", "low", "low2"]
    assert result.summary["jobs"]["completed"] == 4


def test_a_failed_pickup_is_retried_and_the_job_fails_after_max_tries():
    result = vcran.simulate(scenario(job(0, "j1"), parts=0), manager=Dispatcher(max_tries=2))
    assert [e["task"] for e in of(result, "job_assigned")] == ["j1_pick1", "j1_pick2"]
    assert [c["reason"] for c in result.summary["robots"]["robot_1"]["cancelled"]] == ["action_failed"] * 2
    failed = of(result, "job_failed")
    assert [(e["job"], e["reason"], e["tasks"]) for e in failed] == [("j1", "action_failed", 2)]
    assert result.job("j1").outcome == "failed" and result.summary["jobs"]["failed"] == 1


def test_a_robot_freed_by_a_failed_job_takes_the_next_one():
    jobs = job(0, "doomed", pickup="b", dropoff="a") + job(1, "fine")
    result = vcran.simulate(scenario(jobs), manager=Dispatcher(max_tries=1))
    assert [r.outcome for r in result.jobs] == ["failed", "completed"]


def test_a_failed_pickup_waits_before_its_retry_so_a_producing_station_can_catch_up():
    from dataclasses import replace

    base = scenario(job(0, "j1"), parts=0)
    producing = replace(base, stations=tuple(replace(s, produce_every=30.0) if s.id == "a" else s
                                             for s in base.stations))  # the first part appears at t = 30
    eager = vcran.simulate(producing, manager=Dispatcher(retry_after=0.0))  # three loads before t = 30
    assert eager.job("j1").outcome == "failed"
    patient = vcran.simulate(producing, manager=Dispatcher())  # waits 10 s, then 20 s
    assert patient.job("j1").outcome == "completed"
    assert patient.job("j1").tasks == ("j1_pick1", "j1_pick2", "j1_pick3", "j1_drop3")  # n = tries + 1
    cancels = [e["t"] for e in of(patient, "task_cancelled")]
    retries = [e["t"] for e in of(patient, "job_assigned")][1:3]
    # the manager learns of a cancel at the next status tick (<= 1 s) plus the link's 50 ms
    for cancelled, retried, wait in zip(cancels, retries, (10.0, 20.0), strict=True):
        assert cancelled + wait <= retried <= cancelled + wait + 1.05
