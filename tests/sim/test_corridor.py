"""docs/contract.md §12 safety fields in a whole run (issue 32): the bundled ``corridor`` and variants of it, through
vcran.simulate (the shared body, OPIL's glue). Instants derived by hand in docs/robots.md ("The corridor, by
hand") and scenarios/corridor.toml: 1 m x 1 m squares, 1 m/s, 0.5 m/s^2 both ways, turns at once, fields
of margin 2 m plus the braking distance (3 m at 1 m/s); a leg from rest covers 1 m in its first 2 s."""

from __future__ import annotations

import dataclasses
import math
import tomllib

import pytest

import vcran
from vcran.core.faults import FaultSpec
from vcran.core.opil.messages import MotionAssignment
from vcran.core.scenario import Scenario, ScriptEntry, TrafficSettings
from vcran.core.traffic.fields import FieldSpec
from vcran.io.scenario_file import bundled, load, parse


def of(result: vcran.Result, *names: str) -> list[dict]:
    return [e for e in result.events if e["event"] in names]


def brief(events: list[dict]) -> list[tuple]:
    keep = ("other", "kind", "duration", "reason", "code", "task")
    return [(round(e["t"], 6), e["robot"], e["event"],
             *(round(e[k], 6) if k == "duration" else e[k] for k in keep if e.get(k) is not None)) for e in events]


@pytest.fixture(scope="module")
def corridor() -> Scenario:
    return load("corridor")


def test_s12_the_corridor_blocks_at_9_and_deadlocks_at_11(corridor: Scenario) -> None:
    """Both blocked at 9 (A at 8, B at 12), both stopped at 11 (at 9 and 11, 1 m apart): one deadlock, a
    cycle, on A naming B. No contact; neither task completes; each robot's ``blocked`` is a ran_error warning
    (OPIL, docs/contract.md §12), two errors in all; blocked from 9 to the end at 60: 51 s each."""
    result = vcran.simulate(corridor)
    assert brief(of(result, "blocked", "unblocked", "deadlock", "collision", "task_completed")) == [
        (9.0, "A", "blocked", "B"), (9.0, "B", "blocked", "A"), (11.0, "A", "deadlock", "B", "cycle", 2.0)]
    assert [e["x"] for e in of(result, "blocked")] == [pytest.approx(8.0), pytest.approx(12.0)]
    robots = result.summary["robots"]
    assert [(r["final_pose"]["x"], r["distance"]) for r in robots.values()] == [
        (pytest.approx(9.0), pytest.approx(9.0)), (pytest.approx(11.0), pytest.approx(9.0))]
    assert [(r["blocks"], r["blocked_time"], r["errors"]) for r in robots.values()] == [
        (1, pytest.approx(51.0), 1), (1, pytest.approx(51.0), 1)]
    assert result.summary["traffic"] == {"blocks": 2, "blocked_time": pytest.approx(102.0), "deadlocks": 1}


def test_s12_a_blocked_robot_publishes_zero_velocity_once_stopped(corridor: Scenario) -> None:
    """OPIL's current_motion: full speed at 9 (braking begins), 0.5 m/s at 10 (halfway through the 2 s
    braking), 0 from 11 on, at x = 9 (A)."""
    telemetry = vcran.simulate(corridor).telemetry
    a = telemetry[telemetry["robot"] == "A"]
    v = {float(t): float(s) for t, s in zip(a["t"], a["v"])}
    assert (v[9.0], v[10.0], v[11.0], v[30.0]) == (pytest.approx(1.0), pytest.approx(0.5), 0.0, 0.0)


def test_s12_on_deadlock_cancel_ends_both_tasks_with_reason_deadlock(corridor: Scenario) -> None:
    """``on_deadlock = "cancel"``: at 11 both robots halt where they stand, which ends each block (after
    2 s); RanLogic reports ``failed`` (code deadlock) and cancels each task with reason deadlock."""
    traffic = dataclasses.replace(corridor.traffic, on_deadlock="cancel")
    result = vcran.simulate(dataclasses.replace(corridor, traffic=traffic))
    assert brief(of(result, "unblocked", "failed", "task_cancelled")) == [
        # the bodies stop (and rest) first; each tells its RanLogic through its inbox, after them
        (11.0, "A", "unblocked", 2.0), (11.0, "B", "unblocked", 2.0),
        (11.0, "A", "failed", "deadlock", "east"), (11.0, "A", "task_cancelled", "deadlock", "east"),
        (11.0, "B", "failed", "deadlock", "west"), (11.0, "B", "task_cancelled", "deadlock", "west")]
    assert result.summary["traffic"] == {"blocks": 2, "blocked_time": pytest.approx(4.0), "deadlocks": 1}


def test_s12_without_fields_the_robots_drive_through_each_other(corridor: Scenario) -> None:
    """The same run with no field: docs/contract.md §4's collision (the fronts meet at x = 10, 1 m + 8.5 s at 1 m/s:
    t = 10.5) and both tasks complete at 22 s; no traffic section in the summary."""
    result = vcran.simulate(dataclasses.replace(corridor, traffic=TrafficSettings()))
    assert brief(of(result, "collision", "task_completed", "blocked")) == [
        (10.5, "A", "collision", "B"), (22.0, "A", "task_completed", "east"), (22.0, "B", "task_completed", "west")]
    assert "traffic" not in result.summary and "blocks" not in result.summary["robots"]["A"]


def parked(corridor: Scenario, faults: tuple[FaultSpec, ...] = ()) -> Scenario:
    """A sent from W to E at 0; B stands facing north at (15, 0) and is sent to (15, 10) at 30."""
    robots = (corridor.robots[0], dataclasses.replace(corridor.robots[1], pose=(15.0, 0.0, math.pi / 2)))
    a, b = corridor.script[0], corridor.script[1]
    assert isinstance(b.message, MotionAssignment)
    north = dataclasses.replace(b.message, point=dataclasses.replace(b.message.point, x=15.0, y=10.0))
    script = (a, ScriptEntry(30.0, "B", b.attribute, north))
    return dataclasses.replace(corridor, robots=robots, script=script, faults=faults)


def test_s12_a_robot_waits_for_a_parked_one_and_drives_on_when_it_leaves(corridor: Scenario) -> None:
    """A's field reaches B's side (14.5) when A is at 11: t = 12. A stops at 12 at t = 14 and waits. B drives
    north from 30: its square leaves A's field (y up to 0.5) after 1 m, at 32. A drives the last 8 m from
    rest: 2 + 6 + 2 s, done at 42; so is B (10 m: 2 + 8 + 2 s from 30). A parked robot has no field."""
    result = vcran.simulate(parked(corridor))
    assert brief(of(result, "blocked", "unblocked", "task_completed", "deadlock")) == [
        (12.0, "A", "blocked", "B"), (32.0, "A", "unblocked", 20.0),
        # a tie at 42: B's leg end was scheduled at 30, before A's (at 32)
        (42.0, "B", "task_completed", "west"), (42.0, "A", "task_completed", "east")]


def test_s12_a_breakdown_while_blocked_ends_the_block_and_the_robot_blocks_again(corridor: Scenario) -> None:
    """As above, with A broken down from 20 to 25 while it waits: the hold ends the block (unblocked after
    8 s); repaired, A sets off from rest at 12 with B still in its field (at rest it reaches 2 m, to B's
    side at 14.5): blocked again at once, and it drives on when B has left, at 32, done at 42 as before."""
    result = vcran.simulate(parked(corridor, (FaultSpec(20.0, "A", "breakdown", 5.0),)))
    assert brief(of(result, "blocked", "unblocked", "task_completed")) == [
        (12.0, "A", "blocked", "B"), (20.0, "A", "unblocked", 8.0), (25.0, "A", "blocked", "B"),
        (32.0, "A", "unblocked", 7.0), (42.0, "B", "task_completed", "west"), (42.0, "A", "task_completed", "east")]


def turning(cancel: bool) -> Scenario:
    """The corridor with turns at 1 rad/s, A sent back west to W at 20 (task ``back``); ``cancel``:
    ``on_deadlock = "cancel"``."""
    data = tomllib.loads(bundled()["corridor"].read_text())
    for r in data["robots"]:
        r["max_angular_velocity"] = 1.0
    if cancel:
        data["traffic"]["on_deadlock"] = "cancel"
    data["script"].append({"t": 20.0, "robot": "A", "kind": "task", "task": "back", "path": [[0.0, 0.0]]})
    return parse(data, "<corridor, turning>")


def test_s12_a_robot_facing_another_turns_and_drives_away() -> None:
    """docs/robots.md "Fields": a turn in place does not translate, so the field points where the leg will
    drive. The corridor with turns at 1 rad/s blocks and deadlocks as before (both robots face their goals:
    no turn), and the deadlock cancels both tasks at 11: A rests at 9 facing B at 11. Sent back west at 20,
    A turns pi (1 rad/s) with its field pointing west, away from B, then drives its 9 m: 2 s up (1 m), 7 s
    at 1 m/s, 2 s down: ``back`` completed at 20 + pi + 11, no block, no second deadlock (A's turning
    square reaches 9 + 0.71, short of B's side at 10.5: no contact)."""
    result = vcran.simulate(turning(cancel=True))
    assert brief(of(result, "blocked", "deadlock", "task_completed", "collision")) == [
        (9.0, "A", "blocked", "B"), (9.0, "B", "blocked", "A"), (11.0, "A", "deadlock", "B", "cycle", 2.0),
        (round(31.0 + math.pi, 6), "A", "task_completed", "back")]
    a = result.summary["robots"]["A"]
    assert (a["final_pose"]["x"], a["final_pose"]["theta"], a["distance"]) == (
        pytest.approx(0.0, abs=1e-9), pytest.approx(math.pi), pytest.approx(18.0))
    assert result.summary["traffic"] == {"blocks": 2, "blocked_time": pytest.approx(4.0), "deadlocks": 1}


def test_s12_without_the_cancel_the_task_sent_back_waits_behind_the_blocked_one() -> None:
    """The same without ``on_deadlock = "cancel"``: A's ``east`` task is still blocked (RanLogic runs tasks in
    order, docs/contract.md §3), so ``back`` waits behind it: nothing turns, nothing else happens to the end
    at 60 (the cycle is reported once; robots in it are not reported again past the bound)."""
    result = vcran.simulate(turning(cancel=False))
    assert brief(of(result, "blocked", "unblocked", "deadlock", "task_completed")) == [
        (9.0, "A", "blocked", "B"), (9.0, "B", "blocked", "A"), (11.0, "A", "deadlock", "B", "cycle", 2.0)]


def test_s12_the_same_corridor_twice_is_the_same_run(corridor: Scenario, tmp_path) -> None:
    """Determinism (docs/contract.md §5): every output byte for byte."""
    vcran.simulate(corridor, out=tmp_path / "a")
    vcran.simulate(corridor, out=tmp_path / "b")
    for name in ("summary.json", "events.jsonl.zst", "legs.npy", "trace.jsonl.zst"):
        assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "b" / name).read_bytes(), name


def test_s12_with_jobs_the_reference_dispatcher_passes_and_straight_routing_deadlocks() -> None:
    """The corridor with a part to carry each way (tests/sim/test_dispatcher_routing.py: both drop-off legs
    land at 3.10) and fields on. The reference Dispatcher sends A to the bay: no block, both jobs done with the
    lead times derived there (64.05, 47.05). Straight routing drives both head-on from 3.10: blocked at
    3.10 + 9 = 12.10, deadlocked at 3.10 + 11 = 14.10, as the script's corridor shifted by 3.10."""
    from tests.sim.test_dispatcher_routing import HEAD_ON
    from tests.sim.test_dispatcher_routing import corridor as with_jobs
    from vcran.managers import Dispatcher

    sc = dataclasses.replace(with_jobs(HEAD_ON), traffic=TrafficSettings(FieldSpec(2.0)))
    routed = vcran.simulate(sc, manager=Dispatcher())
    assert routed.summary["traffic"] == {"blocks": 0, "blocked_time": 0.0, "deadlocks": 0}
    assert {r.id: r.lead_time for r in routed.jobs} == {"j1": pytest.approx(64.05), "j2": pytest.approx(47.05)}
    straight = vcran.simulate(sc, manager=Dispatcher(routing="straight"))
    assert brief(of(straight, "blocked", "deadlock")) == [
        (12.1, "A", "blocked", "B"), (12.1, "B", "blocked", "A"), (14.1, "A", "deadlock", "B", "cycle", 2.0)]
    assert straight.summary["jobs"]["completed"] == 0
