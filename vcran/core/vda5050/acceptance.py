"""Whether a vehicle takes an order: Figure 8 of §6.6.2 ("The process of accepting an order or order
update") and the rejections of §6.6.4, as one pure function of the order and what the vehicle is doing.

The checks run in this order; the first that fails decides (docs/vda5050.md lists the codes):

1. the graph (:mod:`vcran.core.vda5050.graph`): ``validationError`` (Figure 8 (1), §6.6.4.1);
2. same ``orderId`` as the vehicle's: a lower ``orderUpdateId`` is an ``orderUpdateError`` (5, §6.6.4.3),
   the same one is discarded (6, "the second order will be ignored");
3. what the vehicle cannot do (§6.6.4.2): actions it does not perform (type, where, blocking type,
   missing required parameters), fields it cannot use (trajectory, corridor, an orientation other than
   forwards, a map it does not have, a node without a position, a non-positive maxSpeed): ``orderError``
   naming the fields. The stitching node of an update is not checked: its contents are the first
   order's (§6.6.2: "the AGV shall use the instructions provided in the first order");
4. a FATAL error (the vehicle is "not in running condition"): ``orderError``;
5. a new ``orderId``: refused while charging (§6.8.1, stopCharging: "Deactivates the charging process to
   send a new order"), while still executing an order or waiting for an update (3), or when its first
   node is not where the vehicle is (4): ``orderError``;
6. an update: refused while a cancelOrder runs, or when its first node is not the decision point (7,
   still executing) or the last traversed node (8, order done): ``orderUpdateError``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from vcran.core.vda5050 import errors, graph
from vcran.core.vda5050.config import VehicleConfig
from vcran.core.vda5050.effects import Where
from vcran.core.vda5050.enums import ActionScope, OrientationType
from vcran.core.vda5050.order import Action, Edge, Node, Order
from vcran.core.vda5050.state import Error

NEW, UPDATE, DISCARD = "new", "update", "discard"


@dataclass(frozen=True, slots=True)
class Standing:
    """What of the vehicle the decision depends on."""

    order_id: str | None  # None: no order yet
    order_update_id: int
    executing: bool  # Figure 8 (3): nodeStates not empty, or order actions neither FINISHED nor FAILED
    cancelling: bool
    decision: tuple[str, int] | None  # the last base node of the current order (nodeId, sequenceId)
    last_node: tuple[str, int]
    charging: bool
    fatal: Error | None
    where: Where


def decide(order: Order, standing: Standing, config: VehicleConfig) -> str | Error:
    """``NEW``, ``UPDATE``, ``DISCARD``, or the error to report for refusing ``order``."""
    refs = _order_refs(order)
    found = graph.problem(order)
    if found is not None:
        path, problem = found
        return errors.error(errors.VALIDATION, f"{path}: {problem}", (*refs, ("field", path)))
    same = standing.order_id is not None and order.order_id == standing.order_id
    if same and order.order_update_id < standing.order_update_id:
        return errors.error(errors.ORDER_UPDATE, f"orderUpdateId {order.order_update_id} is older than "
                            f"{standing.order_update_id}, the vehicle's (§6.6.4.3)", refs)
    if same and order.order_update_id == standing.order_update_id:
        return DISCARD
    unusable = _unusable(order, config, stitching=same)
    if unusable is not None:
        return errors.error(errors.ORDER, unusable[0], (*refs, *unusable[1]))
    if standing.fatal is not None:
        return errors.error(errors.ORDER, f"the vehicle is not in running condition: {standing.fatal.error_type}",
                            (*refs, ("errorType", standing.fatal.error_type)))
    first = order.nodes[0]
    first_ref = (("nodeId", first.node_id), ("sequenceId", first.sequence_id))
    if not same:
        if standing.charging:
            return errors.error(errors.ORDER, "the vehicle is charging: stopCharging first", refs)
        if standing.executing:
            return errors.error(errors.ORDER, f"the vehicle is still executing order {standing.order_id!r} "
                                "or waiting for its update (§6.6.2, Figure 8 (3))", refs)
        far = _distance(first, standing, config.node_tolerance)
        if far is not None:
            return errors.error(errors.ORDER, f"the first node is {far} (§6.6.1: trivially reachable)",
                                (*refs, *first_ref))
        return NEW
    if standing.cancelling:
        return errors.error(errors.ORDER_UPDATE, "the order is being cancelled", refs)
    at = (first.node_id, first.sequence_id)
    if standing.executing and at != standing.decision:
        return errors.error(errors.ORDER_UPDATE, f"the first node {at} is not the decision point "
                            f"{standing.decision} (§6.6.2, Figure 8 (7))", (*refs, *first_ref))
    if not standing.executing and at != standing.last_node:
        return errors.error(errors.ORDER_UPDATE, f"the first node {at} is not the last traversed node "
                            f"{standing.last_node} (§6.6.2, Figure 8 (8))", (*refs, *first_ref))
    return UPDATE


def _order_refs(order: Order) -> tuple[tuple[str, str | int], ...]:
    """§7.1: topic, headerId, orderId and orderUpdateId."""
    return (("topic", "order"), ("headerId", order.header.header_id), ("orderId", order.order_id),
            ("orderUpdateId", order.order_update_id))


def _distance(first: Node, standing: Standing, tolerance: float) -> str | None:
    """Why the vehicle is not on ``first``, or None if it is (§6.6.1: "either that the AGV is already
    standing on the node, or that the AGV is in the node's deviation range"). An allowedDeviationXY of 0
    (or none) means "within the normal tolerance of the AGV manufacturer": ``tolerance``."""
    position = first.node_position
    if position is None:  # a node without a position is where the vehicle stands only by its id
        if standing.last_node[0] == first.node_id:
            return None
        return f"{first.node_id!r}, without a position, and the vehicle's last node is {standing.last_node[0]!r}"
    radius = position.allowed_deviation_xy or 0.0
    d = math.hypot(position.x - standing.where.x, position.y - standing.where.y)
    if d <= (radius if radius > 0 else tolerance):
        return None
    return f"{d:.3f} m away, beyond its allowed deviation"


def _unusable(order: Order, config: VehicleConfig, stitching: bool) -> tuple[str, tuple[tuple[str, str], ...]] | None:
    """What of ``order`` this vehicle cannot do (§6.6.4.2), with the fields as error references."""
    for i, node in enumerate(order.nodes):
        if i == 0 and stitching:
            continue
        refs = (("nodeId", node.node_id),)
        position = node.node_position
        if position is None and i > 0:
            return "a node without nodePosition: the vehicle drives to node positions", refs
        if position is not None and position.map_id != config.map_id:
            return (f"map {position.map_id!r} is not on the vehicle (it has {config.map_id!r}, §6.7.1)",
                    (*refs, ("mapId", position.map_id)))
        found = _actions(node.actions, ActionScope.NODE, config, refs)
        if found is not None:
            return found
    for edge in order.edges:
        found = _edge(edge, config)
        if found is not None:
            return found
    return None


def _edge(edge: Edge, config: VehicleConfig) -> tuple[str, tuple[tuple[str, str], ...]] | None:
    refs = (("edgeId", edge.edge_id),)
    if edge.trajectory is not None:
        return "trajectory: the vehicle drives straight lines between nodes", (*refs, ("field", "trajectory"))
    if edge.corridor is not None:
        return "corridor: the vehicle does not deviate from its path", (*refs, ("field", "corridor"))
    if edge.orientation is not None and (edge.orientation != 0.0 or edge.orientation_type is OrientationType.GLOBAL):
        return "orientation: the vehicle drives forwards along its edges", (*refs, ("field", "orientation"))
    if edge.max_speed is not None and edge.max_speed <= 0.0:
        return "maxSpeed must be positive for the vehicle to move", (*refs, ("field", "maxSpeed"))
    return _actions(edge.actions, ActionScope.EDGE, config, refs)


def _actions(actions: tuple[Action, ...], scope: ActionScope, config: VehicleConfig,
             refs: tuple[tuple[str, str], ...]) -> tuple[str, tuple[tuple[str, str], ...]] | None:
    for action in actions:
        here = (*refs, ("actionId", action.action_id), ("actionType", action.action_type))
        spec = config.action(action.action_type)
        if spec is None or scope not in spec.scopes:
            return f"the vehicle cannot perform {action.action_type!r} on {scope.value.lower()}s", here
        if action.blocking_type not in spec.blocking:
            return (f"{action.action_type!r} cannot be {action.blocking_type.value}: "
                    f"{', '.join(sorted(b.value for b in spec.blocking))}", (*here, ("blockingType", action.blocking_type.value)))
        for p in spec.parameters:
            if not p.is_optional and action.parameter(p.key) is None:
                return f"{action.action_type!r} needs parameter {p.key!r}", (*here, ("parameter", p.key))
    return None
