"""A fleet manager in the loop, in simulated time (docs/contract.md §9): the link's latency, ordering and semantics, the
tie order of callbacks, and when a closed-loop run is over (the lost-last-task defect of issue 10)."""

from __future__ import annotations

import tomllib

import pytest

import vcran
from vcran.core.opil.build import motion as build_motion
from vcran.core.opil.messages import AssignmentStatus, RanStatus
from vcran.io.scenario_file import parse
from vcran.io.sinks import MemorySinks
from vcran.io.trace import records, trace_in
from vcran.runner import execute
from vcran.sim.opil.loop import ClosedLoop

FLEET = """
[simulation]
duration = 300.0
until_idle = true
seed = 3
[simulation.action_durations]
dummy = 1.0
[[robots]]
id = "robot_1"
pose = [0.0, 0.0, 0.0]
max_velocity = 1.0
[[robots]]
id = "robot_2"
pose = [0.0, 5.0, 0.0]
max_velocity = 1.0
[[stations]]
id = "a"
position = [0.0, 0.0]
[[stations]]
id = "b"
position = [10.0, 0.0]
"""


def scenario(extra: str = "") -> vcran.Scenario:
    return parse(tomllib.loads(FLEET + extra), "<test>")


def inbound(result: vcran.Result) -> list[dict]:
    return [e for e in result.events if e["event"] == "task_queued"]


class Chain(vcran.FleetManager):
    """Sends task A at the start and task B only once robot_1's ran_status shows A completed: a run that
    stopped when the script-like part was over would lose B (issue 10's reported defect)."""

    def __init__(self) -> None:
        self.sent: list[str] = []

    def on_start(self) -> None:
        self.handle.send_task("robot_1", [(2.0, 0.0)], ["dummy"], task="A")
        self.sent.append("A")

    def on_update(self, robot, attribute, message, t) -> None:
        if isinstance(message, RanStatus) and vcran.id_for("A") in message.completed and "B" not in self.sent:
            self.handle.send_task("robot_1", [(4.0, 0.0)], ["dummy"], task="B")
            self.sent.append("B")


def test_defect_a_task_sent_after_the_last_update_is_not_lost():
    result = vcran.simulate(scenario(), manager=Chain())
    assert result.summary["robots"]["robot_1"]["completed"] == ["A", "B"]
    assert result.summary["sim_time"] < 300.0  # and until_idle still ends the run once B is done


class Later(vcran.FleetManager):
    """Idle for a long while, then a task from a timer: the run must wait for the timer."""

    def on_start(self) -> None:
        self.handle.call_later(100.0, self.handle.send_task, "robot_2", [(1.0, 5.0)], (), task="late")


def test_a_pending_timer_keeps_an_idle_fleet_running():
    result = vcran.simulate(scenario(), manager=Later())
    assert result.summary["robots"]["robot_2"]["completed"] == ["late"]
    queued = [e for e in result.events if e["event"] == "task_queued"]
    assert [e["t"] for e in queued] == [100.05]  # written at 100 s, reaches the RAN 50 ms later


class Silent(vcran.FleetManager):
    pass


def test_a_manager_with_nothing_to_do_ends_at_the_first_idle_tick():
    result = vcran.simulate(scenario(), manager=Silent())
    # t = 0: the first publications leave; they reach the manager at 0.05; tick 1 s finds nothing pending
    assert result.summary["sim_time"] == 1.0


class Recorder(vcran.FleetManager):
    """Writes down every callback; at t = 1.0 a job, a timer and the first updates all fall due."""

    attributes = None  # every attribute, current_motion included

    def __init__(self) -> None:
        self.calls: list[tuple[float, str]] = []

    def on_start(self) -> None:
        self.calls.append((self.handle.now, "start"))
        self.handle.call_at(1.0, lambda: self.calls.append((self.handle.now, "timer")))

    def on_job(self, job) -> None:
        self.calls.append((self.handle.now, f"job {job.id}"))
        self.handle.job_done(job)

    def on_update(self, robot, attribute, message, t) -> None:
        assert t == self.handle.now
        self.calls.append((t, f"update {robot} {attribute}"))


def test_tie_order_at_one_instant_is_updates_then_jobs_then_timers():
    sc = scenario('\n[link]\nlatency = 1.0\n[[jobs]]\nt = 1.0\nid = "j"\npickup = "a"\ndropoff = "b"\n')
    manager = Recorder()
    vcran.simulate(sc, manager=manager)
    at_one = [what for t, what in manager.calls if t == 1.0]
    assert manager.calls[0] == (0.0, "start")
    # what the RAN published at t = 0 arrives at 1.0 as one batch, in publication order
    updates = [w for w in at_one if w.startswith("update")]
    assert updates and at_one[:len(updates)] == updates
    assert {w.split()[2] for w in updates} >= {"robot_description", "current_motion"}
    assert at_one[len(updates):] == ["job j", "timer"]


class Pair(vcran.FleetManager):
    """Two writes of robot_1's motion_assignment 0.1 s apart, different tasks."""

    def on_start(self) -> None:
        self.handle.send_task("robot_1", [(1.0, 0.0)], task="first")
        self.handle.call_later(0.1, self.handle.send_task, "robot_1", [(2.0, 0.0)], (), task="second")


def test_subscription_delivers_every_write_after_the_latency():
    result = vcran.simulate(scenario("\n[link]\nlatency = 0.2\n"), manager=Pair())
    assert [(e["t"], e["task"]) for e in inbound(result)] == [(0.2, "first"), (pytest.approx(0.3), "second")]
    assert result.summary["robots"]["robot_1"]["completed"] == ["first", "second"]


def test_polling_loses_a_write_overwritten_before_the_ran_reads_it():
    # both writes land (0.05, 0.15) before the first read at 0.25: Orion holds only the second
    result = vcran.simulate(scenario("\n[link]\ninbound = 'polling'\npoll_interval = 0.25\n"), manager=Pair())
    assert [(e["t"], e["task"]) for e in inbound(result)] == [(0.25, "second")]
    assert result.summary["robots"]["robot_1"]["completed"] == ["second"]


class BackAndForth(vcran.FleetManager):
    """Writes robot_1's motion_assignment as A at 0, B at 0.3 and A again at 0.35 (each lands 0.05 later)."""

    def on_start(self) -> None:
        first = build_motion("T", "T_m1", 1, 1, 1.0, 0.0)
        other = build_motion("T", "T_m1", 1, 1, 2.0, 0.0)  # R10: the same assignment, new content
        self.handle.send("robot_1", first)
        self.handle.call_at(0.3, self.handle.send, "robot_1", other)
        self.handle.call_at(0.35, self.handle.send, "robot_1", first)


def test_r10_polling_does_not_forward_a_value_read_before_again(tmp_path):
    """docs/loop.md, polling: the RAN gets each attribute that differs from what it read last. A lands at
    0.05 and is read at 0.25; B (0.35) and A (0.4) land before the read at 0.5, which finds A again, the
    value it already read: nothing goes to the RAN, so the trace holds one inbound record, not two (R10
    would make the second silent anyway, but the trace would grow with every such read)."""
    sc = scenario("\n[link]\ninbound = 'polling'\npoll_interval = 0.25\nlatency = 0.05\n")
    vcran.simulate(sc, manager=BackAndForth(), out=tmp_path)
    read = [r for _, r in records(trace_in(tmp_path)) if r["dir"] == "in"]
    assert [(r["t"], r["robot"], r["attr"]) for r in read] == [(0.25, "robot_1", "motion_assignment")]


class Burst(vcran.FleetManager):
    """Ten one-point tasks to robot_1, 10 ms apart: with jitter, they must still arrive in the order sent."""

    def on_start(self) -> None:
        for k in range(10):
            self.handle.call_at(k / 100, self.handle.send_task, "robot_1", [(float(k), 0.0)], task=f"t{k}")


def test_jitter_is_seeded_and_keeps_each_robots_writes_in_order():
    sc = scenario("\n[link]\nlatency = 0.05\njitter = 0.5\n")
    first, second = vcran.simulate(sc, manager=Burst()), vcran.simulate(sc, manager=Burst())
    queued = inbound(first)
    assert [e["task"] for e in queued] == [f"t{k}" for k in range(10)]
    times = [e["t"] for e in queued]
    assert times == sorted(times) and 0.05 <= times[0] and times[-1] < 0.09 + 0.55
    assert len(set(times)) > 1  # the jitter did something
    assert first.events == second.events


class Watch(vcran.FleetManager):
    """Sends one task at 1 s and records when it hears of robot_1's assignment_state changes."""

    def __init__(self) -> None:
        self.heard: list[float] = []

    def on_start(self) -> None:
        self.handle.call_at(1.0, self.handle.send_task, "robot_1", [(1.0, 0.0)])

    def on_update(self, robot, attribute, message, t) -> None:
        if robot == "robot_1" and isinstance(message, AssignmentStatus):
            self.heard.append(t)


def test_link_down_holds_writes_and_publications_until_it_is_restored():
    sc = scenario()
    manager = Watch()
    loop = ClosedLoop(sc, manager, lambda *a: None)
    sinks = MemorySinks()

    def down(model) -> None:
        assert loop.link is not None
        loop.link.outage("robot_1", 5.0)

    execute(sc, loop, sinks, on_start=down)
    queued = [e for e in sinks.events.events if e["event"] == "task_queued"]
    assert [e["t"] for e in queued] == [5.0]  # written at 1.0, landed at 1.05, read when the link is back
    # robot_1 published nothing while down (from t = 0); its held status goes out at 5.0, arrives 5.05
    assert manager.heard[0] == 5.05 and len(manager.heard) >= 2


class Describe(vcran.FleetManager):
    """Subscribed to robot_description only; keeps every update of it and what ``latest`` holds then."""

    attributes = frozenset({"robot_description"})

    def __init__(self) -> None:
        self.got: list[tuple[float, str]] = []

    def on_update(self, robot, attribute, message, t) -> None:
        assert self.handle.latest(robot, attribute) == message
        self.got.append((t, robot))


def test_every_periodic_robot_description_reaches_the_manager_as_live_mode_forces_it():
    """docs/contract.md §2, issue 29 item 2: live, each periodic write of the (unchanged) description is forced through
    Orion (options=forcedUpdate), so it notifies every subscriber; the link stands for Orion (docs/contract.md §9), so
    the manager gets it every description_period too, not only the first time. Expected by hand: written
    at 0, 10, 20 (duration 25 s), each arriving 0.5 s later, robot_1 then robot_2 (fleet order)."""
    sc = parse(tomllib.loads(FLEET.replace("until_idle = true", "description_period = 10.0").replace(
        "duration = 300.0", "duration = 25.0") + "\n[link]\nlatency = 0.5\n"), "<test>")
    manager = Describe()
    vcran.simulate(sc, manager=manager)
    assert manager.got == [(t, r) for t in (0.5, 10.5, 20.5) for r in ("robot_1", "robot_2")]
