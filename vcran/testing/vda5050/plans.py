"""Orders, updates and instant actions built in one call, as a master writes them (docs/contract.md §11).

``order("o1", 0, [("a", 0, 0), ("b", 1, 0), ("c", 2, 0)], base=2)`` is the order of §6.6.2's pseudocode:
nodes at those positions with sequenceIds 0, 2, 4, edges ``a-b`` (1) and ``b-c`` (3) between them, the first
``base`` nodes released (and the edges between them), the rest horizon. An update continues the numbering:
``order("o1", 1, [("b", 1, 0), ("c", 2, 0)], start=2)`` stitches at ``b``. Plain functions, no hypothesis:
usable from a user's master and its tests.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from typing import Any

from vcran.core.vda5050.builder import action
from vcran.core.vda5050.enums import Version
from vcran.core.vda5050.header import Header, timestamp
from vcran.core.vda5050.order import Action, Edge, InstantActions, Node, NodePosition, Order

MANUFACTURER, SERIAL = "acme", "agv1"

Point = tuple[str, float, float]


def header(header_id: int = 0, version: Version = Version.V2_1_0, now: float = 0.0) -> Header:
    return Header(header_id=header_id, timestamp=timestamp(now), version=version.value, manufacturer=MANUFACTURER,
                  serial_number=SERIAL)


def order(order_id: str, update_id: int, points: Iterable[Point], *, base: int | None = None, start: int = 0,
          node_actions: Mapping[str, Iterable[Action]] | None = None,
          edge_actions: Mapping[str, Iterable[Action]] | None = None, max_speed: float | None = None,
          deviation: float | None = None, header_id: int = 0, version: Version = Version.V2_1_0,
          map_id: str = "map", edge_ids: Sequence[str] | None = None) -> Order:
    """An order through ``points`` (see the module docstring). ``node_actions`` and ``edge_actions`` map a
    node id (an edge id) to its actions; a node id that occurs twice gets them at each visit. Edges are
    named ``"a-b"`` unless ``edge_ids`` names them."""
    pts = list(points)
    names = list(edge_ids) if edge_ids is not None else [f"{a[0]}-{b[0]}" for a, b in zip(pts, pts[1:])]
    released = len(pts) if base is None else base
    node_actions = node_actions or {}
    edge_actions = edge_actions or {}
    nodes = tuple(
        Node(node_id=name, sequence_id=start + 2 * i, released=i < released,
             node_position=NodePosition(x=float(x), y=float(y), map_id=map_id, allowed_deviation_xy=deviation),
             actions=tuple(node_actions.get(name, ())))
        for i, (name, x, y) in enumerate(pts))
    edges = tuple(
        Edge(edge_id=names[i], sequence_id=start + 2 * i + 1, released=i + 1 < released,
             start_node_id=a[0], end_node_id=b[0], max_speed=max_speed,
             actions=tuple(edge_actions.get(names[i], ())))
        for i, (a, b) in enumerate(zip(pts, pts[1:])))
    return Order(header=header(header_id, version), order_id=order_id, order_update_id=update_id, nodes=nodes,
                 edges=edges)


def instant(*actions: Action, header_id: int = 0, version: Version = Version.V2_1_0) -> InstantActions:
    return InstantActions(header=header(header_id, version), actions=actions)


def cancel(action_id: str = "cancel", **kwargs: Any) -> InstantActions:
    return instant(action("cancelOrder", action_id, "NONE"), **kwargs)


def pause(action_id: str = "pause") -> InstantActions:
    return instant(action("startPause", action_id, "NONE"))


def resume(action_id: str = "resume") -> InstantActions:
    return instant(action("stopPause", action_id, "NONE"))
