"""The rules of an order's graph that its JSON schema cannot express (§6.6.1, §6.6.2): an order that
breaks one is malformed, refused as a ``validationError`` (§6.6.4.1) naming the field.

- at least one node, and one edge fewer than nodes;
- ``sequenceId`` runs across nodes and edges, one step at a time: node, edge, node ... (§6.6.2: "first
  node of an order receives a 0, the first edge then gets the 1, the second node then gets the 2");
  an order update starts at its stitching node's number, so only the steps are checked here;
- edge ``i`` leads from node ``i`` to node ``i + 1``;
- the first node is released (it is where the vehicle stands, or the stitching node, both base);
- "An edge can be released only if both the start and the end node of the edge are released" and
  "After an unreleased edge, no released nodes or edges can follow in the sequence";
- an ``actionId`` names one action (§6.6.6: "Unique ID to identify the action").
"""

from __future__ import annotations

from vcran.core.vda5050.order import Order


def problem(order: Order) -> tuple[str, str] | None:
    """``(path, problem)`` of the first rule ``order`` breaks, in the order of the module docstring."""
    nodes, edges = order.nodes, order.edges
    if not nodes:
        return "$.nodes", "an order has at least one node (§6.6.1)"
    if len(edges) != len(nodes) - 1:
        return "$.edges", f"{len(edges)} edges for {len(nodes)} nodes: an order has one edge fewer than nodes (§6.6.1)"
    first = nodes[0].sequence_id
    for i, node in enumerate(nodes):
        if node.sequence_id != first + 2 * i:
            return (f"$.nodes[{i}].sequenceId", f"is {node.sequence_id}, expected {first + 2 * i}: sequenceIds "
                    "count up by one from node to edge to node (§6.6.2)")
    for i, edge in enumerate(edges):
        if edge.sequence_id != first + 2 * i + 1:
            return (f"$.edges[{i}].sequenceId", f"is {edge.sequence_id}, expected {first + 2 * i + 1}: "
                    "sequenceIds count up by one from node to edge to node (§6.6.2)")
        if edge.start_node_id != nodes[i].node_id:
            return (f"$.edges[{i}].startNodeId", f"{edge.start_node_id!r} is not the node before it, "
                    f"{nodes[i].node_id!r} (§6.6.1)")
        if edge.end_node_id != nodes[i + 1].node_id:
            return (f"$.edges[{i}].endNodeId", f"{edge.end_node_id!r} is not the node after it, "
                    f"{nodes[i + 1].node_id!r} (§6.6.1)")
    if not nodes[0].released:
        return "$.nodes[0].released", "the first node of an order is released: the vehicle starts there (§6.6.1)"
    horizon = False
    for i, node in enumerate(nodes):
        if i:
            edge = edges[i - 1]
            if edge.released and not node.released:
                return (f"$.edges[{i - 1}].released", "an edge is released only if both its nodes are (§6.6.1)")
            horizon = horizon or not edge.released
        if node.released and horizon:
            return (f"$.nodes[{i}].released", "a released node after an unreleased edge: the base comes before "
                    "the horizon (§6.6.1)")
        horizon = horizon or not node.released
    return _duplicate_action(order)


def _duplicate_action(order: Order) -> tuple[str, str] | None:
    ids = [a.action_id for n in order.nodes for a in n.actions] + [a.action_id for e in order.edges for a in e.actions]
    if len(set(ids)) == len(ids):
        return None  # every order a vehicle accepts: no need to find the first repeat in sequence order
    seen: set[str] = set()
    places = [("nodes", i, n.actions) for i, n in enumerate(order.nodes)]
    places += [("edges", i, e.actions) for i, e in enumerate(order.edges)]
    for kind, i, actions in sorted(places, key=lambda p: _sequence(order, p[0], p[1])):
        for j, action in enumerate(actions):
            if action.action_id in seen:
                return (f"$.{kind}[{i}].actions[{j}].actionId",
                        f"{action.action_id!r} names another action of this order too (§6.6.6)")
            seen.add(action.action_id)
    return None


def _sequence(order: Order, kind: str, i: int) -> int:
    return order.nodes[i].sequence_id if kind == "nodes" else order.edges[i].sequence_id
