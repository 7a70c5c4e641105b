"""The part of an order a vehicle still has to travel: the nodes it has not traversed and the edges it has
not left, base then horizon (§6.10.1: "The nodeStates and edgeStates includes all nodes/edges, that the
AGV still shall traverse"). ``edges[i]`` leads to ``nodes[i]``: the edge behind the last traversed node
stays until the next node is traversed (§6.10.2).

Order updates are stitched here (§6.6.2): the horizon goes, the update's nodes after its first (the
stitching node, which the vehicle already holds) and all its edges are appended. Sequence ids are unique
within an order, so a node or edge is found by its ``sequenceId``.
"""

from __future__ import annotations

from vcran.core.vda5050.enums import BlockingType
from vcran.core.vda5050.order import Action, Edge, Node, Order


def blocking(actions: tuple[Action, ...]) -> bool:
    """Whether these actions stop the vehicle (a SOFT or HARD one among them, §6.12)."""
    for a in actions:  # a loop, not any() over a generator: asked for every node and edge at every step
        if a.blocking_type is not _NONE:
            return True
    return False


_NONE = BlockingType.NONE


class Path:
    def __init__(self) -> None:
        self.nodes: list[Node] = []
        self.edges: list[Edge] = []
        #: Bumped at every change (the state message's nodeStates and edgeStates are built again then).
        self.version = 0
        #: (version, :meth:`short_of_base` then): asked before and after every input of the vehicle.
        self._short = (0, False)

    def load(self, order: Order) -> None:
        """A new order whose first node the vehicle has just traversed (it stands on it)."""
        self.nodes = list(order.nodes[1:])
        self.edges = list(order.edges)
        self.version += 1

    def stitch(self, order: Order) -> set[int]:
        """An accepted update: drop the horizon, append the update's nodes (but its first) and edges.
        Returns the sequence ids of the horizon nodes and edges dropped."""
        dropped = {n.sequence_id for n in self.nodes if not n.released}
        dropped |= {e.sequence_id for e in self.edges if not e.released}
        self.nodes = [n for n in self.nodes if n.released] + list(order.nodes[1:])
        self.edges = [e for e in self.edges if e.released] + list(order.edges)
        self.version += 1
        return dropped

    def traverse(self, sequence_id: int) -> tuple[Edge | None, Node]:
        """The vehicle traversed the next node (``sequence_id``): it and the edge leading to it go."""
        node = self.nodes.pop(0)
        assert node.sequence_id == sequence_id, (node.sequence_id, sequence_id)
        edge = self.edges.pop(0) if self.edges and self.edges[0].sequence_id == sequence_id - 1 else None
        self.version += 1
        return edge, node

    def keep_next_node(self) -> None:
        """cancelOrder while driving to the next node: "The nodeState for the node the AGV is driving to
        is kept. All other nodeStates and edgeStates are deleted" (Figure 9)."""
        self.nodes, self.edges = self.nodes[:1], []
        self.version += 1

    def clear(self) -> None:
        if self.nodes or self.edges:
            self.nodes, self.edges = [], []
            self.version += 1

    def horizon(self) -> bool:
        return any(not n.released for n in self.nodes)

    def released_edges(self) -> int:
        return sum(1 for e in self.edges if e.released)

    def short_of_base(self) -> bool:
        """§6.10.3's ``newBaseRequest`` of an active order: a horizon, and at most one released edge left to
        drive. Worked out once per :attr:`version` (every change of the nodes and edges bumps it)."""
        short = self._short
        if short[0] != self.version:
            short = self._short = (self.version, self.horizon() and self.released_edges() <= 1)
        return short[1]

    def segment(self, commanded: int, entered: set[int]) -> list[tuple[Edge, Node]]:
        """The edges and nodes to drive after the ``commanded`` nodes already on the route: released ones,
        up to the first node whose actions stop the vehicle, and not onto an edge whose actions stop it
        unless the vehicle stands at its start and has ``entered`` it (its actions done)."""
        if commanded and blocking(self.nodes[commanded - 1].actions):
            return []
        out: list[tuple[Edge, Node]] = []
        for i in range(commanded, len(self.nodes)):
            if i >= len(self.edges):
                break
            edge, node = self.edges[i], self.nodes[i]
            if not edge.released:
                break
            if blocking(edge.actions) and (out or commanded or edge.sequence_id not in entered):
                break
            out.append((edge, node))
            if blocking(node.actions):
                break
        return out
