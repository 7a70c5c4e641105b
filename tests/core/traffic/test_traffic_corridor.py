"""The ``corridor`` of docs/robots.md ("Traffic"), derived there by hand, reproduced by the pure core:
straight routing deadlocks at t = 11; the reference reservations send robot A to the passing bay P, where
it waits for B, and both finish (B at W at t = 40, A at E at t = 56), with no block.

The roadmap: W (0, 0) - M (10, 0) - E (20, 0) one lane, P (10, 2) a waiting node off M. Robots: 1 m x 1 m
squares, 1 m/s, 0.5 m/s^2 ramps, turns at once; fields 2 m plus the braking distance (3 m at 1 m/s).
Every leg runs from rest to rest: 10 m takes 2 + 8 + 2 = 12 s, 2 m takes 2 + 0 + 2 = 4 s (it just reaches
1 m/s), 20 m takes 22 s.
"""

from __future__ import annotations

import math

from tests.core.traffic.body import Body
from vcran.core.collisions import Footprint
from vcran.core.motion import Leg, Limits
from vcran.core.traffic.control import Traffic
from vcran.core.traffic.deadlock import CYCLE
from vcran.core.traffic.fields import Field, FieldSpec
from vcran.core.traffic.paths import Graph
from vcran.core.traffic.reservations import Move, Reservations
from vcran.core.traffic.roadmap import Edge, Node, Roadmap, validate

SQUARE = ((0.5, 0.5), (-0.5, 0.5), (-0.5, -0.5), (0.5, -0.5))
LIMITS = Limits(1.0, 0.5, 0.5)
FIELD = Field.of(FieldSpec(margin=2.0), SQUARE, 0.5)
CORRIDOR = Roadmap(
    (Node("W", 0.0, 0.0), Node("M", 10.0, 0.0), Node("E", 20.0, 0.0), Node("P", 10.0, 2.0, waiting=True)),
    (Edge("W", "M"), Edge("M", "E"), Edge("M", "P")),
)
START = {"A": (0.0, 0.0, 0.0), "B": (20.0, 0.0, math.pi)}


def fleet() -> tuple[Body, Traffic]:
    traffic = Traffic([Footprint(SQUARE)] * 2, list(START.values()), [FIELD, FIELD], [0.5, 0.5], 0.05, bound=120.0)
    return Body(traffic), traffic


def test_the_corridor_roadmap_is_valid() -> None:
    assert validate(CORRIDOR) == []


def test_straight_routing_deadlocks_at_11() -> None:
    """Both sent straight through the aisle at t = 0: blocked at 9 (fields 3 m: robots at 8 and 12), both
    stopped at 11 (1 m on: at 9 and 11, 1 m apart), each in the other's waiting field: deadlock at 11."""
    body, _ = fleet()
    body.send(0, Leg(0.0, *START["A"], 20.0, 0.0, None, LIMITS))
    body.send(1, Leg(0.0, *START["B"], 0.0, 0.0, None, LIMITS))
    log = body.run(300.0)
    assert [(round(t, 6), what, robot) for t, what, robot, _ in log if what in ("blocked", "brake")] == [
        (9.0, "blocked", 0), (9.0, "brake", 0), (9.0, "blocked", 1), (9.0, "brake", 1)]
    [deadlock] = [d for _, what, _, d in log if what == "deadlock"]
    assert (deadlock.kind, deadlock.robots, round(deadlock.t, 6)) == (CYCLE, (0, 1), 11.0)


def test_the_reservations_send_a_to_the_bay_and_both_finish() -> None:
    """The timeline of docs/robots.md: A is sent to the bay P (its direct route would be unsafe: B stands
    at E and asks for W), B waits at E until A has left M (t = 16), drives E -> M -> W (t = 28, 40); A
    waits at P until B has left M (t = 40), then drives P -> M -> E (t = 44, 56)."""
    graph = Graph(CORRIDOR)
    plan = Reservations(graph)
    names = ["A", "B"]
    for name, node in (("A", "W"), ("B", "E")):
        plan.place(name, node)
    body, traffic = fleet()
    pose = dict(enumerate(START.values()))
    queue: dict[int, list[str]] = {0: [], 1: []}
    moves: list[tuple[float, Move]] = []
    reached: list[tuple[float, str, str]] = []

    def drive(i: int, now: float) -> None:
        node = graph.nodes[queue[i][0]]
        leg = Leg(now, *pose[i], node.x, node.y, None, LIMITS)
        body.send(i, leg)
        pose[i] = (node.x, node.y, leg.end_theta)

    def serve(now: float) -> None:
        for move in plan.step():
            moves.append((now, move))
            i = names.index(move.robot)
            queue[i] = list(move.nodes)
            drive(i, now)

    def arrived(i: int, now: float) -> None:
        node = queue[i].pop(0)
        reached.append((round(now, 6), names[i], node))
        plan.reached(names[i], node)
        if queue[i]:
            drive(i, now)
        serve(now)

    body.arrived = arrived
    plan.request("A", "E")
    plan.request("B", "W")
    serve(0.0)
    log = body.run(300.0)
    assert [(t, m.robot, m.nodes, m.goal, m.final) for t, m in moves] == [
        (0.0, "A", ("M", "P"), "P", "E"),
        (16.0, "B", ("M", "W"), "W", "W"),
        (40.0, "A", ("M", "E"), "E", "E"),
    ]
    assert reached == [(12.0, "A", "M"), (16.0, "A", "P"), (28.0, "B", "M"), (40.0, "B", "W"), (44.0, "A", "M"),
                       (56.0, "A", "E")]
    assert [what for _, what, _, _ in log if what in ("blocked", "deadlock")] == []  # fields never met
    assert not traffic.blocked(0) and not traffic.blocked(1) and plan.pending() == []
