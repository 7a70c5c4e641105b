"""The fleet manager's handle in simulated time (SPEC §9): what it refuses, timers, spaced task messages,
seeded randomness, what Orion holds, and job reports that make no sense."""

from __future__ import annotations

import tomllib

import pytest

import vcran
from vcran.core.jobs import JobError
from vcran.core.messages import AssignmentStatus
from vcran.io.scenario_file import parse

FLEET = """
[simulation]
duration = 60.0
until_idle = true
seed = 11
[[robots]]
id = "robot_1"
pose = [1.0, 2.0, 0.5]
max_velocity = 1.0
[[stations]]
id = "a"
position = [0.0, 0.0]
[[stations]]
id = "b"
position = [5.0, 0.0]
[[jobs]]
t = 1.0
id = "j"
pickup = "a"
dropoff = "b"
"""


def scenario() -> vcran.Scenario:
    return parse(tomllib.loads(FLEET), "<test>")


class Probe(vcran.FleetManager):
    """Runs ``check(handle)`` at the start and keeps what it returns (or raises)."""

    def __init__(self, check) -> None:
        self.check, self.result = check, None

    def on_start(self) -> None:
        self.result = self.check(self.handle)

    def on_job(self, job) -> None:
        self.handle.job_failed(job, "unassignable")


@pytest.mark.parametrize("check, error, message", [
    (lambda h: h.send("robot_9", vcran.CancelTask()), KeyError, "no robot 'robot_9'"),
    (lambda h: h.send("robot_1", "hello"), TypeError, "got str"),
    (lambda h: h.send_raw("robot_1", "ran_status", {}), ValueError, "unknown inbound attribute 'ran_status'"),
    (lambda h: h.call_later(-1.0, print), ValueError, "negative delay"),
    (lambda h: h.send_task("robot_1", []), ValueError, "at least one point or one action"),
    (lambda h: h.job_done("never_arrived"), JobError, "no such job has arrived"),
])
def test_the_handle_refuses_what_orion_or_the_protocol_would(check, error, message):
    with pytest.raises(error, match=message):
        vcran.simulate(scenario(), manager=Probe(check))


def test_a_job_reported_twice_is_the_managers_bug():
    class Twice(vcran.FleetManager):
        def on_job(self, job) -> None:
            self.handle.job_done(job)
            self.handle.job_failed(job, "timeout")

    with pytest.raises(JobError, match=r"cannot fail job 'j': it already completed at t=1.0"):
        vcran.simulate(scenario(), manager=Twice())


def test_a_cancelled_timer_never_runs_and_does_not_keep_the_run_going():
    fired = []

    def check(h):
        h.call_at(30.0, fired.append, "kept")
        h.call_at(20.0, fired.append, "cancelled").cancel()

    result = vcran.simulate(scenario(), manager=Probe(check))
    assert fired == ["kept"]
    assert result.summary["sim_time"] == 30.0  # the tick at 30 s comes after the timer (tie order)


def test_send_task_every_spaces_the_messages_and_names_them():
    probe = Probe(lambda h: h.send_task("robot_1", [(2.0, 2.0), (3.0, 2.0, 0.0)], ["dummy"], every=2.0))
    result = vcran.simulate(scenario(), manager=probe)
    assert probe.result == vcran.id_for("task_1")
    queued = [e for e in result.events if e["event"] in ("task_queued", "motion_finished", "task_completed")]
    assert queued[0] == {"t": 0.05, "robot": "robot_1", "event": "task_queued", "task": "task_1"}
    assert [e["motion"] for e in queued if e["event"] == "motion_finished"] == ["task_1_m1", "task_1_m2"]
    assert result.summary["robots"]["robot_1"]["completed"] == ["task_1"]
    # the action is written at 4 s and reaches the RAN at 4.05: R3 only then lets the motions start
    motions = [e["t"] for e in result.events if e["event"] == "state" and e["to"] == "MOTION"]
    assert motions == [4.05]


def test_random_is_seeded_by_the_scenario():
    first = Probe(lambda h: [h.random.random() for _ in range(3)])
    second = Probe(lambda h: [h.random.random() for _ in range(3)])
    vcran.simulate(scenario(), manager=first)
    vcran.simulate(scenario(), manager=second)
    assert first.result == second.result and len(set(first.result)) == 3


class Reader(vcran.FleetManager):
    def on_start(self) -> None:
        self.before = (self.handle.pose("robot_1"), self.handle.latest("robot_1", "assignment_status"))
        self.handle.call_at(10.0, self.read)

    def read(self) -> None:
        self.after = (self.handle.pose("robot_1"), self.handle.latest("robot_1", "assignment_status"))

    def on_job(self, job) -> None:
        self.handle.job_failed(job, "unassignable")


def test_latest_and_pose_are_what_orion_holds():
    reader = Reader()
    vcran.simulate(scenario(), manager=reader)
    assert reader.before == ((1.0, 2.0, 0.5), None)  # nothing has reached the manager yet: the start pose
    pose, status = reader.after
    assert pose == pytest.approx((1.0, 2.0, 0.5)) and isinstance(status, AssignmentStatus)
