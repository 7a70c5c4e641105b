"""The fleet manager's handle in simulated time (docs/contract.md §9): what it refuses, timers, spaced task messages,
seeded randomness, what Orion holds, and job reports that make no sense."""

from __future__ import annotations

import tomllib

import pytest

import vcran
from vcran.core.jobs import JobError
from vcran.core.opil.messages import AssignmentStatus
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
    # in memory the RAN rejected it (R12); with out= the trace could not write it (exit 70, not the manager's
    # fault by the note); under vcran manage the sender thread died on it and nothing more was written
    (lambda h: h.send_raw("robot_1", "motion_assignment", {"x": {1, 2}}), TypeError,
     "send_raw: the value is not JSON: Object of type set is not JSON serializable"),
    (lambda h: h.send_raw("robot_1", "motion_assignment", {"x": float("nan")}), ValueError,
     "send_raw: the value is not JSON: Out of range float values are not JSON compliant"),
    (lambda h: h.call_later(-1.0, print), ValueError, "negative delay"),
    (lambda h: h.send_task("robot_1", []), ValueError, "at least one point or one action"),
    (lambda h: h.job_done("never_arrived"), JobError, "no such job has arrived"),
    # "'int' object has no attribute 'id'", a bare KeyError 'robot_9', and None for ever
    (lambda h: h.job_done(7), TypeError, "a job is a vcran.Job or its id, got int"),
    (lambda h: h.send_task("robot_1", [(1.0, 1.0)], job=7), TypeError, "a job is a vcran.Job or its id, got int"),
    (lambda h: h.call_at(5.0, h.pose, "robot_9"), KeyError, "no robot 'robot_9' in this fleet"),  # once telemetry came
    (lambda h: h.latest("robot_9", "ran_status"), KeyError, "no robot 'robot_9' in this fleet"),
    (lambda h: h.latest("robot_1", "motion_assignment"), ValueError,
     "latest: 'motion_assignment' is not an attribute robots publish; known: robot_description, current_motion"),
    # a NaN time went into SimPy's heap and broke its order: 12 of the warehouse's 224 jobs arrived, and
    # job_completed events were written with "t": null; an infinite one never runs and holds until_idle off
    (lambda h: h.call_later(float("nan"), print), ValueError, "delay must be a finite number of seconds, got nan"),
    (lambda h: h.call_later(float("inf"), print), ValueError, "delay must be a finite number of seconds, got inf"),
    (lambda h: h.call_at(float("nan"), print), ValueError, r"call_at\(nan\): not a finite time"),
    (lambda h: h.call_at(float("inf"), print), ValueError, r"call_at\(inf\): not a finite time"),
    # what the task builder met deep inside: 'tuple index out of range', "could not convert string to float: 'l'"
    (lambda h: h.send_task("robot_1", [(1.0,)]), ValueError, r"path\[0\]: expected \(x, y\) or \(x, y, theta\), got \(1.0,\)"),
    (lambda h: h.send_task("robot_1", ["a"]), ValueError, r"path\[0\]: expected \(x, y\) or \(x, y, theta\), got 'a'"),
    (lambda h: h.send_task("robot_1", [(0.0, "1")]), ValueError, r"path\[0\]: expected \(x, y\) or \(x, y, theta\)"),
    (lambda h: h.send_task("robot_1", "a"), TypeError, "path is a list of points"),
    (lambda h: h.send_task("robot_1", [(0.0, 0.0)], "load"), TypeError,
     r"actions is a list of action names, e.g. \['load'\]; got the string 'load'"),
])
def test_the_handle_refuses_what_orion_or_the_protocol_would(check, error, message):
    with pytest.raises(error, match=message):
        vcran.simulate(scenario(), manager=Probe(check))


@pytest.mark.parametrize("every", [-1.0, float("nan"), float("inf")])
def test_a_task_spaced_by_no_finite_interval_is_refused_before_anything_goes_out(every):
    """The first message went out and the job was recorded as assigned before the second one's timer was
    refused ('call_at(1.97...): that is in the past'): half a task on the robot, and in the events."""
    class Spaced(vcran.FleetManager):
        def on_job(self, job) -> None:
            with pytest.raises(ValueError, match=f"send_task: every must be a finite number of seconds >= 0, got {every}"):
                self.handle.send_task("robot_1", [(1.0, 2.0), (3.0, 2.0)], ["dummy"], job=job, every=every)
            self.handle.job_failed(job, "unassignable")

    result = vcran.simulate(scenario(), manager=Spaced())
    assert [e["event"] for e in result.events if e["event"].startswith(("job_", "task_"))] == ["job_arrived", "job_failed"]
    assert result.jobs[0].tasks == ()


def test_a_refused_task_does_not_use_up_a_task_number():
    def check(h):
        with pytest.raises(ValueError):
            h.send_task("robot_1", [(1.0,)])
        return h.send_task("robot_1", [(2.0, 2.0)])

    probe = Probe(check)
    vcran.simulate(scenario(), manager=probe)
    assert probe.result == vcran.id_for("task_1")


def test_a_failure_reason_is_a_string():
    """In memory any object was taken (JobRecord.reason typed str held None); with out= the events file
    could not encode it, so the same manager failed only on disk."""
    class Failing(vcran.FleetManager):
        def on_job(self, job) -> None:
            self.handle.job_failed(job, None)

    with pytest.raises(TypeError, match="job_failed: reason must be a string, got NoneType") as err:
        vcran.simulate(scenario(), manager=Failing())
    assert "in fleet manager Failing: on_job at t=1.0" in err.value.__notes__


class Waits(vcran.FleetManager):
    """A SimPy habit: a hook that yields to wait. It returned a generator that nobody ran, so the job
    was silently never handled."""

    def on_job(self, job):
        yield self.handle.call_later(1.0, print)
        self.handle.job_done(job)


class Awaits(vcran.FleetManager):
    async def on_job(self, job) -> None:
        self.handle.job_done(job)


@pytest.mark.parametrize("manager, kind", [(Waits, "generator"), (Awaits, "coroutine")])
def test_a_hook_that_would_wait_is_refused(manager, kind):
    with pytest.raises(TypeError, match=f"on_job returned a {kind}: hooks and timers run to the end at one simulated "
                                        "instant; to wait, schedule a callback") as err:
        vcran.simulate(scenario(), manager=manager())
    assert f"in fleet manager {manager.__name__}: on_job at t=1.0" in err.value.__notes__


def test_a_timer_that_would_wait_is_refused():
    class Later(vcran.FleetManager):
        def on_start(self) -> None:
            self.handle.call_later(2.0, self.tick)

        def tick(self):
            yield None

    with pytest.raises(TypeError, match="tick returned a generator") as err:
        vcran.simulate(scenario(), manager=Later())
    assert "in fleet manager Later: timer tick at t=2.0" in err.value.__notes__


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
        self.before = (self.handle.pose("robot_1"), self.handle.latest("robot_1", "assignment_state"))
        self.handle.call_at(10.0, self.read)

    def read(self) -> None:
        self.after = (self.handle.pose("robot_1"), self.handle.latest("robot_1", "assignment_state"))

    def on_job(self, job) -> None:
        self.handle.job_failed(job, "unassignable")


def test_latest_and_pose_are_what_orion_holds():
    reader = Reader()
    vcran.simulate(scenario(), manager=reader)
    assert reader.before == ((1.0, 2.0, 0.5), None)  # nothing has reached the manager yet: the start pose
    pose, status = reader.after
    assert pose == pytest.approx((1.0, 2.0, 0.5)) and isinstance(status, AssignmentStatus)


def test_the_fleet_a_manager_is_given_is_read_only():
    """Settings.durations is the one mutable part of a scenario, and the fleet shared it with the model:
    a manager setting ``self.fleet.settings.durations["load"] = 0`` made the simulated loads instant, and
    the caller's scenario kept the change for its next run (the warehouse's p95 lead time 67.5 s instead of
    78.0 s, run after run)."""
    class Quick(vcran.FleetManager):
        def on_start(self) -> None:
            self.fleet.settings.durations["load"] = 0.0

    given = scenario()
    with pytest.raises(TypeError, match="does not support item assignment") as err:
        vcran.simulate(given, manager=Quick())
    assert "in fleet manager Quick: on_start at t=0.0" in err.value.__notes__
    assert given.settings.durations == {"dummy": 1.0, "load": 5.0, "unload": 5.0}


def test_the_read_only_fleet_still_copies_pickles_and_serialises():
    """Read-only must not mean unusable (docs/contract.md §9): a MappingProxyType made the fleet, and a manager holding
    it after a run, impossible to pickle or deep-copy ("cannot pickle 'mappingproxy' object"), and its
    durations to json.dumps or dataclasses.asdict, all of which worked before the fleet was made
    read-only. A copy is read-only too, and writing to it leaves the original alone."""
    import copy
    import dataclasses
    import json
    import pickle

    from vcran.core.manager import Fleet

    fleet = Fleet.of(scenario())
    durations = {"dummy": 1.0, "load": 5.0, "unload": 5.0}
    assert json.loads(json.dumps(fleet.settings.durations)) == durations
    assert dataclasses.asdict(fleet.settings)["durations"] == durations
    for twin in (pickle.loads(pickle.dumps(fleet)), copy.deepcopy(fleet)):
        assert twin == fleet and twin.settings.durations == durations
        with pytest.raises(TypeError, match="does not support item assignment"):
            twin.settings.durations["load"] = 0.0
    mine = dict(fleet.settings.durations)  # the way to a copy one may change
    mine["load"] = 0.0
    assert fleet.settings.durations == durations
    for write in (lambda d: d.update(load=0.0), lambda d: d.pop("load"), lambda d: d.setdefault("x", 1.0),
                  lambda d: d.clear(), lambda d: d.popitem(), lambda d: d.__delitem__("load"),
                  lambda d: d.__ior__({"load": 0.0})):
        with pytest.raises(TypeError, match="read-only"):
            write(fleet.settings.durations)
    assert fleet.settings.durations == durations


def test_a_path_as_a_numpy_array_or_any_iterable_is_the_same_task():
    """A planner's path as an (n, 2) numpy array ('The truth value of an array with more than one element
    is ambiguous', from inside the task builder), or a generator (consumed by the point check, then 'has no
    len()'), is the task the same points as a list give: the handle takes the points, as its check says
    (docs/contract.md §9, docs/library.md)."""
    import numpy as np

    points = [(2.0, 2.0), (3.0, 2.0)]
    given = [points, np.array(points), (p for p in points), tuple(points)]
    runs = []
    for path in given:
        result = vcran.simulate(scenario(), manager=Probe(lambda h, path=path: h.send_task("robot_1", path, ["dummy"])))
        runs.append([e for e in result.events if e["event"] in ("task_queued", "motion_finished", "task_completed")])
    assert runs[0][-1] == {"t": runs[0][-1]["t"], "robot": "robot_1", "event": "task_completed", "task": "task_1"}
    assert all(run == runs[0] for run in runs)
