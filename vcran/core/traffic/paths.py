"""Shortest routes on a roadmap (docs/contract.md §12): what the reference managers drive their robots along.

:class:`Graph` is a validated :class:`~vcran.core.traffic.roadmap.Roadmap` made ready for searching: each
node's outgoing arcs (a both-ways edge is two arcs). :meth:`Graph.route` is Dijkstra's search.

Cost. By length (metres) when no speed is given; by time when the robot's top speed is: an arc takes its
length over the robot's speed or the edge's limit, whichever is lower. Time counts neither the ramps nor
the turns (every leg starts and ends at rest, so each node costs the same ramps whichever way a route
goes; turns depend on the route taken, which a node-by-node search cannot charge for).

Ties, documented so that two runs (and two machines) pick the same route: routes are compared by cost
(floats compared exactly, as summed arc by arc from the start), then by the number of arcs, then by their
node ids read as a sequence of strings (lexicographically). This order is consistent with extending a
route by an arc (a prefix that wins keeps winning), so Dijkstra's search with it as the key finds the
least route in it.
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Collection
from dataclasses import dataclass

from vcran.core.traffic.roadmap import Node, Roadmap


@dataclass(frozen=True, slots=True)
class Arc:
    """One direction of an edge: to ``target``, ``length`` metres, at most ``speed`` m/s (None: no limit)."""

    target: str
    length: float
    speed: float | None


@dataclass(frozen=True, slots=True)
class Route:
    """Node ids from start to goal (both included), the route's cost (m or s) and its length (m)."""

    nodes: tuple[str, ...]
    cost: float
    length: float


class Graph:
    """A roadmap's arcs by node, each node's in target-id order. Build it from a roadmap that
    :func:`~vcran.core.traffic.roadmap.validate` accepts."""

    def __init__(self, roadmap: Roadmap) -> None:
        self.roadmap = roadmap
        self.nodes: dict[str, Node] = roadmap.index()
        arcs: dict[str, list[Arc]] = {n: [] for n in self.nodes}
        for e in roadmap.edges:
            a, b = self.nodes[e.start], self.nodes[e.end]
            length = math.hypot(b.x - a.x, b.y - a.y)
            arcs[e.start].append(Arc(e.end, length, e.speed))
            if not e.one_way:
                arcs[e.end].append(Arc(e.start, length, e.speed))
        self.arcs = {n: sorted(out, key=lambda arc: arc.target) for n, out in arcs.items()}

    def distance(self, a: str, b: str) -> float:
        """Straight-line distance between two nodes (m)."""
        na, nb = self.nodes[a], self.nodes[b]
        return math.hypot(nb.x - na.x, nb.y - na.y)

    def route(self, start: str, goal: str, *, speed: float | None = None,
              avoid: Collection[str] = ()) -> Route | None:
        """The least route from ``start`` to ``goal`` (module docstring: cost and ties), entering no node
        of ``avoid`` (``start`` may be in it: the robot is already there), or None if there is none.

        ``speed``: the robot's top speed (m/s) to search by time; None searches by length.
        """
        for name in (start, goal):
            if name not in self.nodes:
                raise KeyError(f"no node {name!r} in the roadmap")
        if speed is not None and not speed > 0:
            raise ValueError(f"a route's speed must be positive, got {speed!r}")
        # (cost, arcs, node ids so far, length): the key is the first three, in that order
        heap: list[tuple[float, int, tuple[str, ...], float]] = [(0.0, 0, (start,), 0.0)]
        settled: set[str] = set()
        while heap:
            cost, hops, nodes, length = heapq.heappop(heap)
            here = nodes[-1]
            if here in settled:
                continue
            if here == goal:
                return Route(nodes, cost, length)
            settled.add(here)
            for arc in self.arcs[here]:
                if arc.target in settled or arc.target in avoid:
                    continue
                if speed is None:
                    step = arc.length
                else:
                    step = arc.length / (speed if arc.speed is None else min(speed, arc.speed))
                heapq.heappush(heap, (cost + step, hops + 1, (*nodes, arc.target), length + arc.length))
        return None
