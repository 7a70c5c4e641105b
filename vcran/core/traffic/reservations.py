"""Node reservations for one fleet manager's robots on a roadmap (docs/contract.md §12): they neither meet nor deadlock.

Any manager can use it (OPIL's Dispatcher sends each granted stretch as a path of motion assignments; a
VDA 5050 master as an order's base, the rest of the route as its horizon). Robots and nodes are ids.

The scheme. A robot holds the node it is at and the nodes reserved ahead of it; no node is ever held by
two robots. A robot asks to go to a goal (:meth:`Reservations.request`); :meth:`Reservations.step` then
accepts a route for it and reserves it stretch by stretch: each stretch runs from the next node up to and
including the next *stop node* (a waiting node, or the route's end), all of it or nothing, so a robot
only ever waits at a stop node or where it started. Nodes are released behind the robot as it reaches the
next one (:meth:`Reservations.reached`). A robot at the end of its route rests there, holding that node.

Why nobody deadlocks (a banker's argument). Call the reservations *safe* when the robots with routes can
finish one after the other: some robot's remaining route is free of every node held by the others and of
every node where a robot rests for good (idle robots, and robots already finished in this order), and its
goal is on no other unfinished route (else it would block that route for good once it arrives); it
finishes, releasing all it holds but its goal, and so on. Routes are accepted, and stretches reserved,
only when the reservations stay safe afterwards; reaching a node only releases one. So they are always
safe, and then:

- the first robot of a finishing order can always have its next stretch (its remaining route is free, and
  reserving some of it keeps that order valid), so some robot always moves on: no deadlock;
- robots waiting for a stretch wait for the robots holding its nodes, and these never form a cycle (the
  first robot of the cycle in a finishing order would need a node held by a later one);
- every accepted route is driven to its end, provided the robots drive what they are granted.

Finding a finishing order greedily is enough: finishing a robot that may finish never takes away what
another needs (only its goal stays held, and no unfinished route needs it), so a greedy order finds one
whenever one exists.

Detours. A route that would make the reservations unsafe (two robots sent head-on along a one-lane aisle,
each to where the other stands) is not accepted; the robot is sent instead to the nearest free waiting
node (:attr:`vcran.core.traffic.roadmap.Node.waiting`) whose route is safe, and asks again from there (a
robot at a waiting node waits there). A request that neither can serve stays pending, and is tried again
at the next :meth:`Reservations.step`: e.g. a goal where an idle robot rests (the manager must move it), or
a swap of two robots on a roadmap without a free waiting node.

Geometry is the roadmap's part: robots on distinct nodes and edges must not touch (nodes at least a
footprint apart, edges meeting only at nodes); then distinct reservations mean no contact.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field

from vcran.core.traffic.paths import Graph


@dataclass(frozen=True, slots=True)
class Move:
    """Drive ``robot`` through ``nodes`` (reserved, in order, the next node first). Its route ends at
    ``goal``; ``final`` is the goal it asked for (they differ on a detour to a waiting node)."""

    robot: str
    nodes: tuple[str, ...]
    goal: str
    final: str


@dataclass(slots=True)
class _Robot:
    at: str  # the node it is at (held)
    ahead: list[str] = field(default_factory=list)  # nodes reserved ahead (held), in order
    route: list[str] | None = None  # the accepted route's nodes not yet reserved; None: no route
    goal: str | None = None  # where the accepted route ends
    final: str | None = None  # the goal asked for, until reached
    asked: int = 0  # request order


#: A robot as the safety check sees it: nodes held, nodes still needed, goal.
_Plan = tuple[frozenset[str], tuple[str, ...], str]


class Reservations:
    """Reservations of one manager's robots on ``graph``'s roadmap (module docstring).

    ``speed``: the robots' top speed (m/s) to route by time under speed limits; None routes by length.
    """

    def __init__(self, graph: Graph, speed: float | None = None) -> None:
        self.graph, self.speed = graph, speed
        self.robots: dict[str, _Robot] = {}
        self.holder: dict[str, str] = {}  # node -> robot
        self._order = itertools.count(1)

    # --- inputs -----------------------------------------------------------------------------------------

    def place(self, robot: str, node: str) -> None:
        """``robot`` rests at ``node`` (where it starts, or was brought outside the plan), holding it.

        Refused (ValueError, nothing changed) for a robot on a route, at a node another robot holds, or at a
        node that an accepted route still needs (that route could never finish)."""
        if node not in self.graph.nodes:
            raise KeyError(f"no node {node!r} in the roadmap")
        r = self.robots.get(robot)
        if r is not None and (r.ahead or r.route is not None):
            raise ValueError(f"{robot} is on a route: it cannot be placed")
        if self.holder.get(node, robot) != robot:
            raise ValueError(f"{node!r} is held by {self.holder[node]}")
        placed = _Robot(node, final=None if r is None else r.final, asked=0 if r is None else r.asked)
        self.robots[robot] = placed
        if not self._safe({}):
            if r is None:
                del self.robots[robot]
            else:
                self.robots[robot] = r
            raise ValueError(f"{node!r} is on an accepted route: {robot} would block it for good")
        if r is not None:
            del self.holder[r.at]
        self.holder[node] = robot

    def request(self, robot: str, goal: str) -> None:
        """``robot`` (resting, no route) is to go to ``goal``; served by the next :meth:`step`."""
        r = self.robots[robot]
        if goal not in self.graph.nodes:
            raise KeyError(f"no node {goal!r} in the roadmap")
        if r.route is not None:
            raise ValueError(f"{robot} is on a route to {r.goal}: ask again when it has arrived")
        r.final, r.asked = goal, next(self._order)

    def reached(self, robot: str, node: str) -> None:
        """``robot`` is at ``node``, the next of its reserved nodes: the node behind it is released."""
        r = self.robots[robot]
        if not r.ahead or r.ahead[0] != node:
            raise ValueError(f"{robot} has not reserved {node!r} next (ahead: {r.ahead})")
        del self.holder[r.at]
        r.at = r.ahead.pop(0)
        if not r.ahead and not r.route:  # the route's end
            if r.goal == r.final:
                r.final = None
            r.route = r.goal = None

    def step(self) -> list[Move]:
        """Accept the routes and reserve the stretches that can be now, robots in request order (then by
        id), until nothing changes; the stretches to drive, in that order."""
        moves: list[Move] = []
        changed = True
        while changed:
            changed = False
            for name in sorted(self.robots, key=lambda n: (self.robots[n].asked or 1 << 62, n)):
                r = self.robots[name]
                if r.route is None and r.final is not None and self._accept(name, r):
                    changed = True
                if r.route and not r.ahead:
                    stretch = self._reserve(name, r)
                    if stretch:
                        assert r.goal is not None and r.final is not None
                        moves.append(Move(name, stretch, r.goal, r.final))
                        changed = True
        return moves

    # --- read-only --------------------------------------------------------------------------------------

    def held(self, robot: str) -> tuple[str, ...]:
        r = self.robots[robot]
        return (r.at, *r.ahead)

    def routes(self) -> dict[str, tuple[str, ...]]:
        """Robot -> the nodes ahead of it to its route's end, reserved first (robots on a route only): a
        VDA 5050 order's base (reserved) and horizon (the rest)."""
        return {n: (*r.ahead, *r.route) for n, r in self.robots.items() if r.route is not None}

    def pending(self) -> list[str]:
        """Robots whose request has no route yet, in request order."""
        return [n for n, r in sorted(self.robots.items(), key=lambda kv: kv[1].asked) if r.final and r.route is None]

    def waits(self) -> dict[str, frozenset[str]]:
        """Robot -> the robots holding nodes of the stretch it waits to reserve (robots with a route only)."""
        out = {}
        for name, r in self.robots.items():
            if r.route and not r.ahead:
                holders = {self.holder[n] for n in self._stretch(r) if self.holder.get(n, name) != name}
                if holders:
                    out[name] = frozenset(holders)
        return out

    # --- the rules ----------------------------------------------------------------------------------------

    def _accept(self, name: str, r: _Robot) -> bool:
        """A route to ``r.final`` if safe, else a detour to a waiting node if safe (module docstring)."""
        assert r.final is not None
        if r.final == r.at:
            r.final = None
            return True
        resting = {o.at for n, o in self.robots.items() if n != name and o.route is None}
        direct = self.graph.route(r.at, r.final, speed=self.speed, avoid=resting)
        if direct is not None and self._safe({name: (frozenset((r.at,)), direct.nodes[1:], r.final)}):
            r.route, r.goal = list(direct.nodes[1:]), r.final
            return True
        if self.graph.nodes[r.at].waiting:
            return False  # it waits where it is
        goals = {o.goal for o in self.robots.values() if o.goal is not None}
        detours = []
        for node in self.graph.nodes.values():
            if node.waiting and node.id not in self.holder and node.id not in goals:
                route = self.graph.route(r.at, node.id, speed=self.speed, avoid=resting)
                if route is not None:
                    detours.append((route.cost, node.id, route.nodes))
        for _, w, nodes in sorted(detours):
            if self._safe({name: (frozenset((r.at,)), nodes[1:], w)}):
                r.route, r.goal = list(nodes[1:]), w
                return True
        return False

    def _stretch(self, r: _Robot) -> list[str]:
        """The route's next nodes up to and including the next stop node (a waiting node or the end)."""
        assert r.route
        for k, node in enumerate(r.route):
            if self.graph.nodes[node].waiting:
                return r.route[: k + 1]
        return list(r.route)

    def _reserve(self, name: str, r: _Robot) -> tuple[str, ...]:
        assert r.route is not None and r.goal is not None
        stretch = self._stretch(r)
        if any(self.holder.get(n, name) != name for n in stretch):
            return ()
        if not self._safe({name: (frozenset((r.at, *stretch)), tuple(r.route[len(stretch):]), r.goal)}):
            return ()
        r.ahead = list(stretch)
        del r.route[: len(stretch)]
        for n in stretch:
            self.holder[n] = name
        return tuple(stretch)

    def _safe(self, changed: dict[str, _Plan]) -> bool:
        """Whether the robots with routes (with ``changed`` instead of their present plans) can finish one
        after the other (module docstring)."""
        plans: dict[str, _Plan] = {}
        blocked: set[str] = set()  # nodes where a robot rests for good
        for name, r in self.robots.items():
            if name in changed:
                plans[name] = changed[name]
            elif r.route is not None:
                assert r.goal is not None
                plans[name] = (frozenset((r.at, *r.ahead)), tuple(r.route), r.goal)
            else:
                blocked.add(r.at)
        left = sorted(plans)
        while left:
            for name in left:
                _, need, goal = plans[name]
                others = [plans[o] for o in left if o != name]
                if any(n in blocked or any(n in held for held, _, _ in others) for n in need):
                    continue
                if any(goal in rest for _, rest, _ in others):
                    continue
                left.remove(name)
                blocked.add(goal)
                break
            else:
                return False
        return True
