"""The reference fleet manager, vcran.managers.Dispatcher (docs/contract.md §9): nearest idle robot, priority then FIFO,
two tasks per job, a retry after a cancelled task, failure after max_tries."""

from __future__ import annotations

import tomllib

import pytest

import vcran
from vcran.io.scenario_file import parse
from vcran.managers import Dispatcher
from vcran.testing.outcomes import check_failures_have_evidence

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


# --- docs/contract.md §4 in the loop: link_down -------------------------------------------------------------------------

LINK_DOWN = '\n[[faults]]\nt = 5.0\nrobot = "robot_1"\nkind = "link_down"\nduration = 20.0\n'


def test_s4_link_down_in_the_loop_holds_the_robots_news_until_the_link_is_back(tmp_path):
    from vcran.cli import main

    # The pick task lands at 0.05, drives 10 m at 1 m/s and loads for 2 s: done at 12.05, published with
    # the tick at 13, heard at 13.05 (latency 0.05), and the drop task follows at once.
    plain = vcran.simulate(scenario(job(0, "j1")), manager=Dispatcher())
    assert [e["t"] for e in of(plain, "job_assigned")] == [0.0, pytest.approx(13.05)]
    # With robot_1's link down from 5 to 25 the status published at 13 waits in Orion's place: it goes out
    # when the link is back (25) and reaches the manager at 25.05; the drop task then lands at 25.10,
    # drives 20 m and unloads for 2 s (47.10), published at 48 and heard at 48.05.
    result = vcran.simulate(scenario(job(0, "j1") + LINK_DOWN), manager=Dispatcher(), out=tmp_path / "run")
    assert [e["t"] for e in of(result, "job_assigned")] == [0.0, pytest.approx(25.05)]
    assert result.job("j1").lead_time == pytest.approx(48.05)
    assert [(e["event"], e["t"], e["kind"]) for e in result.events if e["event"].startswith("fault")] == [
        ("fault", 5.0, "link_down"), ("fault_end", 25.0, "link_down")]
    # the RAN itself published on time (the link held it): the trace replays byte for byte
    assert main(["replay", str(tmp_path / "run" / "trace.jsonl.zst"), "--out", str(tmp_path / "replay"), "--verify",
                 "--quiet"]) == 0
    # and so does the replay's own trace: it still says the link was the loop's, so the RAN holds nothing
    assert main(["replay", str(tmp_path / "replay"), "--out", str(tmp_path / "again"), "--verify", "--quiet"]) == 0


class Heard(Dispatcher):
    """The Dispatcher, also noting when robot_1's pose reaches it."""

    attributes = frozenset({"ran_status", "current_motion"})

    def on_start(self) -> None:
        super().on_start()
        self.heard: list[float] = []

    def on_update(self, robot, attribute, message, t) -> None:
        if robot == "robot_1" and attribute == "current_motion":
            self.heard.append(t)
        super().on_update(robot, attribute, message, t)


def test_s4_link_down_in_the_loop_hides_the_robots_pose_too():
    manager = Heard()
    vcran.simulate(scenario(job(0, "j1") + LINK_DOWN), manager=manager)
    # a frame every second, heard 0.05 later; robot_1's rows of the frames of 5 to 24 never leave (the
    # latest pose is no news once the link is back): Orion, and the manager, keep the pose of 4
    assert manager.heard[:6] == [pytest.approx(k + 0.05) for k in range(5)] + [pytest.approx(25.05)]


# --- docs/contract.md §4 in the loop: charging when low, re-planning after a fault --------------------------------------

def battery(initial: float, *, swap_after: float | None = None) -> str:
    swap = f"swap_after = {swap_after}\n" if swap_after is not None else ""
    return ("[robots.battery]\ncapacity = 1.0\n"
            f"initial = {initial}\nper_metre = 0.01\ncharge_rate = 0.1\n{swap}")


CHARGER = '\n[[stations]]\nid = "charger"\nposition = [10.0, 0.0]\ncharger = true\n'


def with_battery(jobs: str, initial: float, *, swap_after: float | None = None, charger: bool = False) -> vcran.Scenario:
    text = FLEET.format(robot_2="", parts=5).replace("max_velocity = 1.0\n", "max_velocity = 1.0\n" + battery(
        initial, swap_after=swap_after), 1)
    return parse(tomllib.loads(text + (CHARGER if charger else "") + jobs), "<test>")


def test_s4_a_robot_low_after_its_job_charges_before_the_next_one():
    # 50 % (0.5 Ah), 0.01 Ah/m. j1: 10 m to a, 20 m to b: 0.2 Ah left (20 %, below charge_below 30 %), heard
    # with the battery update of the tick at 34. j1 is done at 36.05 (unload ends 35.10, status at 36):
    # robot_1 goes to the charger at (10, 0), 14.142 m from b, landing at 36.10: there at 50.252 with
    # 0.2 - 0.14142 = 0.05858 Ah, full after (1 - 0.05858) / 0.1 = 9.4142 s, at 59.666; heard at 60.05,
    # when j2 (waiting since 40) gets the robot.
    result = vcran.simulate(with_battery(job(0, "j1") + job(40, "j2"), 0.5, charger=True),
                            manager=Dispatcher(charge_below=0.3))
    assert [(e["task"], e["t"]) for e in of(result, "job_assigned")][:3] == [
        ("j1_pick1", 0.0), ("j1_drop1", pytest.approx(13.05)), ("j2_pick1", pytest.approx(60.05))]
    done = {e["task"]: e["t"] for e in of(result, "task_completed")}
    assert done["charge1_robot_1"] == pytest.approx(36.10 + 10 * 2 ** 0.5 + (1 - 0.2 + 0.1 * 2 ** 0.5) / 0.1)
    assert result.summary["jobs"]["completed"] == 2


def test_s4_without_a_charger_a_low_robot_keeps_working():
    result = vcran.simulate(with_battery(job(0, "j1") + job(40, "j2"), 0.5), manager=Dispatcher())
    assert [e["t"] for e in of(result, "job_assigned")][2] == pytest.approx(40.0)


def test_s4_an_empty_robot_is_out_until_swapped_and_its_pickup_is_planned_again():
    # 0.05 Ah at 0.01 Ah/m: empty 5 m into the pick leg (t = 5.05), heard at 5.10 (the ran_error): one try
    # lost, the job back in the queue at 15.10 but no robot to take it; the battery swapped at 35.05 is
    # published at 36 and heard at 36.05: robot_1 takes j1 again, 5 m from a.
    result = vcran.simulate(with_battery(job(0, "j1"), 0.05, swap_after=30.0), manager=Dispatcher())
    assert [(e["task"], e["t"]) for e in of(result, "job_assigned")] == [
        ("j1_pick1", 0.0), ("j1_pick2", pytest.approx(36.05)), ("j1_drop2", pytest.approx(44.05))]
    assert result.summary["robots"]["robot_1"]["cancelled"] == [{"task": "j1_pick1", "reason": "battery_empty"}]
    assert result.job("j1").outcome == "completed" and result.job("j1").lead_time == pytest.approx(67.05)


def test_s4_a_part_stranded_on_an_empty_robot_fails_its_job_at_once():
    # 0.2 Ah: 0.1 left after the pick leg, empty 10 m into the drop leg (lands 13.10: 23.10), heard 23.15
    result = vcran.simulate(with_battery(job(0, "j1"), 0.2), manager=Dispatcher())
    (failed,) = of(result, "job_failed")
    assert (failed["job"], failed["reason"], failed["tasks"], failed["t"]) == ("j1", "battery_empty", 2,
                                                                           pytest.approx(23.15))


def test_s4_the_drop_off_of_a_robot_swapped_in_time_waits_for_it():
    # as above, swapped 20 s later (43.10), published at 44, heard at 44.05: the drop-off goes again from
    # (0, 0), 10 m: lands 44.10, arrives 54.10, unloads until 56.10, heard done at 57.05
    result = vcran.simulate(with_battery(job(0, "j1"), 0.2, swap_after=20.0), manager=Dispatcher())
    assert [(e["task"], e["t"]) for e in of(result, "job_assigned")][2] == ("j1_drop2", pytest.approx(44.05))
    assert result.job("j1").lead_time == pytest.approx(57.05)


def test_s4_a_motion_failure_costs_the_pickup_one_try_and_it_is_planned_again():
    # the pick leg fails at 5 (robot at (0, 5)); cancelled motion_failed, published by the tick of the
    # same instant (faults act before telemetry), heard 5.05; the retry waits 10 s: j1_pick2 at 15.05
    fault = '\n[[faults]]\nt = 5.0\nrobot = "robot_1"\nkind = "motion_failure"\n'
    result = vcran.simulate(scenario(job(0, "j1") + fault), manager=Dispatcher())
    assert [(e["task"], e["t"]) for e in of(result, "job_assigned")][:2] == [("j1_pick1", 0.0),
                                                                           ("j1_pick2", pytest.approx(15.05))]
    assert result.job("j1").outcome == "completed"


def resting(jobs: str, *, swap_after: float | None = None, others: str = "") -> vcran.Scenario:
    """robot_1 rests with 0.05 Ah of 1 and draws 0.01 Ah/s: its battery runs empty at t = 5."""
    text = FLEET.format(robot_2=others, parts=5).replace("max_velocity = 1.0\n", "max_velocity = 1.0\n" + battery(
        0.05, swap_after=swap_after) + "per_idle_second = 0.01\n", 1)
    return parse(tomllib.loads(text + jobs), "<test>")


def test_s4_a_task_refused_by_a_robot_already_out_of_service_is_planned_again():
    # robot_1 is empty at 5, before any job. j1 (t = 10) goes to it anyway (no charger to send it to):
    # refused on landing (10.05) with ran_error battery_empty, heard 10.10, which is the only word on that
    # task. Swapped at 35, published with that instant's tick, heard 35.05: j1 goes out again.
    result = vcran.simulate(resting(job(10, "j1"), swap_after=30.0), manager=Dispatcher())
    assert [(e["task"], e["t"]) for e in of(result, "job_assigned")][:2] == [("j1_pick1", 10.0),
                                                                           ("j1_pick2", pytest.approx(35.05))]
    assert result.job("j1").outcome == "completed"


# --- docs/contract.md §4 in the loop: a failed load or unload moves nothing (issue 29 item 5) ----------------------------

ACTION_FAILURE = '\n[[faults]]\nt = {t}\nrobot = "robot_1"\nkind = "action_failure"\n'


def test_s4_a_load_failed_by_a_fault_is_picked_up_again_and_the_job_completes():
    # The load armed to fail at 0.5 ends at 12.05 (10 m at 1 m/s from 0.05, then 2 s) and takes no part: the
    # retry after 10 s loads one. It used to take the part anyway, so the retries failed load_full.
    result = vcran.simulate(scenario(job(0, "j1") + ACTION_FAILURE.format(t=0.5)), manager=Dispatcher())
    assert result.job("j1").tasks == ("j1_pick1", "j1_pick2", "j1_drop2")
    assert result.job("j1").outcome == "completed"
    assert [c["reason"] for c in result.summary["robots"]["robot_1"]["cancelled"]] == ["action_failed"]
    stations = result.summary["stations"]
    assert (stations["a"]["parts"], stations["b"]["parts"], result.summary["robots"]["robot_1"]["carrying"]) == (4, 1, 0)


def test_s4_a_drop_off_failed_by_a_fault_is_sent_again_to_the_robot_that_carries_the_part():
    # The load ends 12.05; the fault armed at 13 fails the unload at b (lands 13.10, 20 m, 2 s: 35.10),
    # heard with the tick of 36 at 36.05. The part is still on board: the retry (10 s later) is a drop-off on
    # the same robot, not a new pickup; it ends 2 s after landing at 46.10, heard at 49.05.
    result = vcran.simulate(scenario(job(0, "j1") + ACTION_FAILURE.format(t=13.0)), manager=Dispatcher())
    assert [(e["robot"], e["task"], e["t"]) for e in of(result, "job_assigned")] == [
        ("robot_1", "j1_pick1", 0.0), ("robot_1", "j1_drop1", pytest.approx(13.05)),
        ("robot_1", "j1_drop2", pytest.approx(46.05))]
    assert result.job("j1").outcome == "completed" and result.job("j1").lead_time == pytest.approx(49.05)
    stations = result.summary["stations"]
    assert (stations["a"]["parts"], stations["b"]["parts"], result.summary["robots"]["robot_1"]["carrying"]) == (4, 1, 0)
    assert result.summary["robots"]["robot_1"]["parts_moved"] == 1


@pytest.mark.slow
def test_s4_the_warehouse_with_one_action_failure_completes_every_job():
    """Issue 29 item 5: with one action failure at t = 1 on robot_1 the Dispatcher completed 203 of 224 jobs;
    robot_1 kept the part of its failed load and failed a job every ~20 s (load_full) for the rest of the hour."""
    from dataclasses import replace

    from tests.conftest import ROOT
    from vcran.core.faults import FaultSpec

    warehouse = vcran.load_scenario(ROOT / "scenarios" / "warehouse.toml")
    result = vcran.simulate(replace(warehouse, faults=(FaultSpec(1.0, "robot_1", "action_failure"),)))
    jobs = result.summary["jobs"]
    assert (jobs["completed"], jobs["failed"], jobs["open"]) == (jobs["arrived"], 0, 0)
    [failed] = [e for e in result.events if e["event"] == "failed"]  # the one injected, nothing after it
    assert (failed["robot"], failed["code"]) == ("robot_1", "action_fault")


# --- a part the Dispatcher could not deliver (issue 29 item 5: never a pickup on a loaded robot) -----------

def test_s4_a_part_whose_drop_off_failed_for_good_is_returned_and_the_robot_works_on():
    """Issue 29 item 5: j1's unload at b fails (the fault armed at 13; it ends 35.10, heard 36.05) and with
    max_tries = 1 j1 fails with the part on board. It used to stay there: j2's pickups then failed load_full.
    Now the part goes back to the nearest station that has not refused it, a (b did): return1_robot_1 lands
    36.10, drives 20 m to a's dock (56.10) and unloads until 58.10, heard 59.05. j2 (arrived 40) then loads
    at a where the robot stands (59.10 + 2 s, heard 62.05) and unloads at b (62.10 + 20 m + 2 s = 84.10,
    heard 85.05). Parts: a 5 - 1 + 1 - 1 = 4, b 1, none on board."""
    result = vcran.simulate(scenario(job(0, "j1") + job(40, "j2") + ACTION_FAILURE.format(t=13.0)),
                            manager=Dispatcher(max_tries=1))
    assert [(e["job"], e["reason"], e["t"]) for e in of(result, "job_failed")] == [
        ("j1", "action_failed", pytest.approx(36.05))]
    assert [(e["task"], e["t"]) for e in of(result, "task_completed")][1] == ("return1_robot_1", pytest.approx(58.10))
    assert [(e["task"], e["t"]) for e in of(result, "job_assigned") if e["job"] == "j2"] == [
        ("j2_pick1", pytest.approx(59.05)), ("j2_drop1", pytest.approx(62.05))]
    assert result.job("j2").outcome == "completed" and result.job("j2").lead_time == pytest.approx(85.05 - 40)
    assert not [e for e in result.events if e["event"] == "failed" and e.get("code") == "load_full"]
    stations = result.summary["stations"]
    assert (stations["a"]["parts"], stations["b"]["parts"], result.summary["robots"]["robot_1"]["carrying"]) == (4, 1, 0)


def test_s4_a_part_no_station_takes_stays_on_board_and_its_robot_takes_no_pickup():
    # as above, and a second fault armed at 37 fails the return's unload at a (58.10): every station has
    # refused the part, so robot_1 keeps it (an operator must unload it) and is sent to no pickup: j2 waits
    result = vcran.simulate(scenario(job(0, "j1") + job(40, "j2") + ACTION_FAILURE.format(t=13.0)
                                     + ACTION_FAILURE.format(t=37.0)), manager=Dispatcher(max_tries=1))
    assert [e["task"] for e in of(result, "task_cancelled")] == ["j1_drop1", "return1_robot_1"]
    assert [e["job"] for e in of(result, "job_assigned")] == ["j1", "j1"]
    assert result.job("j2").outcome == "open" and result.summary["robots"]["robot_1"]["carrying"] == 1
    assert not [e for e in result.events if e["event"] == "failed" and e.get("code") == "load_full"]


def test_s4_a_robot_that_starts_loaded_returns_its_part_before_its_first_pickup():
    # robot_1 starts with a part: a and b are both 10 m from it, a listed first. return1_robot_1 lands 0.05,
    # at a 10.05, unloaded 12.05, heard 13.05; then j1 (waiting since 0) loads at a (13.10 + 2 s, heard 16.05)
    # and unloads at b (16.10 + 20 m + 2 s = 38.10, heard 39.05). It used to take j1 at once, and fail load_full.
    text = FLEET.format(robot_2="", parts=5).replace("max_velocity = 1.0\n", "max_velocity = 1.0\ncarrying = 1\n", 1)
    result = vcran.simulate(parse(tomllib.loads(text + job(0, "j1")), "<test>"), manager=Dispatcher())
    assert [(e["task"], e["t"]) for e in of(result, "task_completed")][0] == ("return1_robot_1", pytest.approx(12.05))
    assert result.job("j1").tasks == ("j1_pick1", "j1_drop1") and result.job("j1").lead_time == pytest.approx(39.05)
    stations = result.summary["stations"]
    assert (stations["a"]["parts"], stations["b"]["parts"], result.summary["robots"]["robot_1"]["carrying"]) == (5, 1, 0)


# --- jobs no robot can serve (docs/contract.md §9: a job failed with evidence; issue 29 item 6) -------------------------

def test_a_job_no_robot_can_serve_is_reported_unassignable_at_once():
    # robot_1 cannot unload: it could never finish a job, so it gets none and each fails on arrival
    text = FLEET.format(robot_2="", parts=5).replace("max_velocity = 1.0\n", 'max_velocity = 1.0\nactions = ["load"]\n', 1)
    result = vcran.simulate(parse(tomllib.loads(text + job(0, "j1") + job(7, "j2")), "<test>"), manager=Dispatcher())
    assert [(e["job"], e["reason"], e["t"]) for e in of(result, "job_failed")] == [
        ("j1", "unassignable", 0.0), ("j2", "unassignable", 7.0)]
    assert of(result, "job_assigned") == [] and check_failures_have_evidence(result) == []


def test_jobs_waiting_when_the_last_robot_is_lost_for_good_are_reported_unassignable():
    # 0.05 Ah at 0.01 Ah/m, never swapped: robot_1 runs empty 5 m into j1's pickup (5.05), heard 5.10; j1
    # waits its 10 s back-off and comes back (15.10) to a fleet with no robot left: unassignable then, as
    # is j2 on arrival at 30. They used to stay open until the run's end.
    result = vcran.simulate(with_battery(job(0, "j1") + job(30, "j2"), 0.05), manager=Dispatcher())
    assert [(e["job"], e["reason"], e["t"]) for e in of(result, "job_failed")] == [
        ("j1", "unassignable", pytest.approx(15.10)), ("j2", "unassignable", 30.0)]
    assert check_failures_have_evidence(result) == [] and result.summary["jobs"]["open"] == 0


ROBOT_3 = '[[robots]]\nid = "robot_3"\npose = [2.0, 9.0, 0.0]\nmax_velocity = 1.0\nactions = ["dummy"]'


def test_s4_robots_out_of_service_or_unable_to_move_parts_are_not_idle_while_a_job_waits():
    """docs/contract.md §4/§9 (vcran.testing.loop.check_no_idle_while_waiting): robot_1 is empty from 5 until swapped
    at 205, robot_3 cannot load or unload; robot_2 does the three jobs of t = 10 one after the other (j2
    from 37.05: 20 m to a, 2 s, 20 m to b, 2 s, heard done at 83.05), so j3 waits until 83.05. Neither
    robot_1 nor robot_3 could have taken it: both were reported idle 10..83.05 while it waited."""
    from vcran.testing.loop import check_no_idle_while_waiting

    jobs = job(10, "j1") + job(10, "j2") + job(10, "j3")
    result = vcran.simulate(resting(jobs, swap_after=200.0, others=ROBOT_2 + "\n" + ROBOT_3), manager=Dispatcher())
    assert [(e["robot"], e["t"]) for e in of(result, "battery_empty")] == [("robot_1", 5.0)]
    assert [e["t"] for e in of(result, "job_assigned") if e["job"] == "j3"][0] == pytest.approx(83.05)
    assert check_no_idle_while_waiting(result) == []
