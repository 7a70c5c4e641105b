"""What a master sends a vehicle: ``order`` (§6.6.6) and ``instantActions`` (§6.9), as frozen models.

Field names are the specification's in snake case (``orderUpdateId`` is ``order_update_id``); optional
fields are ``None`` when absent and then left out on the wire. A model is what the codec built from a
message that passed the official schema (:func:`vcran.core.vda5050.codec.decode`), or what a master
builds to send; the graph rules of §6.6.1 that a schema cannot express are the vehicle's to check
(:mod:`vcran.core.vda5050.graph`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from vcran.core.vda5050.enums import BlockingType, CorridorRefPoint, OrientationType, Version
from vcran.core.vda5050.fields import wire
from vcran.core.vda5050.header import Header


@dataclass(frozen=True, slots=True, kw_only=True)
class ActionParameter:
    """§7.2: a key and any JSON value (an object only from 2.1.0 on)."""

    key: str
    value: Any = wire(no_object_before=Version.V2_1_0)


@dataclass(frozen=True, slots=True, kw_only=True)
class Action:
    """§6.6.6 action: on a node, on an edge, or instant (§6.9). A 2.0.0 instant action may name its type
    ``actionName``, as the 2.0.0 schema does (:mod:`vcran.core.vda5050.validation`)."""

    action_type: str = wire(v2_0_alias="actionName")
    action_id: str
    action_description: str | None = None
    blocking_type: BlockingType
    action_parameters: tuple[ActionParameter, ...] | None = None

    def parameter(self, key: str, default: Any = None) -> Any:
        """The value of parameter ``key`` (the first, should a master send it twice), else ``default``."""
        for p in self.action_parameters or ():
            if p.key == key:
                return p.value
        return default


@dataclass(frozen=True, slots=True, kw_only=True)
class NodePosition:
    """Where a node is, on map ``map_id``. ``allowed_deviation_xy`` is spelled ``allowedDeviationXy`` in the
    2.0.0 schema and ``allowedDeviationXY`` in 2.1.0."""

    x: float
    y: float
    theta: float | None = None
    allowed_deviation_xy: float | None = wire(None, name="allowedDeviationXY", v2_0="allowedDeviationXy")
    allowed_deviation_theta: float | None = None
    map_id: str
    map_description: str | None = None


@dataclass(frozen=True, slots=True, kw_only=True)
class Node:
    node_id: str
    sequence_id: int
    node_description: str | None = None
    released: bool
    node_position: NodePosition | None = None
    actions: tuple[Action, ...] = ()


@dataclass(frozen=True, slots=True, kw_only=True)
class ControlPoint:
    """A NURBS control point; an absent ``weight`` is 1.0 (§6.6.6)."""

    x: float
    y: float
    weight: float | None = None


@dataclass(frozen=True, slots=True, kw_only=True)
class Trajectory:
    degree: int
    knot_vector: tuple[float, ...]
    control_points: tuple[ControlPoint, ...]


@dataclass(frozen=True, slots=True, kw_only=True)
class Corridor:
    """§6.6.5 (2.1.0 only)."""

    left_width: float
    right_width: float
    corridor_ref_point: CorridorRefPoint | None = None


@dataclass(frozen=True, slots=True, kw_only=True)
class Edge:
    edge_id: str
    sequence_id: int
    edge_description: str | None = None
    released: bool
    start_node_id: str
    end_node_id: str
    max_speed: float | None = None
    max_height: float | None = None
    min_height: float | None = None
    orientation: float | None = None
    orientation_type: OrientationType | None = wire(None, since=Version.V2_1_0)
    direction: str | None = None
    rotation_allowed: bool | None = None
    max_rotation_speed: float | None = None
    trajectory: Trajectory | None = None
    length: float | None = None
    corridor: Corridor | None = wire(None, since=Version.V2_1_0)
    actions: tuple[Action, ...] = ()


@dataclass(frozen=True, slots=True, kw_only=True)
class Order:
    """§6.6.6. ``nodes`` and ``edges`` alternate in sequence order: node, edge, node, ..."""

    header: Header = wire(flatten=True)
    order_id: str
    order_update_id: int
    zone_set_id: str | None = None
    nodes: tuple[Node, ...]
    edges: tuple[Edge, ...]


@dataclass(frozen=True, slots=True, kw_only=True)
class InstantActions:
    """§6.9. The 2.0.0 schema names an action's type ``actionName``; the 2.0.0 text says ``actionType``,
    which vcran writes in both versions and reads besides ``actionName`` in 2.0.0. The 2.0 text calls the
    list ``instantActions`` (as 1.1 did), the schemas ``actions``: a 2.0.0 vehicle reads either
    (docs/vda5050.md, "Versions")."""

    header: Header = wire(flatten=True)
    actions: tuple[Action, ...] = wire(v2_0_alias="instantActions")
