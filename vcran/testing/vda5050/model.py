"""A reference model of a VDA 5050 vehicle's acceptance rules, written from the specification, not from
vcran's vehicle (docs/contract.md §11, issue 31 item 6).

It decides what a vehicle must do with an order, an order update or a cancelOrder from what a master can
see: the vehicle's last ``state`` message, where the vehicle is, and which actions the master sent as
instant actions. Figure 8 of §6.6.2 is written in those terms ("(3) Are nodeStates not empty or are
actionStates containing states which are neither FAILED nor FINISHED?", "(8) ... equal to lastNodeId and
lastNodeSequenceId"), so the model needs nothing of the vehicle's insides. The order of the checks and
the choices the text leaves open are vcran's documented ones (docs/vda5050.md).
"""

from __future__ import annotations

import math

from vcran.core.vda5050.config import VehicleConfig
from vcran.core.vda5050.effects import Where
from vcran.core.vda5050.enums import ActionScope, ActionStatus, ErrorLevel
from vcran.core.vda5050.order import Order
from vcran.core.vda5050.state import State

NEW, UPDATE, DISCARD = "new", "update", "discard"
CANCEL, NO_ORDER_TO_CANCEL = "cancel", "noOrderToCancel"


class ReferenceVehicle:
    """The acceptance rules; :meth:`order` and :meth:`cancel` are pure functions of their arguments."""

    def __init__(self, config: VehicleConfig) -> None:
        self.config = config

    def order(self, state: State, order: Order, where: Where, instant_ids: set[str]) -> str:
        """``NEW``, ``UPDATE``, ``DISCARD``, or the errorType of the refusal."""
        if not well_formed(order):
            return "validationError"  # (1)
        same = state.order_id != "" and order.order_id == state.order_id  # (2)
        if same and order.order_update_id < state.order_update_id:
            return "orderUpdateError"  # (5), §6.6.4.3
        if same and order.order_update_id == state.order_update_id:
            return DISCARD  # (6)
        if not self.usable(order, stitching=same):
            return "orderError"  # §6.6.4.2
        if any(e.error_level is ErrorLevel.FATAL for e in state.errors):
            return "orderError"
        busy = executing(state, instant_ids)  # (3)
        first = order.nodes[0]
        if not same:
            if state.battery_state.charging or busy:
                return "orderError"
            return NEW if self.on(first.node_position, first.node_id, state, where) else "orderError"  # (4)
        if cancelling(state):
            return "orderUpdateError"
        at = (first.node_id, first.sequence_id)
        if busy:  # (7): the first node is the last node of the base
            base = [(n.node_id, n.sequence_id) for n in state.node_states if n.released]
            decision = base[-1] if base else (state.last_node_id, state.last_node_sequence_id)
            return UPDATE if at == decision else "orderUpdateError"
        return UPDATE if at == (state.last_node_id, state.last_node_sequence_id) else "orderUpdateError"  # (8)

    def cancel(self, state: State, instant_ids: set[str]) -> str:
        """§6.6.3.2: FAILED with noOrderToCancel when "the AGV currently has no order, or the previous order
        was canceled"."""
        return CANCEL if executing(state, instant_ids) and not cancelling(state) else NO_ORDER_TO_CANCEL

    def usable(self, order: Order, stitching: bool) -> bool:
        """§6.6.4.2 for what the fuzzer sends: actions the vehicle performs there, on its map."""
        for i, node in enumerate(order.nodes):
            if i == 0 and stitching:
                continue
            if node.node_position is not None and node.node_position.map_id != self.config.map_id:
                return False
            if not all(self._can(a.action_type, a.blocking_type, ActionScope.NODE, a) for a in node.actions):
                return False
        return all(self._can(a.action_type, a.blocking_type, ActionScope.EDGE, a)
                   for e in order.edges for a in e.actions)

    def _can(self, kind: str, blocking: object, scope: ActionScope, action: object) -> bool:
        spec = self.config.action(kind)
        if spec is None or scope not in spec.scopes or blocking not in spec.blocking:
            return False
        return all(p.is_optional or action.parameter(p.key) is not None  # type: ignore[attr-defined]
                   for p in spec.parameters)

    def on(self, position: object, node_id: str, state: State, where: Where) -> bool:
        """(4): "Is the vehicle already standing on the node, or is it in the node's deviation range?"."""
        if position is None:
            return state.last_node_id == node_id
        deviation = getattr(position, "allowed_deviation_xy", None) or 0.0
        radius = deviation if deviation > 0 else self.config.node_tolerance
        return math.hypot(position.x - where.x, position.y - where.y) <= radius  # type: ignore[attr-defined]


def executing(state: State, instant_ids: set[str]) -> bool:
    """Figure 8 (3), counting the order's actions (not the instant ones, which §6.10.6 keeps across orders)."""
    open_actions = any(a.action_status not in (ActionStatus.FINISHED, ActionStatus.FAILED)
                       and a.action_id not in instant_ids for a in state.action_states)
    return bool(state.node_states) or open_actions


def cancelling(state: State) -> bool:
    """A cancelOrder still RUNNING (Figure 9)."""
    return any(a.action_type == "cancelOrder" and a.action_status is ActionStatus.RUNNING for a in state.action_states)


def well_formed(order: Order) -> bool:
    """§6.6.1 and §6.6.2, read plainly: nodes and edges alternate with consecutive sequenceIds, each edge
    joins its neighbours, the base (released) comes first and starts with the first node, actionIds are
    unique."""
    nodes, edges = order.nodes, order.edges
    if not nodes or len(edges) != len(nodes) - 1:
        return False
    chain: list[tuple[int, bool]] = []
    for i, node in enumerate(nodes):
        chain.append((node.sequence_id, node.released))
        if i < len(edges):
            edge = edges[i]
            if (edge.start_node_id, edge.end_node_id) != (node.node_id, nodes[i + 1].node_id):
                return False
            chain.append((edge.sequence_id, edge.released))
    numbers = [n for n, _ in chain]
    if numbers != list(range(numbers[0], numbers[0] + len(numbers))):
        return False
    flags = [r for _, r in chain]
    released = flags.count(True)
    if flags != [True] * released + [False] * (len(flags) - released) or released % 2 == 0:
        return False  # a prefix, starting and ending with a node (so an edge's nodes are released with it)
    ids = [a.action_id for n in nodes for a in n.actions] + [a.action_id for e in edges for a in e.actions]
    return len(ids) == len(set(ids))
