"""docs/contract.md §12 roadmaps: the model's one check (validate) and shortest routes with their documented ties."""

from __future__ import annotations

import math
from dataclasses import dataclass

import pytest

from vcran.core.traffic.paths import Graph
from vcran.core.traffic.roadmap import Edge, Node, Roadmap, validate


@dataclass(frozen=True)
class Station:
    id: str
    position: tuple[float, float]
    dock: tuple[float, float, float | None] | None = None
    dock_node: str | None = None


SQUARE = Roadmap(
    nodes=(Node("a", 0, 0), Node("b", 10, 0), Node("c", 10, 10), Node("d", 0, 10, waiting=True)),
    edges=(Edge("a", "b"), Edge("b", "c"), Edge("c", "d"), Edge("d", "a")),
)


def test_a_sound_roadmap_has_no_problem() -> None:
    stations = [Station("s1", (10, 0)), Station("s2", (3, 3), dock=(0, 10, None)), Station("s3", (9, 9), dock_node="c")]
    assert validate(SQUARE, stations) == []
    assert validate(None, [Station("s", (1, 2))]) == []  # no roadmap: docks are anywhere


@pytest.mark.parametrize(
    ("roadmap", "expected"),
    [
        (Roadmap(()), [("roadmap.nodes", "a roadmap needs at least one node")]),
        (Roadmap((Node("a", 0, 0), Node("a", 1, 0))), [("roadmap.nodes[1].id", "duplicate id 'a' (nodes[0])")]),
        (Roadmap((Node("a", 0, math.inf),)), [("roadmap.nodes[0].y", "expected a finite number, got inf")]),
        (Roadmap((Node("a", 0, 0), Node("b", 1, 0)), (Edge("a", "q"),)),
         [("roadmap.edges[0].to", "unknown node 'q'; nodes: a, b")]),
        (Roadmap((Node("a", 0, 0),), (Edge("a", "a"),)),
         [("roadmap.edges[0].to", "'a' again: an edge joins two different nodes")]),
        (Roadmap((Node("a", 0, 0), Node("b", 0, 0)), (Edge("a", "b"),)),
         [("roadmap.edges[0]", "zero length: 'a' and 'b' are both at [0, 0]")]),
        (Roadmap((Node("a", 0, 0), Node("b", 1, 0)), (Edge("a", "b", speed=0.0),)),
         [("roadmap.edges[0].speed", "must be a positive number of m/s, got 0.0")]),
        # a both-ways edge covers b -> a: a one-way edge b -> a beside it is given twice
        (Roadmap((Node("a", 0, 0), Node("b", 1, 0)), (Edge("a", "b"), Edge("b", "a", one_way=True))),
         [("roadmap.edges[1]", "joins 'b' and 'a' again (edges[0])")]),
    ],
    ids=["empty", "duplicate-id", "infinite", "unknown-node", "loop", "zero-length", "speed", "twice"],
)
def test_each_problem_names_its_entry_and_field(roadmap: Roadmap, expected: list[tuple[str, str]]) -> None:
    """docs/contract.md §12 / issue 32 item 1: one line naming the entry."""
    assert validate(roadmap) == expected


def test_two_one_way_edges_against_each_other_are_two_lanes() -> None:
    roadmap = Roadmap((Node("a", 0, 0), Node("b", 1, 0)), (Edge("a", "b", one_way=True), Edge("b", "a", one_way=True)))
    assert validate(roadmap) == []


def test_docks_off_the_roadmap_are_refused() -> None:
    stations = [
        Station("p", (5, 5)),  # no dock: its position is the dock, and no node is there
        Station("q", (0, 0), dock=(0.5, 0, None)),
        Station("r", (0, 0), dock_node="zz"),
    ]
    assert [path for path, _ in validate(SQUARE, stations)] == ["stations[0].position", "stations[1].dock",
                                                                 "stations[2].dock"]
    assert validate(SQUARE, stations)[0][1].startswith("[5, 5] is off the roadmap: no node at the station's position")
    assert validate(None, [Station("r", (0, 0), dock_node="a")]) == [
        ("stations[0].dock", "names the roadmap node 'a', but the scenario has no [roadmap]")]


def test_roadmap_as_dict_leaves_defaults_out() -> None:
    roadmap = Roadmap((Node("a", 0, 0), Node("b", 1, 0, waiting=True)), (Edge("a", "b", one_way=True, speed=0.5),))
    assert roadmap.as_dict() == {
        "nodes": [{"id": "a", "x": 0, "y": 0}, {"id": "b", "x": 1, "y": 0, "waiting": True}],
        "edges": [{"from": "a", "to": "b", "one_way": True, "speed": 0.5}],
    }


# --- routes ------------------------------------------------------------------------------------------------


def test_route_by_length_takes_the_shorter_way_round() -> None:
    # a -> c round the square: a-b-c and a-d-c are both 20 m and 2 arcs; ids decide: (a, b, c) < (a, d, c)
    route = Graph(SQUARE).route("a", "c")
    assert route is not None and route.nodes == ("a", "b", "c") and route.cost == 20.0 and route.length == 20.0
    # avoiding b leaves a-d-c
    route = Graph(SQUARE).route("a", "c", avoid={"b"})
    assert route is not None and route.nodes == ("a", "d", "c")
    assert Graph(SQUARE).route("a", "c", avoid={"b", "d"}) is None
    assert Graph(SQUARE).route("a", "a").nodes == ("a",)  # type: ignore[union-attr]


def test_route_by_time_obeys_speed_limits() -> None:
    # a-b limited to 0.25 m/s: a -> b direct takes 10 / 0.25 = 40 s at a robot speed of 1 m/s, round the
    # other three sides 30 s; by length the direct edge (10 m) wins
    roadmap = Roadmap(SQUARE.nodes, (Edge("a", "b", speed=0.25), *SQUARE.edges[1:]))
    graph = Graph(roadmap)
    assert graph.route("a", "b").nodes == ("a", "b")  # type: ignore[union-attr]
    by_time = graph.route("a", "b", speed=1.0)
    assert by_time is not None and by_time.nodes == ("a", "d", "c", "b") and by_time.cost == 30.0
    assert by_time.length == 30.0
    # a robot slower than the limit is not slowed further: at 0.2 m/s direct is 50 s, round 150 s
    assert graph.route("a", "b", speed=0.2).nodes == ("a", "b")  # type: ignore[union-attr]


def test_one_way_edges_are_driven_one_way() -> None:
    roadmap = Roadmap(SQUARE.nodes, (Edge("a", "b", one_way=True), *SQUARE.edges[1:]))
    assert Graph(roadmap).route("b", "a").nodes == ("b", "c", "d", "a")  # type: ignore[union-attr]


def test_ties_prefer_fewer_arcs_then_smaller_ids() -> None:
    # x -> y: direct 2 m (one arc) against x-m-y, 1 m + 1 m (two arcs): equal cost, fewer arcs wins
    roadmap = Roadmap((Node("x", 0, 0), Node("m", 1, 0), Node("y", 2, 0)),
                      (Edge("x", "y"), Edge("x", "m"), Edge("m", "y")))
    assert Graph(roadmap).route("x", "y").nodes == ("x", "y")  # type: ignore[union-attr]
    # and the order the edges are listed in does not matter
    flipped = Roadmap(roadmap.nodes, tuple(reversed(roadmap.edges)))
    assert Graph(flipped).route("x", "y").nodes == ("x", "y")  # type: ignore[union-attr]


def test_unknown_nodes_are_key_errors() -> None:
    with pytest.raises(KeyError, match="no node 'q'"):
        Graph(SQUARE).route("a", "q")
