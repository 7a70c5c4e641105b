"""Orders built from routes, as a master writes them (docs/contract.md §11; VDA 5050 §6.6): one call per order or update.

A route is the nodes a vehicle is to pass, in order, each a :class:`Stop` (a node id, where it is, what to
do there). :class:`OrderLine` keeps what one vehicle was last sent, so that each message is numbered as
§6.6.2 asks without the master counting:

- a new order (:meth:`OrderLine.new`): its nodes get sequenceIds 0, 2, 4 ..., the edges between them 1, 3
  ...; the first ``base`` nodes and the edges between them are released (the base), the rest is horizon;
- an update (:meth:`OrderLine.update`): the same orderId, the next orderUpdateId, starting at the
  *decision point* (the last released node, which the update repeats as its stitching node with the same
  sequenceId) and numbering on from there. The horizon sent before is replaced by the update's.

Edges are named ``"{start}-{end}"`` and carry the ``max_speed`` of the stop they lead to. The messages'
headers are the sender's to stamp (:class:`vcran.core.vda5050.master.MasterHandle` does it).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from vcran.core.vda5050.enums import BlockingType
from vcran.core.vda5050.header import Header
from vcran.core.vda5050.order import Action, ActionParameter, Edge, Node, NodePosition, Order


@dataclass(frozen=True, slots=True)
class Stop:
    """A node of a route: its id, its position (and the heading to end in, if any), the actions to perform
    there, and the top speed on the edge that leads to it (m/s; None: the vehicle's own)."""

    node_id: str
    x: float
    y: float
    theta: float | None = None
    actions: tuple[Action, ...] = ()
    max_speed: float | None = None


def action(action_type: str, action_id: str, blocking: str = "HARD", **parameters: Any) -> Action:
    """``action("pick", "p1", "HARD", stationName="A")``: an action with its parameters in keyword order."""
    return Action(action_type=action_type, action_id=action_id, blocking_type=BlockingType(blocking),
                  action_parameters=tuple(ActionParameter(key=k, value=v) for k, v in parameters.items()) or None)


class OrderLine:
    """One vehicle's orders as its master sent them: the orderId, the last orderUpdateId, and the decision
    point with its sequenceId, where the next update stitches (module docstring)."""

    def __init__(self, map_id: str = "map") -> None:
        self.map_id = map_id
        self.order_id: str | None = None
        self.order_update_id = 0
        #: The last released node sent, and its sequenceId: the next update's first node.
        self.decision: Stop | None = None
        self.decision_sequence = 0
        #: The last order or update built, to send again if it was lost (QoS 0, §6.2).
        self.last: Order | None = None

    def new(self, header: Header, order_id: str, route: Sequence[Stop], base: int | None = None) -> Order:
        """A new order along ``route`` (its first stop is where the vehicle stands), the first ``base``
        stops released (None: all of them)."""
        if not route:
            raise ValueError("an order needs at least one node: where the vehicle stands (§6.6.1)")
        if order_id == self.order_id:
            raise ValueError(f"order {order_id!r} was sent already: a new order needs a new orderId "
                             "(the vehicle would read it as an update, §6.6.2)")
        released = _released(base, len(route), least=1)
        order = self._order(header, order_id, 0, route, released, 0)
        self.order_id, self.order_update_id = order_id, 0
        return order

    def update(self, header: Header, route: Sequence[Stop], base: int | None = None) -> Order:
        """The next update of the current order: ``route`` is the nodes after the decision point, the first
        ``base`` of them released (None: all), the rest the new horizon."""
        if self.order_id is None or self.decision is None:
            raise ValueError("no order to update: send a new order first")
        released = _released(base, len(route), least=0)
        stitch = self.decision
        stitching = Stop(stitch.node_id, stitch.x, stitch.y, stitch.theta)  # its actions were the first order's
        self.order_update_id += 1
        return self._order(header, self.order_id, self.order_update_id, [stitching, *route], released + 1,
                           self.decision_sequence)

    def _order(self, header: Header, order_id: str, update_id: int, route: Sequence[Stop], released: int,
               first: int) -> Order:
        nodes = tuple(
            Node(node_id=s.node_id, sequence_id=first + 2 * i, released=i < released,
                 node_position=NodePosition(x=float(s.x), y=float(s.y), theta=s.theta, map_id=self.map_id),
                 actions=s.actions)
            for i, s in enumerate(route))
        edges = tuple(
            Edge(edge_id=f"{a.node_id}-{b.node_id}", sequence_id=first + 2 * i + 1, released=i + 1 < released,
                 start_node_id=a.node_id, end_node_id=b.node_id, max_speed=b.max_speed)
            for i, (a, b) in enumerate(zip(route, route[1:])))
        self.decision, self.decision_sequence = route[released - 1], first + 2 * (released - 1)
        self.last = Order(header=header, order_id=order_id, order_update_id=update_id, nodes=nodes, edges=edges)
        return self.last


def _released(base: int | None, n: int, least: int) -> int:
    if base is None:
        return n
    if not least <= base <= n:
        raise ValueError(f"base {base}: between {least} and the route's {n} nodes")
    return base
