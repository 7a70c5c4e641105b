"""scenarios/warehouse-traffic.toml (docs/contract.md §12, issue 32 items 4 and 5): the warehouse on
a roadmap with safety fields on, where the reference Dispatcher routes and reserves so that every job
completes with no contact between robots and no deadlock; driving straight, as in the warehouse, its robots
brake for one another and deadlock, and without fields they run through one another."""

from __future__ import annotations

import itertools
import math
from dataclasses import replace

import pytest

import vcran
from tests.conftest import ROOT
from vcran.core.traffic.paths import Graph
from vcran.core.traffic.roadmap import validate
from vcran.managers import Dispatcher
from vcran.testing.deadlocks import check_no_deadlock
from vcran.testing.loop import loop_problems

SCENARIO = vcran.load_scenario(ROOT / "scenarios" / "warehouse-traffic.toml")
WAREHOUSE = vcran.load_scenario("warehouse")


@pytest.fixture(scope="module")
def run() -> vcran.Result:
    return vcran.simulate(SCENARIO)


def collisions(result: vcran.Result) -> int:
    return sum(e["event"] == "collision" for e in result.events)


def test_it_is_the_warehouse_s_fleet_and_stations_on_a_roadmap_robots_parked_in_bays():
    assert SCENARIO.roadmap is not None and validate(SCENARIO.roadmap, SCENARIO.stations) == []
    assert SCENARIO.stations == WAREHOUSE.stations
    assert [replace(r, pose=(0.0, 0.0, 0.0)) for r in SCENARIO.robots] == [
        replace(r, pose=(0.0, 0.0, 0.0)) for r in WAREHOUSE.robots]
    waiting = {n.id for n in SCENARIO.roadmap.nodes if n.waiting}
    assert {SCENARIO.roadmap.node_at(*r.pose[:2]).id for r in SCENARIO.robots} <= waiting
    # the warehouse's stream of jobs at a quarter of its rate: one a minute (the scenario's comment says why)
    assert SCENARIO.job_stream == replace(WAREHOUSE.job_stream, rate=WAREHOUSE.job_stream.rate / 4)


def test_the_roadmap_keeps_robots_on_distinct_nodes_and_edges_apart():
    """Robots on distinct nodes and edges never touch (reservations keep them on distinct ones) when every
    node is farther than twice the footprint's reach (0.94 m from its origin: the corner (-0.87, 0.35)) from
    every node and every edge it is not an end of, and edges that share no node are as far apart."""
    reach = max(math.hypot(x, y) for x, y in SCENARIO.robots[0].footprint)
    graph = Graph(SCENARIO.roadmap)
    nodes = graph.nodes
    edges = [(e.start, e.end) for e in SCENARIO.roadmap.edges]

    def to_segment(p: tuple[float, float], a: str, b: str) -> float:
        (ax, ay), (bx, by) = (nodes[a].x, nodes[a].y), (nodes[b].x, nodes[b].y)
        k = max(0.0, min(1.0, ((p[0] - ax) * (bx - ax) + (p[1] - ay) * (by - ay)) / ((bx - ax) ** 2 + (by - ay) ** 2)))
        return math.hypot(p[0] - ax - k * (bx - ax), p[1] - ay - k * (by - ay))

    for n in nodes.values():
        for a, b in edges:
            if n.id not in (a, b):
                assert to_segment((n.x, n.y), a, b) >= 2 * reach, (n.id, a, b)
    for (a, b), (c, d) in itertools.combinations(edges, 2):
        if not {a, b} & {c, d}:  # segments that do not cross: their distance is at an end point
            gap = min(to_segment((nodes[c].x, nodes[c].y), a, b), to_segment((nodes[d].x, nodes[d].y), a, b),
                      to_segment((nodes[a].x, nodes[a].y), c, d), to_segment((nodes[b].x, nodes[b].y), c, d))
            assert gap >= 2 * reach, (a, b, c, d)


def test_s12_every_job_completes_and_no_robot_touches_another(run):
    jobs = run.summary["jobs"]
    assert jobs["arrived"] == sum(1 for _ in SCENARIO.job_stream.jobs()) and jobs["completed"] == jobs["arrived"]
    assert collisions(run) == 0
    assert run.summary["sim_time"] < SCENARIO.settings.duration  # all done before the hour is out
    # the loop properties, "no deadlock" among them (a roadmap); a robot waits for a lane or a station
    # before its task goes out, so the idle bound must cover traffic (docs/fuzzing.md): five minutes
    assert loop_problems(run, bound=300.0) == []
    assert check_no_deadlock(run) == []
    # safety fields on (docs/contract.md §12): the reservations keep every robot out of the others' fields
    assert SCENARIO.traffic.any_field(SCENARIO.robots)
    assert run.summary["traffic"] == {"blocks": 0, "blocked_time": 0.0, "deadlocks": 0}


def test_s12_straight_routing_with_fields_deadlocks():
    """Straight lines through shared lanes: robots brake for one another and some end up stopped on one
    another for good; their jobs stay open (no collision: the fields stop them first)."""
    straight = vcran.simulate(SCENARIO, manager=Dispatcher(max_tries=3, routing="straight"))
    assert straight.summary["traffic"]["deadlocks"] > 0 and check_no_deadlock(straight) != []
    assert straight.summary["jobs"]["completed"] < straight.summary["jobs"]["arrived"]
    assert collisions(straight) == 0


def test_s12_straight_routing_without_fields_runs_robots_through_one_another():
    off = replace(SCENARIO, traffic=replace(SCENARIO.traffic, field=None, deadlock_bound=None))
    straight = vcran.simulate(off, manager=Dispatcher(max_tries=3, routing="straight"))
    assert straight.summary["jobs"]["completed"] == straight.summary["jobs"]["arrived"]
    assert collisions(straight) > 0
