"""The Dispatcher on a roadmap (docs/contract.md §12, issue 32 item 4): shortest routes under node reservations, one OPIL
task per stretch, so that its robots neither collide nor deadlock; ``routing = "straight"`` drives through.

Every scenario here: 1 m x 1 m robots at 1 m/s, 0.5 m/s^2 both ways, turns at once (docs/robots.md's
corridor), load and unload 2 s, the link's 50 ms, status ticks every second. A leg runs rest to rest: 10 m
take 2 + 8 + 2 = 12 s, 2 m take 4 s, 20 m take 22 s, 4.1 m take 2 + 2.1 + 2 = 6.1 s. The manager hears a
task's end (``ran_status``) and a node reached (``assignment_state``'s ``last_finished_motion``) at the
next whole second, plus 0.05 s; what it sends lands 0.05 s later.
"""

from __future__ import annotations

import math
import tomllib

import pytest
from hypothesis import given
from hypothesis import strategies as st

import vcran
from vcran.core.scenario import Job, LinkSettings, RobotConfig, Scenario, Settings, StationConfig
from vcran.core.traffic.roadmap import Edge, Node, Roadmap, validate
from vcran.io.scenario_file import parse
from vcran.managers import Dispatcher
from vcran.testing.loop import loop_problems

SQUARE = "[[0.5, 0.5], [-0.5, 0.5], [-0.5, -0.5], [0.5, -0.5]]"
ROBOT = """
[[robots]]
id = "{id}"
pose = [{x}, {y}, {theta}]
max_velocity = 1.0
max_acceleration = 0.5
footprint = {square}
"""
HEAD = """
[simulation]
duration = {duration}
until_idle = true
[simulation.action_durations]
load = 2.0
unload = 2.0
"""


def station(id: str, node: str, x: float, y: float) -> str:
    return f'\n[[stations]]\nid = "{id}"\nposition = [{x}, {y}]\ndock = "{node}"\nparts = 5\n'


def job(t: float, id: str, pickup: str, dropoff: str) -> str:
    return f'\n[[jobs]]\nt = {t}\nid = "{id}"\npickup = "{pickup}"\ndropoff = "{dropoff}"\n'


def load(text: str) -> Scenario:
    return parse(tomllib.loads(text), "<test>")


def robot(id: str, x: float, y: float, theta: float) -> str:
    return ROBOT.format(id=id, x=x, y=y, theta=theta, square=SQUARE)


def of(result: vcran.Result, name: str) -> list[dict]:
    return [e for e in result.events if e["event"] == name]


# --- a crossing: straight lines meet in the middle, the reservations take turns ------------------------------

CROSSING = (HEAD.format(duration=300.0) + robot("A", 0.0, 10.0, -math.pi / 2) + robot("B", -10.0, 0.0, 0.0) + """
[roadmap]
nodes = [{ id = "N", x = 0.0, y = 10.0 }, { id = "S", x = 0.0, y = -10.0 }, { id = "W", x = -10.0, y = 0.0 },
         { id = "E", x = 10.0, y = 0.0 }, { id = "C", x = 0.0, y = 0.0 }]
edges = [{ from = "N", to = "C" }, { from = "C", to = "S" }, { from = "W", to = "C" }, { from = "C", to = "E" }]
""" + station("north", "N", 0.0, 11.0) + station("south", "S", 0.0, -11.0) + station("west", "W", -11.0, 0.0)
    + station("east", "E", 11.0, 0.0) + job(0.0, "j1", "north", "south") + job(0.0, "j2", "west", "east"))


def test_s12_straight_lines_through_a_crossing_collide():
    """A (at N) carries j1 south, B (at W) j2 east. Each loads where it stands (lands 0.05, 2 s, heard 3.05);
    both drop-offs land at 3.10 and drive 20 m straight through the middle, where the squares first touch
    9 m in (2 s to cover 1 m, then 8 s at 1 m/s): t = 13.10. Both jobs still complete (collisions reported)."""
    result = vcran.simulate(load(CROSSING), manager=Dispatcher(routing="straight"))
    assert [(e["robot"], e["other"], e["t"]) for e in of(result, "collision")] == [("A", "B", pytest.approx(13.10))]
    assert result.summary["jobs"]["completed"] == 2


def test_s12_on_the_roadmap_one_robot_waits_for_the_crossing_to_clear():
    """A asks first (its status comes first in the batch of 3.05): N-C-S, one stretch, reserved. B's W-C-E
    is safe (A finishes first) but waits for C. A: at C 15.10 (N released at 16.05), at S 27.10 (C released
    at 28.05), unloaded 29.10, heard 30.05. B's stretch lands 28.10: at C 40.10, at E 52.10, unloaded 54.10,
    heard 55.05. No contact: B starts once A is 10 m past the middle."""
    result = vcran.simulate(load(CROSSING), manager=Dispatcher())
    assert of(result, "collision") == []
    assert [(e["task"], e["t"]) for e in of(result, "job_assigned")] == [
        ("j1_pick1_s1", 0.0), ("j2_pick1_s1", 0.0), ("j1_drop1_s1", pytest.approx(3.05)),
        ("j2_drop1_s1", pytest.approx(28.05))]
    assert {r.id: r.lead_time for r in result.jobs} == {"j1": pytest.approx(30.05), "j2": pytest.approx(55.05)}
    assert loop_problems(result) == []


# --- the corridor of docs/robots.md: head-on in one lane, a passing bay -------------------------------------

CORRIDOR_MAP = """
[roadmap]
nodes = [
  { id = "W", x = 0.0, y = 0.0 }, { id = "M", x = 10.0, y = 0.0 }, { id = "E", x = 20.0, y = 0.0 },
  { id = "P", x = 10.0, y = 2.0, waiting = true },{extra_nodes}
]
edges = [{ from = "W", to = "M" }, { from = "M", to = "E" }, { from = "M", to = "P" },{extra_edges}]
"""
STATIONS = station("west", "W", -1.0, 0.0) + station("east", "E", 21.0, 0.0)


def corridor(jobs: str, *, bay: bool = True, second_bay: bool = False, duration: float = 300.0,
             a: str = "0.0, 0.0") -> Scenario:
    x, y = (float(v) for v in a.split(","))
    roadmap = CORRIDOR_MAP.replace("{extra_nodes}", ' { id = "Q", x = 20.0, y = 2.0, waiting = true },' if second_bay
                                   else "").replace("{extra_edges}", ' { from = "E", to = "Q" },' if second_bay else "")
    if not bay:
        roadmap = roadmap.replace('{ id = "P", x = 10.0, y = 2.0, waiting = true },', "").replace(
            ', { from = "M", to = "P" }', "")
    return load(HEAD.format(duration=duration) + robot("A", x, y, 0.0) + robot("B", 20.0, 0.0, math.pi) + roadmap
                + STATIONS + jobs)


HEAD_ON = job(0.0, "j1", "west", "east") + job(0.0, "j2", "east", "west")


def test_s12_corridor_one_robot_waits_in_the_bay_and_both_finish():
    """docs/robots.md's corridor with jobs: A carries j1 from W to E, B j2 from E to W. Both load where they
    stand (heard 3.05). A asks first: its straight route is unsafe (B rests at E and will need W), so it
    goes to the bay P (stretch M, P; lands 3.10): at M 15.10, at P 19.10 (heard 20.05: M released). B's
    route E-M-W, accepted after A's, gets M and W at 20.05: at M 32.10, at W 44.10 (M released, heard
    45.05), unloaded 46.10, heard 47.05. A's route P-M-E then gets M and E at 45.05: lands 45.10, at M
    49.10, at E 61.10, unloaded 63.10, heard 64.05. A waits in the bay from 19.10 to 45.10; no contact."""
    result = vcran.simulate(corridor(HEAD_ON), manager=Dispatcher())
    assert of(result, "collision") == []
    assert [(e["robot"], e["task"], e["t"]) for e in of(result, "job_assigned")] == [
        ("A", "j1_pick1_s1", 0.0), ("B", "j2_pick1_s1", 0.0), ("A", "j1_drop1_s1", pytest.approx(3.05)),
        ("B", "j2_drop1_s1", pytest.approx(20.05)), ("A", "j1_drop1_s2", pytest.approx(45.05))]
    reached = [(e["robot"], e["motion"], e["t"]) for e in of(result, "motion_finished") if "_drop" in e["task"]]
    assert reached == [("A", "j1_drop1_s1_m1", pytest.approx(15.10)), ("A", "j1_drop1_s1_m2", pytest.approx(19.10)),
                       ("B", "j2_drop1_s1_m1", pytest.approx(32.10)), ("B", "j2_drop1_s1_m2", pytest.approx(44.10)),
                       ("A", "j1_drop1_s2_m1", pytest.approx(49.10)), ("A", "j1_drop1_s2_m2", pytest.approx(61.10))]
    assert {r.id: r.lead_time for r in result.jobs} == {"j1": pytest.approx(64.05), "j2": pytest.approx(47.05)}
    assert loop_problems(result) == []


def test_s12_corridor_straight_routing_drives_head_on_through_the_other_robot():
    """Both drop-offs land at 3.10 and drive 20 m head-on: the fronts meet when each has covered 9.5 m
    (1 m in 2 s, then 8.5 s at 1 m/s): t = 13.60, at x = 10."""
    result = vcran.simulate(corridor(HEAD_ON), manager=Dispatcher(routing="straight"))
    assert [(e["robot"], e["other"], e["t"], e["x"]) for e in of(result, "collision")] == [
        ("A", "B", pytest.approx(13.60), pytest.approx(10.0))]


def test_s12_without_a_bay_the_reservations_never_swap_the_robots():
    """No waiting node: neither robot may pass the other, so neither drop-off is ever granted (the
    reservations keep them apart rather than let them meet); the jobs stay open. docs/loop.md says a roadmap
    needs bays; vcran.testing's "no deadlock" property reports the two robots (tests/testing)."""
    result = vcran.simulate(corridor(HEAD_ON, bay=False, duration=200.0), manager=Dispatcher())
    assert [e["task"] for e in of(result, "job_assigned")] == ["j1_pick1_s1", "j2_pick1_s1"]
    assert of(result, "collision") == [] and result.summary["jobs"]["open"] == 2


def test_s12_an_idle_robot_in_the_way_is_parked_in_a_bay():
    """One job, j1 from W to E, where B rests idle; a second bay Q (20, 2) off E. A loads (heard 3.05) and is
    sent to the bay P (E is taken: stretch M, P; at P 19.10, heard 20.05). From P its route needs E, held
    by idle B: B is parked in Q (park1_B, lands 20.10, 2 m: 24.10, heard 25.05, E released). A then gets M
    and E: lands 25.10, at M 29.10, at E 41.10, unloaded 43.10, heard 44.05. B at Q is 2 m from E: no contact."""
    result = vcran.simulate(corridor(job(0.0, "j1", "west", "east"), second_bay=True), manager=Dispatcher())
    tasks = [(e["robot"], e["task"], e["t"]) for e in of(result, "task_queued")]
    assert tasks == [("A", "j1_pick1_s1", pytest.approx(0.05)), ("A", "j1_drop1_s1", pytest.approx(3.10)),
                     ("B", "park1_B_s1", pytest.approx(20.10)), ("A", "j1_drop1_s2", pytest.approx(25.10))]
    assert result.job("j1").lead_time == pytest.approx(44.05) and of(result, "collision") == []


def test_s12_a_robot_off_the_roadmap_drives_to_its_node_first():
    """A starts at (0, -1.5), off the roadmap: it is placed at the nearest node, W, and its first task drives
    there (m1) before the dock's point (m2) and the load."""
    result = vcran.simulate(corridor(job(0.0, "j1", "west", "east"), a="0.0, -1.5", second_bay=True),
                            manager=Dispatcher())
    first = [e["motion"] for e in of(result, "motion_finished") if e["task"] == "j1_pick1_s1"]
    assert first == ["j1_pick1_s1_m1", "j1_pick1_s1_m2"]
    assert result.job("j1").outcome == "completed" and of(result, "collision") == []


def test_s12_a_cancelled_stretch_fails_the_task_for_the_manager_and_the_robot_drives_on():
    """A's motion fails at t = 10 on its way W -> M (stretch M, P, to the bay): the Dispatcher loses one try
    of j1's drop-off and sends it again after 10 s, but the robot holds M and P, on a route B's plan counts
    on: the router drives it on there at once (j1_drop1_s2, no job: only the route), and the drop-off
    sent again (j1_drop2) starts where that route ends. Both jobs complete, no contact."""
    fault = '\n[[faults]]\nt = 10.0\nrobot = "A"\nkind = "motion_failure"\n'
    result = vcran.simulate(corridor(HEAD_ON + fault), manager=Dispatcher())
    assert [(e["task"], e["reason"]) for e in of(result, "task_cancelled")] == [("j1_drop1_s1", "motion_failed")]
    driven_on = [e for e in of(result, "task_queued") if e["task"] == "j1_drop1_s2"]
    assert [e["t"] for e in driven_on] == [pytest.approx(10.10)]  # cancelled at the tick of 10, heard 10.05
    assert "j1_drop1_s2" not in result.job("j1").tasks and result.job("j1").tasks[-1].startswith("j1_drop2_")
    assert result.summary["jobs"]["completed"] == 2 and of(result, "collision") == []


def test_s12_under_polling_a_stretch_goes_out_motion_by_motion():
    """Under polling, a stretch's motions written at once would overwrite one another before the RAN reads
    them (the task would never assemble); the router spaces them by 1.5 poll intervals."""
    from dataclasses import replace

    polled = replace(corridor(HEAD_ON), link=LinkSettings(inbound="polling", poll_interval=0.25))
    result = vcran.simulate(polled, manager=Dispatcher())
    assert [e for e in of(result, "task_cancelled")] == [] and of(result, "collision") == []
    assert result.summary["jobs"]["completed"] == 2


def test_s12_the_routing_option():
    with pytest.raises(ValueError, match="routing is one of auto, roadmap, straight; got 'shortest'"):
        Dispatcher(routing="shortest")
    text = HEAD.format(duration=10.0) + robot("A", 0.0, 0.0, 0.0) + '\n[[stations]]\nid = "s"\nposition = [1.0, 0.0]\n'
    with pytest.raises(ValueError, match=r"routing on the roadmap needs a scenario with a \[roadmap\]"):
        vcran.simulate(load(text), manager=Dispatcher(routing="roadmap"))


# --- the property: random small roadmaps and workloads ------------------------------------------------------

SPACING = 4.0  # lane nodes on a 4 m grid, each with a bay 2 m off both axes: 2 m from anything, > 2 x 0.71 m


class Watched(Dispatcher):
    """The Dispatcher, checking after every hook that no node is held twice and that every robot drives
    only nodes it holds."""

    def on_start(self) -> None:
        super().on_start()
        self.clashes: list[str] = []
        self.watch()

    def watch(self) -> None:
        router = self.router
        assert router is not None
        holders: dict[str, str] = {}
        for robot in self.fleet.robot_ids:
            held = router.plan.held(robot)
            for node in held:
                if node in holders:
                    self.clashes.append(f"t={self.handle.now}: {node} held by {holders[node]} and {robot}")
                holders[node] = robot
            s = router.robots[robot].stretch
            if s is not None and not set(s.nodes[s.reached:]) <= set(held):
                self.clashes.append(f"t={self.handle.now}: {robot} drives {s.nodes[s.reached:]} holding {held}")

    def on_job(self, job: Job) -> None:
        super().on_job(job)
        self.watch()

    def on_update(self, robot, attribute, message, t) -> None:
        super().on_update(robot, attribute, message, t)
        self.watch()


@st.composite
def layouts(draw: st.DrawFn) -> Scenario:
    """Lanes on a grid (2-4 columns, 1-3 rows), connected by a random spanning tree plus random extra
    edges, both ways; a bay (waiting node) off every lane node; 2-4 stations docked at distinct lane nodes;
    fewer robots than lane nodes (so that robots can always pass one another through the bays), at distinct
    nodes; 1-5 jobs in the first 30 s."""
    cols, rows = draw(st.integers(2, 4)), draw(st.integers(1, 3))
    lanes = [(c, r) for r in range(rows) for c in range(cols)]
    order = draw(st.permutations(lanes))
    tree, seen = set(), {order[0]}
    for cell in order[1:]:  # join each cell to a seen neighbour, in a drawn order: a random spanning tree
        c, r = cell
        near = [n for n in ((c - 1, r), (c + 1, r), (c, r - 1), (c, r + 1)) if n in seen]
        if near:
            tree.add(tuple(sorted((cell, draw(st.sampled_from(near))))))
            seen.add(cell)
    while len(seen) < len(lanes):  # a cell without a seen neighbour at its turn joins later, next to one
        for cell in order:
            c, r = cell
            near = sorted(n for n in ((c - 1, r), (c + 1, r), (c, r - 1), (c, r + 1)) if n in seen)
            if cell not in seen and near:
                tree.add(tuple(sorted((cell, near[0]))))
                seen.add(cell)
    extra = {tuple(sorted((a, b))) for a in lanes for b in ((a[0] + 1, a[1]), (a[0], a[1] + 1)) if b in lanes
             and draw(st.booleans())}

    def name(cell: tuple[int, int]) -> str:
        return f"n{cell[0]}{cell[1]}"

    nodes = [Node(name(c), c[0] * SPACING, c[1] * SPACING) for c in lanes]
    nodes += [Node("b" + name(c), c[0] * SPACING + 2.0, c[1] * SPACING + 2.0, waiting=True) for c in lanes]
    edges = [Edge(name(a), name(b)) for a, b in sorted(tree | extra)] + [Edge(name(c), "b" + name(c)) for c in lanes]
    roadmap = Roadmap(tuple(nodes), tuple(edges))
    docks = draw(st.lists(st.sampled_from(lanes), min_size=2, max_size=min(4, len(lanes)), unique=True))
    stations = tuple(StationConfig(f"s{k}", (c[0] * SPACING, c[1] * SPACING + 0.5), parts=10, dock_node=name(c),
                                   dock=(c[0] * SPACING, c[1] * SPACING, None)) for k, c in enumerate(docks))
    starts = draw(st.lists(st.sampled_from(nodes), min_size=1, max_size=min(3, len(lanes) - 1), unique=True))
    robots = tuple(RobotConfig(f"r{k}", (n.x, n.y, 0.0), max_velocity=1.0, footprint=((0.5, 0.5), (-0.5, 0.5),
                                                                                      (-0.5, -0.5), (0.5, -0.5)))
                   for k, n in enumerate(starts))
    trips = draw(st.lists(st.tuples(st.integers(0, 30), st.permutations(range(len(docks)))), min_size=1, max_size=5))
    jobs = tuple(Job(float(t), f"j{k}", f"s{p[0]}", f"s{p[1]}") for k, (t, p) in enumerate(sorted(trips)))
    assert validate(roadmap, stations) == []
    return Scenario(Settings(name="lanes", duration=3000.0, until_idle=True,
                             durations={"dummy": 1.0, "load": 1.0, "unload": 1.0}),
                    robots, stations, (), jobs=jobs, roadmap=roadmap)


@given(layouts())
def test_s12_property_no_node_held_twice_no_contact_every_job_completed(scenario: Scenario):
    """Issue 32 item 4, on random small roadmaps (``layouts``) and job lists: no two robots ever hold the
    same node per the Dispatcher's reservations, each drives only what it holds, no two robots touch, and
    every job completes."""
    manager = Watched()
    result = vcran.simulate(scenario, manager=manager)
    assert manager.clashes == []
    assert of(result, "collision") == []
    assert [(r.id, r.outcome) for r in result.jobs if r.outcome != "completed"] == []
