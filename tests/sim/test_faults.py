"""docs/contract.md §4 Faults, end to end: scenarios/faults.toml's outcome as derived by hand in docs/robots.md, and the
scenario keys' errors."""

from __future__ import annotations

import dataclasses
import itertools
import tomllib

import pytest

from tests.conftest import ROOT, run_scenario
from tests.sim.test_scenarios import FLEET, motion, script
from vcran.core.faults import RandomFaults
from vcran.io.scenario_file import ScenarioError, load, parse
from vcran.io.trace import samples

SCENARIO = ROOT / "scenarios" / "faults.toml"


@pytest.fixture(scope="module")
def faults_run(tmp_path_factory):
    return run_scenario(load(SCENARIO), tmp_path_factory.mktemp("faults"))


def ended(out, robot):
    return [(e["t"], e["event"], e.get("reason")) for e in out.events
            if e["robot"] == robot and e["event"] in ("task_completed", "task_cancelled")]


def test_s4_breakdown_delays_completion_by_exactly_its_duration(faults_run, tmp_path):
    scenario = load(SCENARIO)
    calm = run_scenario(dataclasses.replace(scenario, faults=()), tmp_path / "calm")
    # without it: 22 s of driving from t = 1, then a 1 s action
    assert ended(calm, "robot_1") == [(24.0, "task_completed", None)]
    assert ended(faults_run, "robot_1") == [(31.5, "task_completed", None)]  # 24 + 7.5, exactly


def test_s4_breakdown_stops_the_robot_where_it_is(faults_run):
    rows = samples(faults_run.dir)
    x1, v1 = rows[:, 1], rows[:, 4]  # robot_1's x and v, one row per second
    # t = 8: 1 m of ramp + 5 m at 1 m/s = 6 m; standing still until 15.5, then on at cruise speed
    assert list(x1[8:16]) == [6.0] * 8 and list(v1[8:16]) == [0.0] * 8
    assert (x1[16], v1[16]) == (6.5, 1.0)
    (fault,) = faults_run.of("fault", "robot_1")
    assert fault == {"t": 8.0, "robot": "robot_1", "event": "fault", "kind": "breakdown", "duration": 7.5}
    assert faults_run.of("fault_end", "robot_1")[0]["t"] == 15.5
    warnings = [r["value"] for r in faults_run.trace() if r["attr"] == "ran_error" and r["robot"] == "robot_1"]
    assert [(w["code"], w["severity"]) for w in warnings] == [("breakdown", "warning")]


def test_s4_motion_failure_ends_the_leg_where_the_robot_is(faults_run):
    assert ended(faults_run, "robot_2") == [(10.0, "task_cancelled", "motion_failed")]
    r = faults_run.robot("robot_2")
    assert r["final_pose"] == {"x": 8.0, "y": 20.0, "theta": 0.0}  # 1 m ramp + 7 m by t = 10
    assert r["distance"] == 8.0
    (failed,) = faults_run.of("failed", "robot_2")
    assert failed["code"] == "motion_failed" and failed["motion"] == "B_m1"


def test_s4_action_failure_then_pause_and_resume(faults_run):
    assert ended(faults_run, "robot_3") == [(2.0, "task_cancelled", "action_failed"), (18.0, "task_completed", None)]
    # paused 3..6: task D (queued at 4) starts driving at 6; 10 m take 2 + 8 + 2 s
    rows = samples(faults_run.dir)
    assert list(rows[4:7, 11]) == [0.0, 0.0, 0.0]  # robot_3's x at 4, 5, 6 s


def test_s4_link_down_holds_inbound_and_outbound_until_the_link_is_back(faults_run):
    assert [e["t"] for e in faults_run.of("task_queued", "robot_4")] == [0.0, 5.5]
    assert ended(faults_run, "robot_4") == [(1.0, "task_completed", None), (6.5, "task_completed", None)]
    out = [(r["t"], r["attr"], r["value"]) for r in faults_run.trace() if r["robot"] == "robot_4" and r["dir"] == "out"
           and r["attr"] in ("ran_status", "assignment_state")]
    assert not [t for t, _, _ in out if 0.5 <= t < 5.5]
    # E0 completed at 1.0 unseen; the statuses it could not publish go out when the link is back
    back = {attr: value for t, attr, value in out if t == 5.5}
    assert back["ran_status"]["state"] == "WAITING"
    assert [i["description"] for i in back["ran_status"]["completed"]] == ["E0"]


def _task(t: float, name: str, action: str) -> str:
    # s1 stands at (10, 1) with reach 1: the robot's point (10, 0) is exactly in reach
    return f't = {t}\nkind = "task"\ntask = "{name}"\npath = [[10.0, 0.0]]\nactions = ["{action}"]'


ARMED = '\n[[faults]]\nt = 0.5\nrobot = "robot_1"\nkind = "action_failure"\n'


def test_s4_a_load_failed_by_an_injected_action_failure_moves_no_part(run_toml):
    """docs/contract.md §4 (issue 29 item 5): a failed load moves nothing. The load was applied and its outcome replaced
    afterwards: task L cancelled action_failed, yet the robot carried a part and s1 held 2 of its 3."""
    out = run_toml(script(_task(1.0, "L", "load")) + ARMED)
    assert [(e["task"], e["event"], e.get("reason")) for e in out.of("task_cancelled") + out.of("task_completed")] == [
        ("L", "task_cancelled", "action_failed")]
    assert out.robot()["carrying"] == 0 and out.summary["stations"]["s1"]["parts"] == 3
    # the fault is spent on that load: the next one takes a part
    again = run_toml(script(_task(1.0, "L", "load"), _task(30.0, "L2", "load")) + ARMED)
    assert [e["task"] for e in again.of("task_completed")] == ["L2"]
    assert again.robot()["carrying"] == 1 and again.summary["stations"]["s1"]["parts"] == 2


def test_s4_an_unload_failed_by_an_injected_action_failure_keeps_the_part_on_board(run_toml):
    """docs/contract.md §4 (issue 29 item 5): a failed unload moves nothing: the robot still carries its part, s1 keeps
    its 3, and no part counts as moved; the unload sent again delivers it."""
    def loaded(*tasks: str) -> str:  # the robot starts with a part on board
        return script(*tasks).replace("max_velocity = 1.0\n", "max_velocity = 1.0\ncarrying = 1\n", 1) + ARMED

    once = run_toml(loaded(_task(1.0, "U", "unload")))
    assert [e["task"] for e in once.of("task_cancelled")] == ["U"]
    assert once.robot()["carrying"] == 1 and once.robot()["parts_moved"] == 0
    assert once.summary["stations"]["s1"]["parts"] == 3
    twice = run_toml(loaded(_task(1.0, "U", "unload"), _task(30.0, "U2", "unload")))
    assert [e["task"] for e in twice.of("task_completed")] == ["U2"]
    assert twice.robot()["carrying"] == 0 and twice.robot()["parts_moved"] == 1
    assert twice.summary["stations"]["s1"]["parts"] == 4


def test_s4_random_faults_are_seeded_and_reproducible(tmp_path):
    text = FLEET + """
[[random_faults]]
kind = "breakdown"
mtbf = 20.0
mttr = 5.0
""" + "\n[[script]]\nrobot = \"robot_1\"\n" + motion(1, "A", "A_m1", 1, 1, 80, 0)
    first = run_scenario(parse(tomllib.loads(text)), tmp_path / "a")
    again = run_scenario(parse(tomllib.loads(text)), tmp_path / "b")
    assert (first.dir / "events.jsonl.zst").read_bytes() == (again.dir / "events.jsonl.zst").read_bytes()
    breakdowns = first.of("fault")
    assert breakdowns and all(e["kind"] == "breakdown" for e in breakdowns)
    # 80 m at 1 m/s from t = 1: arrival when 80 s of un-held time have passed since t = 1
    t, left = 1.0, 80.0
    for e in breakdowns:
        start, end = max(e["t"], t), e["t"] + e["duration"]
        if start - t >= left:
            break
        if end > t:
            left -= start - t
            t = end
    assert first.of("task_completed")[0]["t"] == pytest.approx(t + left)
    other = run_scenario(parse(tomllib.loads(text.replace("seed = 0", "seed = 2") if "seed = 0" in text
                                             else text.replace("[simulation]", "[simulation]\nseed = 2"))), tmp_path / "c")
    assert other.of("fault") != breakdowns


@pytest.mark.parametrize(("extra", "problem"), [
    ('[[faults]]\nt = 1.0\nrobot = "robot_1"\nkind = "meteor"', "unknown fault 'meteor'"),
    ('[[faults]]\nt = 1.0\nrobot = "robot_9"\nkind = "pause"', "no robot 'robot_9'"),
    ('[[faults]]\nt = 1.0\nrobot = "robot_1"\nkind = "breakdown"', "field 'duration': missing"),
    ('[[random_faults]]\nkind = "pause"\nmtbf = 5.0', "unknown random fault 'pause'"),
    ('[[random_faults]]\nkind = "breakdown"\nmtbf = 0.0\nmttr = 1.0', "must be positive"),
    # a mean this small drew faults at one instant forever: simulated time stopped, Ctrl-C waited for it
    ('[[random_faults]]\nkind = "motion_failure"\nmtbf = 1e-300', "field 'mtbf': must be at least 1e-06 s"),
    ('[[random_faults]]\nkind = "breakdown"\nmtbf = 1.0\nmttr = 1e-7', "field 'mttr': must be at least 1e-06 s"),
    ('[[random_faults]]\nkind = "breakdown"\nmtbf = 1.0\nmttr = 1.0\nstart = 1e6',  # it would draw nothing
     r"random_faults\[0\]: field 'start': the random fault source starts at t = 1e\+06, when the run has ended"),
    # until before start drew nothing, silently (a job stream's is refused); a robot named twice is a slip
    ('[[random_faults]]\nkind = "breakdown"\nmtbf = 1.0\nmttr = 1.0\nstart = 50.0\nuntil = 20.0',
     r"random_faults\[0\]: field 'until': 20 is not after start 50: the source would draw nothing"),
    ('[[random_faults]]\nkind = "motion_failure"\nmtbf = 1.0\nrobots = ["robot_1", "robot_1"]',
     r"random_faults\[0\]: field 'robots': names 'robot_1' twice"),
    ('[[faults]]\nt = 1e6\nrobot = "robot_1"\nkind = "pause"',
     r"faults\[0\]: field 't': the fault happens at t = 1e\+06, after the run ends \(duration = "),
])
def test_s4_bad_fault_entries_fail_to_load(extra, problem):
    with pytest.raises(ScenarioError, match=problem):
        parse(tomllib.loads(FLEET + "\n" + extra + "\n"), "<test>")


def test_s4_the_smallest_mean_loads():
    """The bound is inclusive (1 µs, docs/robots.md)."""
    text = FLEET + '\n[[random_faults]]\nkind = "breakdown"\nmtbf = 1e-6\nmttr = 1e-6\n'
    assert parse(tomllib.loads(text), "<test>").random_faults[0].mtbf == 1e-6


def test_s4_a_random_stream_always_advances_time():
    """Far out in time a gap can be below the float spacing of ``t`` (``t + gap == t``): the faults
    must still come at strictly later instants, or a run draws them at one instant forever."""
    source = RandomFaults("motion_failure", mtbf=1e-6, start=2.0**60)
    times = [f.t for f in itertools.islice(source.stream(0, "robot_1"), 5)]
    assert all(a < b for a, b in zip([source.start, *times], times)), times


def test_s4_a_link_down_during_another_that_outlasts_it_keeps_the_link_down_to_its_own_end(run_toml):
    """Link downs stack like holds: the link is back when the last one ends (docs/robots.md), as the closed
    loop's Link.outage does. The RAN ignored a link_down that began while another was in force, so the
    robot received and published from the first one's end on, under a fault its events said lasted
    (found by the fifth fresh-user review)."""
    faults = "".join(f'\n[[faults]]\nt = {t}\nrobot = "robot_1"\nkind = "link_down"\nduration = {d}\n'
                     for t, d in ((2.0, 2.0), (3.0, 10.0), (5.0, 1.0)))
    out = run_toml(script(motion(5, "A", "A_m1", 1, 1, 3, 0)).replace("until_idle = true\n", "") + faults)
    assert [(e["t"], e["event"]) for e in out.events if e["event"] in ("fault", "fault_end")] == [
        (2.0, "fault"), (3.0, "fault"), (4.0, "fault_end"), (5.0, "fault"), (6.0, "fault_end"), (13.0, "fault_end")]
    # the task written at 5 is read when the link is back (13), and done 3 s later
    assert [e["t"] for e in out.of("task_queued")] == [13.0]
    assert [e["t"] for e in out.of("task_completed")] == [16.0]
    statuses = [r["t"] for r in out.trace() if r["dir"] == "out" and r["attr"] in ("ran_status", "assignment_state")]
    assert not [t for t in statuses if 2.0 <= t < 13.0]


def test_s4_until_idle_waits_for_a_link_to_be_back(run_toml):
    """A task written while the robot's link is down is read when the link is back (docs/robots.md): with
    until_idle the run ended at the first tick after the script was played, the robot WAITING, the task
    never read and the link never back (found by the fifth fresh-user review)."""
    fault = '\n[[faults]]\nt = 0.5\nrobot = "robot_1"\nkind = "link_down"\nduration = 5.0\n'
    out = run_toml(script(motion(1, "A", "A_m1", 1, 1, 3, 0)) + fault)
    assert [(e["t"], e["event"]) for e in out.events if e["event"] in ("fault_end", "task_queued", "task_completed")] == [
        (5.5, "fault_end"), (5.5, "task_queued"), (8.5, "task_completed")]
    assert out.summary["sim_time"] == 9.0


def test_s4_a_pause_never_resumed_fails_to_load_when_only_idleness_would_end_the_run():
    """until_idle without a duration and a robot paused for good with a task: the run never ended (simulated
    time ran on, tick by tick, until the process was killed; found by the fifth fresh-user review)."""
    text = script(motion(1, "A", "A_m1", 1, 1, 5, 0)).replace("duration = 500.0\n", "")
    pause = '\n[[faults]]\nt = {t}\nrobot = "robot_1"\nkind = "{kind}"\n'
    with pytest.raises(ScenarioError, match=r"<test>: \[\[faults\]\]: robot_1 is paused at t = 0.5 and never resumed, "
                                            r"and \[simulation\] has no duration"):
        parse(tomllib.loads(text + pause.format(t=0.5, kind="pause")), "<test>")
    # resumed later (file order does not matter: time does), or a duration to stop at: it loads
    parse(tomllib.loads(text + pause.format(t=9.0, kind="resume") + pause.format(t=0.5, kind="pause")), "<test>")
    parse(tomllib.loads(text.replace("until_idle = true\n", "until_idle = true\nduration = 60.0\n")
                        + pause.format(t=0.5, kind="pause")), "<test>")


def test_s4_two_random_sources_of_one_kind_draw_independently(run_toml):
    """Each [[random_faults]] table is a source of its own: two of one kind for one robot (say frequent short
    breakdowns and rare long ones) drew from one generator, so their faults came at the same instants, or
    as scaled copies of each other (found by the fifth fresh-user review). The first source of a kind
    draws as before, so scenarios with one source per kind run as they did."""
    source = '\n[[random_faults]]\nkind = "breakdown"\nmtbf = {mtbf}\nmttr = 5.0\n'
    fleet = FLEET.replace("until_idle = true\n", "")  # 500 s
    alone = run_toml(fleet + source.format(mtbf=20.0))
    both = run_toml(fleet + source.format(mtbf=20.0) + source.format(mtbf=20.0))
    first = [e["t"] for e in alone.of("fault")]
    second = sorted(set(e["t"] for e in both.of("fault")) - set(first))
    assert first and set(first) <= {e["t"] for e in both.of("fault")}  # the first source draws as it did alone
    assert second and len(both.of("fault")) == len(first) + len(second)
