"""docs/contract.md §12 / issue 32 item 4: node reservations for a manager's robots. Hand cases, then the property: on
random small roadmaps with random requests, no node is ever held by two robots, the waits never form a
cycle, some robot can always move while any has a route, and every accepted route is driven to its end."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vcran.core.traffic.paths import Graph
from vcran.core.traffic.reservations import Move, Reservations
from vcran.core.traffic.roadmap import Edge, Node, Roadmap

#: a - b - c - d in a row (10 m apart), bay w off b
ROW = Roadmap(
    (Node("a", 0, 0), Node("b", 10, 0), Node("c", 20, 0), Node("d", 30, 0), Node("w", 10, 5, waiting=True)),
    (Edge("a", "b"), Edge("b", "c"), Edge("c", "d"), Edge("b", "w")),
)


def planner(**robots: str) -> Reservations:
    plan = Reservations(Graph(ROW))
    for name, node in robots.items():
        plan.place(name, node)
    return plan


def test_a_lone_robot_reserves_its_whole_route_and_releases_behind() -> None:
    plan = planner(r1="a")
    plan.request("r1", "d")
    assert plan.step() == [Move("r1", ("b", "c", "d"), "d", "d")]
    assert plan.held("r1") == ("a", "b", "c", "d") and plan.routes() == {"r1": ("b", "c", "d")}
    plan.reached("r1", "b")
    assert plan.held("r1") == ("b", "c", "d") and plan.holder.get("a") is None
    plan.reached("r1", "c")
    plan.reached("r1", "d")
    assert plan.held("r1") == ("d",) and plan.routes() == {} and plan.pending() == []


def test_a_stretch_ends_at_a_waiting_node_on_the_route() -> None:
    # a -> w passes b then stops at the bay w: one stretch b, w
    plan = planner(r1="a")
    plan.request("r1", "w")
    assert plan.step() == [Move("r1", ("b", "w"), "w", "w")]


def test_a_follower_waits_for_the_nodes_ahead_and_gets_them_as_they_are_released() -> None:
    plan = planner(r1="b", r2="a")
    plan.request("r1", "d")
    plan.request("r2", "c")
    assert plan.step() == [Move("r1", ("c", "d"), "d", "d")]
    # r2's route a-b-c: b and c are r1's; it waits for r1, which never waits
    assert plan.waits() == {"r2": frozenset({"r1"})}
    plan.reached("r1", "c")
    assert plan.step() == []  # c is still r1's
    plan.reached("r1", "d")
    assert plan.step() == [Move("r2", ("b", "c"), "c", "c")]


def test_head_on_requests_send_one_robot_to_the_bay() -> None:
    # the corridor's case: r1 at a wants d, r2 at d wants a; a single lane with the bay w off b
    plan = planner(r1="a", r2="d")
    plan.request("r1", "d")
    plan.request("r2", "a")
    # r1 first (asked first): d is where r2 rests, so r1 is sent to the bay; r2's route is then safe but b
    # is r1's until r1 is in the bay
    assert plan.step() == [Move("r1", ("b", "w"), "w", "d")]
    assert plan.waits() == {"r2": frozenset({"r1"})}
    plan.reached("r1", "b")
    assert plan.step() == []
    plan.reached("r1", "w")  # r1 in the bay, still asking for d: accepted, but r2 holds d
    assert plan.step() == [Move("r2", ("c", "b", "a"), "a", "a")]
    assert plan.routes() == {"r1": ("b", "c", "d"), "r2": ("c", "b", "a")}
    for node in ("c", "b", "a"):
        plan.reached("r2", node)
    assert plan.step() == [Move("r1", ("b", "c", "d"), "d", "d")]


def test_a_goal_where_an_idle_robot_rests_stays_pending_from_a_bay() -> None:
    plan = planner(r1="a", r2="d")
    plan.request("r1", "d")  # r2 never leaves d
    assert plan.step() == [Move("r1", ("b", "w"), "w", "d")]
    plan.reached("r1", "b")
    plan.reached("r1", "w")
    assert plan.step() == [] and plan.pending() == ["r1"]  # it waits in the bay; the manager must move r2


def test_placing_a_robot_on_a_route_in_progress_is_refused() -> None:
    # b is a waiting node here: r1's route a -> d is reserved in two stretches, (b) then (c, d)
    roadmap = Roadmap((*ROW.nodes[:1], Node("b", 10, 0, waiting=True), *ROW.nodes[2:4]), ROW.edges[:3])
    plan = Reservations(Graph(roadmap))
    plan.place("r1", "a")
    plan.request("r1", "d")
    assert plan.step() == [Move("r1", ("b",), "d", "d")]
    with pytest.raises(ValueError, match="'b' is held by r1"):
        plan.place("r2", "b")
    with pytest.raises(ValueError, match="'c' is on an accepted route: r2 would block it for good"):
        plan.place("r2", "c")
    assert "r2" not in plan.robots and "c" not in plan.holder  # nothing half-applied
    plan.reached("r1", "b")
    plan.place("r2", "a")  # behind r1, needed by nobody: fine
    assert plan.held("r2") == ("a",)


# --- the property -------------------------------------------------------------------------------------------


@st.composite
def worlds(draw: st.DrawFn) -> tuple[Roadmap, list[str], list[tuple[str, int, int]]]:
    n = draw(st.integers(3, 7))
    cells = draw(st.lists(st.tuples(st.integers(0, 3), st.integers(0, 3)), min_size=n, max_size=n, unique=True))
    waiting = draw(st.lists(st.booleans(), min_size=n, max_size=n))
    nodes = tuple(Node(f"n{k}", 5.0 * x, 5.0 * y, w) for k, ((x, y), w) in enumerate(zip(cells, waiting)))
    pairs = {(draw(st.integers(0, k - 1)), k) for k in range(1, n)}  # a spanning tree: connected
    for a, b in draw(st.lists(st.tuples(st.integers(0, n - 1), st.integers(0, n - 1)), max_size=4)):
        if a != b:
            pairs.add((min(a, b), max(a, b)))
    edges = tuple(Edge(f"n{a}", f"n{b}") for a, b in sorted(pairs))
    robots = draw(st.integers(1, min(3, n - 1)))
    starts = [f"n{k}" for k in draw(st.permutations(range(n)))[:robots]]
    ops = draw(st.lists(st.tuples(st.sampled_from(["request", "reach"]), st.integers(0, robots - 1),
                                  st.integers(0, n - 1)), max_size=40))
    return Roadmap(nodes, edges), starts, ops


def check(plan: Reservations) -> None:
    held = [node for name in plan.robots for node in plan.held(name)]
    assert len(held) == len(set(held)), f"a node held twice: {held}"
    assert all(plan.holder[node] == name for name in plan.robots for node in plan.held(name))
    waits = plan.waits()
    for start in waits:  # no cycle: following waits from any robot never comes back to it
        seen, todo = set(), [start]
        while todo:
            for nxt in waits.get(todo.pop(), ()):
                assert nxt != start, f"a cyclic wait through {start}: {waits}"
                if nxt not in seen:
                    seen.add(nxt)
                    todo.append(nxt)
    on_route = plan.routes()
    if on_route:  # someone can move: a robot with nodes reserved ahead
        assert any(plan.held(name)[1:] for name in on_route), f"nobody moves: {on_route}, waits {waits}"


@pytest.mark.slow
@settings(max_examples=300, deadline=None)
@given(worlds())
def test_no_node_held_twice_no_cyclic_wait_every_route_finishes(world: tuple[Roadmap, list[str], list]) -> None:
    roadmap, starts, ops = world
    plan = Reservations(Graph(roadmap))
    names = [f"r{k}" for k in range(len(starts))]
    for name, node in zip(names, starts):
        plan.place(name, node)
    for op, k, node in ops:
        name = names[k]
        if op == "request" and name not in plan.routes():
            plan.request(name, f"n{node}")
        elif op == "reach" and plan.held(name)[1:]:
            plan.reached(name, plan.held(name)[1])
        plan.step()
        check(plan)
    for _ in range(200):  # drive what is granted until every accepted route has ended
        movers = [name for name in names if plan.held(name)[1:]]
        if not movers:
            break
        for name in movers:
            plan.reached(name, plan.held(name)[1])
        plan.step()
        check(plan)
    assert plan.routes() == {}
