"""docs/contract.md §4 properties (issue 11, item 5), with hypothesis: batteries stay in range and an empty robot never
moves; random fault streams never crash a run and every task ends exactly once; collision detection agrees
with a brute-force all-pairs check."""

from __future__ import annotations

import math
import tomllib
from pathlib import Path
from tempfile import TemporaryDirectory

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

from tests.conftest import run_scenario
from vcran.io.scenario_file import parse
from vcran.io.trace import read_header, samples
from vcran.testing.checks import check_run

pytestmark = pytest.mark.slow  # whole runs of drawn fleets, a hundred examples

SQUARE = "[[0.5, 0.5], [-0.5, 0.5], [-0.5, -0.5], [0.5, -0.5]]"
coord = st.integers(-12, 12).map(float)


def fleet(n: int, extra: str = "", robot_extra: str = "", poses=None, collisions: str = "off") -> str:
    head = f'[simulation]\nuntil_idle = true\nduration = 2000.0\ncollisions = "{collisions}"\n{extra}\n'
    robots = "".join(
        f'\n[[robots]]\nid = "r{i}"\npose = [{poses[i][0] if poses else 30.0 * i}, {poses[i][1] if poses else 0.0}, '
        f'{poses[i][2] if poses else 0.0}]\nmax_velocity = 1.0\nfootprint = {SQUARE}\n{robot_extra}'
        for i in range(n)
    )
    return head + robots


def task(t: float, robot: int, name: str, x: float, y: float, actions: str = "") -> str:
    acts = f"\nactions = [{actions}]" if actions else ""
    return f'\n[[script]]\nt = {t}\nrobot = "r{robot}"\nkind = "task"\ntask = "{name}"\npath = [[{x}, {y}]]{acts}\n'


def run(text: str, work: Path):
    return run_scenario(parse(tomllib.loads(text), "<property>"), work)


# --- battery ---------------------------------------------------------------------------------------------

BATTERY = """[robots.battery]
capacity = {capacity}
initial = {initial}
per_metre = {per_metre}
per_idle_second = 0.002
per_action_second = 0.01
charge_rate = 0.05
swap_after = {swap}
"""


@settings(max_examples=25)
@given(capacity=st.sampled_from([0.5, 1.0, 2.0]), fill=st.floats(0.05, 1.0), per_metre=st.sampled_from([0.005, 0.02, 0.05]),
       swap=st.sampled_from([5.0, 40.0]),
       plan=st.lists(st.tuples(st.integers(0, 60), coord, coord, st.booleans()), min_size=1, max_size=6))
def test_s4_battery_stays_in_range_and_an_empty_robot_never_moves(capacity, fill, per_metre, swap, plan):
    text = fleet(1, "", BATTERY.format(capacity=capacity, initial=capacity * fill, per_metre=per_metre, swap=swap))
    text += '\n[[stations]]\nid = "charger"\nposition = [0.0, 0.0]\nreach = 1.0\ncharger = true\n'
    for k, (t, x, y, charge) in enumerate(sorted(plan)):
        text += task(float(t), 0, f"T{k}", x, y, '"charge"' if charge else "")
    with TemporaryDirectory() as tmp:
        out = run(text, Path(tmp))
        charges = [r["value"]["charge"] for r in out.trace() if r["attr"] == "battery_state"]
        assert charges and all(0.0 <= c <= capacity + 1e-9 for c in charges)
        assert 0.0 <= out.robot("r0")["battery"]["charge"] <= capacity + 1e-12
        rows = samples(out.dir)
        swaps = [e["t"] for e in out.of("battery_swapped")]
        for empty in out.of("battery_empty"):
            back = min([s for s in swaps if s >= empty["t"]], default=math.inf)
            still = rows[(rows[:, 0] >= empty["t"]) & (rows[:, 0] < back)]
            assert np.all(still[:, 1] == empty["x"]) and np.all(still[:, 2] == empty["y"]) and np.all(still[:, 4] == 0.0)
        assert check_run(out.dir, 30.0, finished=True) == []


# --- faults ----------------------------------------------------------------------------------------------


@settings(max_examples=25)
@given(seed=st.integers(0, 10_000), mtbf=st.sampled_from([3.0, 10.0, 40.0]),
       kinds=st.lists(st.sampled_from(["breakdown", "motion_failure", "action_failure", "link_down"]), min_size=1, max_size=4, unique=True),
       plan=st.lists(st.tuples(st.integers(0, 1), st.integers(0, 40), coord, coord, st.booleans()), min_size=1, max_size=8))
def test_s4_random_faults_never_crash_and_every_task_ends_once(seed, mtbf, kinds, plan):
    text = fleet(2, f"seed = {seed}\n[simulation.action_durations]\ndummy = 2.0")
    for kind in kinds:
        text += f'\n[[random_faults]]\nkind = "{kind}"\nmtbf = {mtbf}\n' + ("mttr = 3.0\n" if kind in ("breakdown", "link_down") else "")
    for k, (robot, t, x, y, act) in enumerate(sorted(plan, key=lambda p: p[1])):
        text += task(float(t), robot, f"T{k}", x + 30.0 * robot, y, '"dummy"' if act else "")
    with TemporaryDirectory() as tmp:
        out = run(text, Path(tmp))
        queued = [(e["robot"], e["task"]) for e in out.of("task_queued")]
        ends = [(e["robot"], e["task"]) for e in out.events if e["event"] in ("task_completed", "task_cancelled")]
        assert sorted(queued) == sorted(ends) and len(set(ends)) == len(ends)
        assert check_run(out.dir, 30.0, finished=True) == []


# --- collisions ------------------------------------------------------------------------------------------

BRUTE_STEP = 0.002


def brute_force_contacts(text: str, out, pad: float) -> dict[tuple[str, str], list[tuple[float, float]]]:
    """Every pair's contact episodes ``(start, end)``, sampled every BRUTE_STEP s from the robots' legs as
    the script gives them (telemetry would be too coarse), with the squares grown by ``pad`` metres (a
    negative pad: overlapping by more than a graze)."""
    header = read_header(out.dir / "trace.jsonl.zst")["fleet"]["robots"]
    starts = {e["robot"]: e["t"] for e in out.of("state") if e["to"] == "MOTION"}
    script = tomllib.loads(text)["script"]
    end = max(out.summary["sim_time"], 1.0)
    times = np.arange(0.0, end + BRUTE_STEP, BRUTE_STEP)
    half = 0.5 + pad
    boxes = {}
    for r in header:
        (x0, y0, _), (x1, y1) = r["pose"], next(s["path"][0] for s in script if s["robot"] == r["id"])
        d = math.hypot(x1 - x0, y1 - y0)
        s = np.clip(times - starts[r["id"]], 0.0, d)
        ux, uy = ((x1 - x0) / d, (y1 - y0) / d) if d else (0.0, 0.0)
        x, y = x0 + ux * s, y0 + uy * s
        boxes[r["id"]] = shapely.box(x - half, y - half, x + half, y + half)  # legs along the axes: no turning
    ids = sorted(boxes, key=lambda r: int(r[1:]))
    contacts = {}
    for k, a in enumerate(ids):
        for b in ids[k + 1:]:
            hit = shapely.intersects(boxes[a], boxes[b])
            begins = np.flatnonzero(hit & ~np.concatenate(([False], hit[:-1])))
            ends = np.flatnonzero(hit & ~np.concatenate((hit[1:], [False])))
            contacts[(a, b)] = [(float(times[i]), float(times[j])) for i, j in zip(begins, ends, strict=True)]
    return contacts


axis_goal = st.tuples(st.sampled_from(["x", "y"]), st.integers(-12, 12).map(float))


@settings(max_examples=30)
@given(n=st.integers(2, 5), data=st.data())
def test_s4_collision_detection_agrees_with_brute_force(n, data):
    # legs along the axes (every robot faces its goal's axis: no turns), so brute force can use plain boxes
    poses, goals = [], []
    for _ in range(n):
        x, y = data.draw(coord), data.draw(coord)
        axis, to = data.draw(axis_goal)
        goal = (to, y) if axis == "x" else (x, to)
        heading = 0.0 if axis == "x" and to >= x else math.pi if axis == "x" else (math.pi / 2 if to >= y else -math.pi / 2)
        poses.append((x, y, heading))
        goals.append(goal)
    text = fleet(n, poses=poses, collisions="report")
    for i, (gx, gy) in enumerate(goals):
        text += task(1.0, i, f"T{i}", gx, gy)
    with TemporaryDirectory() as tmp:
        out = run(text, Path(tmp))
        reported = {}
        for e in out.of("collision"):
            reported.setdefault((e["robot"], e["other"]), []).append(e["t"])
        # Exact touching (an edge or a corner shared to the last bit) is a coin flip of floating point,
        # so brute force brackets it: "touching" within 1 um, and "overlapping" by more than 1 mm.
        loose = brute_force_contacts(text, out, 1e-6)
        strict = brute_force_contacts(text, out, -1e-3)
        slack = 2 * BRUTE_STEP
        for pair, episodes in loose.items():
            got = reported.get(pair, [])
            # everything reported is real: the footprints touch then (within 1 um)
            for t in got:
                assert any(a - slack <= t <= b + slack for a, b in episodes), (pair, t, episodes)
            # every real overlap is reported, no later than it begins and within the same contact
            for a, b in strict[pair]:
                (a0, b0), = [(x, y) for x, y in episodes if x - slack <= a and b <= y + slack]
                assert any(a0 - slack <= t <= a + slack for t in got), (pair, (a, b), got)
