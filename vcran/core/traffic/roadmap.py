"""A roadmap (docs/contract.md §12): the nodes robots stop at and the edges they drive between, and its one check.

A roadmap is plain data. A :class:`Node` has an id and a position; a *waiting* node is a bay off the lanes
where a robot may wait for others to pass (the reservation planner parks robots there:
:mod:`vcran.core.traffic.reservations`). An :class:`Edge` joins two nodes, driven both ways unless
``one_way`` (then from ``start`` to ``end`` only), with an optional speed limit. Station docks are nodes: a
station names its dock node (``dock = "id"`` in a scenario file), or its dock (its position, without one)
lies on a node.

:func:`validate` is every rule a roadmap must satisfy, on the model (issue 30: validity lives with the data,
so a roadmap built in code is checked as one read from a file). It returns each problem as ``(path,
message)``, the path naming the entry and field as a scenario file spells them (``roadmap.edges[2].to``,
``stations[0].dock``; a path ending in ``]`` names a whole entry), so a reader only adds the file's name.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Protocol

#: One problem: where (``roadmap.nodes[3].id``) and what.
Problem = tuple[str, str]
#: How many node ids a message lists before "...".
_LISTED = 8


@dataclass(frozen=True, slots=True)
class Node:
    id: str
    x: float
    y: float
    #: A bay off the lanes where a robot may wait for others to pass (a passing or parking place).
    waiting: bool = False


@dataclass(frozen=True, slots=True)
class Edge:
    """A lane from node ``start`` to node ``end`` (``from`` and ``to`` in a file); both ways unless ``one_way``."""

    start: str
    end: str
    one_way: bool = False
    #: m/s: no robot drives this edge faster (None: no limit but the robot's).
    speed: float | None = None


@dataclass(frozen=True, slots=True)
class Roadmap:
    nodes: tuple[Node, ...]
    edges: tuple[Edge, ...] = ()

    def index(self) -> dict[str, Node]:
        """Node by id (the first of a duplicated id: :func:`validate` refuses those)."""
        out: dict[str, Node] = {}
        for n in self.nodes:
            out.setdefault(n.id, n)
        return out

    def node_at(self, x: float, y: float) -> Node | None:
        """The first node (in file order) exactly at ``(x, y)``, or None."""
        return next((n for n in self.nodes if n.x == x and n.y == y), None)

    def as_dict(self) -> dict[str, Any]:
        """The ``[roadmap]`` table as a scenario file writes it (keys at their defaults left out)."""
        nodes = [{"id": n.id, "x": n.x, "y": n.y, **({"waiting": True} if n.waiting else {})} for n in self.nodes]
        edges = [{"from": e.start, "to": e.end, **({"one_way": True} if e.one_way else {}),
                  **({"speed": e.speed} if e.speed is not None else {})} for e in self.edges]
        return {"nodes": nodes, **({"edges": edges} if edges else {})}

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> Roadmap:
        """:meth:`as_dict`'s form read back, as a run's trace header holds it (``fleet.roadmap``): what reports
        and the view draw. Unchecked (:func:`validate` checked it when the scenario was read); a missing key
        raises KeyError."""
        nodes = tuple(Node(n["id"], float(n["x"]), float(n["y"]), bool(n.get("waiting", False))) for n in data["nodes"])
        edges = tuple(Edge(e["from"], e["to"], bool(e.get("one_way", False)), e.get("speed"))
                      for e in data.get("edges", []))
        return cls(nodes, edges)


class Docked(Protocol):
    """What :func:`validate` reads of a station (:class:`vcran.core.scenario.StationConfig`)."""

    @property
    def id(self) -> str: ...
    @property
    def position(self) -> tuple[float, float]: ...
    @property
    def dock(self) -> tuple[float, float, float | None] | None: ...
    @property
    def dock_node(self) -> str | None: ...


def validate(roadmap: Roadmap | None, stations: Sequence[Docked] = ()) -> list[Problem]:
    """Every problem of ``roadmap`` and of the stations' docks on it, in file order (nodes, edges, stations).

    Nodes: ids unique, positions finite. Edges: both ends known nodes, two different nodes at different
    points (an edge of zero length has no heading to drive), a positive speed limit, no edge given twice
    (a both-ways edge and any other edge between the same nodes, or two one-way edges the same way).
    Stations: a named dock is a node of the roadmap; with a roadmap, every station's dock (its position
    when it has none) is at a node, since robots reach stations along the roadmap.
    """
    problems: list[Problem] = []
    if roadmap is not None:
        problems += _node_problems(roadmap)
        problems += _edge_problems(roadmap)
    problems += _dock_problems(roadmap, stations)
    return problems


def _node_problems(roadmap: Roadmap) -> list[Problem]:
    if not roadmap.nodes:
        return [("roadmap.nodes", "a roadmap needs at least one node")]
    problems = []
    first: dict[str, int] = {}
    for i, n in enumerate(roadmap.nodes):
        where = f"roadmap.nodes[{i}]"
        if not n.id:
            problems.append((f"{where}.id", "expected a non-empty id"))
        elif n.id in first:
            problems.append((f"{where}.id", f"duplicate id {n.id!r} (nodes[{first[n.id]}])"))
        else:
            first[n.id] = i
        for axis, v in (("x", n.x), ("y", n.y)):
            if not math.isfinite(v):
                problems.append((f"{where}.{axis}", f"expected a finite number, got {v!r}"))
    return problems


def _edge_problems(roadmap: Roadmap) -> list[Problem]:
    problems = []
    nodes = roadmap.index()
    seen: dict[tuple[str, str], int] = {}  # (start, end) -> edge index, both directions for a both-ways edge
    for i, e in enumerate(roadmap.edges):
        where = f"roadmap.edges[{i}]"
        known = True
        for key, name in (("from", e.start), ("to", e.end)):
            if name not in nodes:
                problems.append((f"{where}.{key}", f"unknown node {name!r}; nodes: {_listing(nodes)}"))
                known = False
        if e.speed is not None and not (math.isfinite(e.speed) and e.speed > 0):
            problems.append((f"{where}.speed", f"must be a positive number of m/s, got {e.speed!r}"))
        if not known:
            continue
        if e.start == e.end:
            problems.append((f"{where}.to", f"{e.end!r} again: an edge joins two different nodes"))
            continue
        a, b = nodes[e.start], nodes[e.end]
        if a.x == b.x and a.y == b.y:
            problems.append((where, f"zero length: {a.id!r} and {b.id!r} are both at {_show(a.x, a.y)}"))
            continue
        ways = [(e.start, e.end)] if e.one_way else [(e.start, e.end), (e.end, e.start)]
        clash = next((seen[w] for w in ways if w in seen), None)
        if clash is not None:
            problems.append((where, f"joins {e.start!r} and {e.end!r} again (edges[{clash}])"))
            continue
        for w in ways:
            seen[w] = i
    return problems


def _dock_problems(roadmap: Roadmap | None, stations: Sequence[Docked]) -> list[Problem]:
    problems = []
    nodes = roadmap.index() if roadmap is not None else {}
    for k, s in enumerate(stations):
        where = f"stations[{k}]"
        if s.dock_node is not None:
            if roadmap is None:
                problems.append((f"{where}.dock", f"names the roadmap node {s.dock_node!r}, but the scenario has "
                                                  "no [roadmap]"))
            elif s.dock_node not in nodes:
                problems.append((f"{where}.dock", f"unknown node {s.dock_node!r}; nodes: {_listing(nodes)}"))
            continue
        if roadmap is None:
            continue
        if s.dock is not None:
            x, y, key, what = s.dock[0], s.dock[1], "dock", "the dock"
        else:
            (x, y), key, what = s.position, "position", "the station's position (it has no dock)"
        if roadmap.node_at(x, y) is None:
            problems.append((f"{where}.{key}", f"{_show(x, y)} is off the roadmap: no node at {what}; robots "
                                               "reach stations along the roadmap: put a node there, or name "
                                               "one with dock = \"id\""))
    return problems


def _listing(nodes: dict[str, Node]) -> str:
    names = list(nodes)
    shown = ", ".join(names[:_LISTED])
    return (shown + ", ...") if len(names) > _LISTED else (shown or "none")


def _show(x: float, y: float) -> str:
    return f"[{x:g}, {y:g}]"
