"""What a vehicle sends: ``state`` (§6.10.6), ``visualization`` (§6.13) and ``connection`` (§6.14).

Frozen models with the specification's field names in snake case; ``None`` is absent on the wire. Fields
that exist in 2.1.0 only (``maps``, ``errorHint``) are marked, and the codec refuses to send them as
2.0.0 rather than drop them silently.
"""

from __future__ import annotations

from dataclasses import dataclass

from vcran.core.slots import slot_init
from vcran.core.vda5050.enums import (
    ActionStatus,
    ConnectionState,
    ErrorLevel,
    EStop,
    InfoLevel,
    MapStatus,
    OperatingMode,
    Version,
)
from vcran.core.vda5050.fields import wire
from vcran.core.vda5050.header import Header
from vcran.core.vda5050.order import NodePosition, Trajectory


@slot_init
@dataclass(frozen=True, slots=True, kw_only=True)
class Map:
    """§6.7.2 (2.1.0 only)."""

    map_id: str
    map_version: str
    map_description: str | None = None
    map_status: MapStatus


@slot_init
@dataclass(frozen=True, slots=True, kw_only=True)
class NodeState:
    """A node still to traverse. 2.0.0 requires ``theta`` in its ``nodePosition``."""

    node_id: str
    sequence_id: int
    node_description: str | None = None
    released: bool
    node_position: NodePosition | None = wire(None, v2_0_check=lambda p: "theta" if p.theta is None else None)


def _weights(trajectory: Trajectory) -> str | None:
    for i, point in enumerate(trajectory.control_points):
        if point.weight is None:
            return f"controlPoints[{i}].weight"
    return None


@slot_init
@dataclass(frozen=True, slots=True, kw_only=True)
class EdgeState:
    """An edge still to traverse. 2.0.0 requires every control point's ``weight`` in its trajectory."""

    edge_id: str
    sequence_id: int
    edge_description: str | None = None
    released: bool
    trajectory: Trajectory | None = wire(None, v2_0_check=_weights)


@slot_init
@dataclass(frozen=True, slots=True, kw_only=True)
class AgvPosition:
    x: float
    y: float
    theta: float
    map_id: str
    map_description: str | None = None
    position_initialized: bool
    localization_score: float | None = None
    deviation_range: float | None = None


@slot_init
@dataclass(frozen=True, slots=True, kw_only=True)
class Velocity:
    vx: float | None = None
    vy: float | None = None
    omega: float | None = None


@dataclass(frozen=True, slots=True, kw_only=True)
class BoundingBoxReference:
    x: float
    y: float
    z: float
    theta: float | None = None


@dataclass(frozen=True, slots=True, kw_only=True)
class LoadDimensions:
    length: float
    width: float
    height: float | None = None


@slot_init
@dataclass(frozen=True, slots=True, kw_only=True)
class Load:
    load_id: str | None = None
    load_type: str | None = None
    load_position: str | None = None
    bounding_box_reference: BoundingBoxReference | None = None
    load_dimensions: LoadDimensions | None = None
    weight: float | None = None


@slot_init
@dataclass(frozen=True, slots=True, kw_only=True)
class ActionState:
    action_id: str
    action_type: str | None = None
    action_description: str | None = None
    action_status: ActionStatus
    result_description: str | None = None


@slot_init
@dataclass(frozen=True, slots=True, kw_only=True)
class BatteryState:
    """``battery_health`` (%) and ``reach`` (m) are integers in 2.0.0 and numbers in 2.1.0: integers suit
    both (the text: int8 and uint32)."""

    battery_charge: float
    battery_voltage: float | None = None
    battery_health: int | None = None
    charging: bool
    reach: int | None = None


@dataclass(frozen=True, slots=True, kw_only=True)
class ErrorReference:
    reference_key: str
    reference_value: str


@dataclass(frozen=True, slots=True, kw_only=True)
class Error:
    """§6.10.5 and §7.1: a type, a level, and references that help find the cause."""

    error_type: str
    error_references: tuple[ErrorReference, ...] | None = None
    error_description: str | None = None
    error_hint: str | None = wire(None, since=Version.V2_1_0)
    error_level: ErrorLevel


@dataclass(frozen=True, slots=True, kw_only=True)
class InfoReference:
    reference_key: str
    reference_value: str


@dataclass(frozen=True, slots=True, kw_only=True)
class Info:
    info_type: str
    info_references: tuple[InfoReference, ...] | None = None
    info_description: str | None = None
    info_level: InfoLevel


@dataclass(frozen=True, slots=True, kw_only=True)
class SafetyState:
    e_stop: EStop
    field_violation: bool


@slot_init
@dataclass(frozen=True, slots=True, kw_only=True)
class State:
    """§6.10.6, fields in the specification's order."""

    header: Header = wire(flatten=True)
    maps: tuple[Map, ...] | None = wire(None, since=Version.V2_1_0)
    order_id: str
    order_update_id: int
    zone_set_id: str | None = None
    last_node_id: str
    last_node_sequence_id: int
    node_states: tuple[NodeState, ...]
    edge_states: tuple[EdgeState, ...]
    agv_position: AgvPosition | None = None
    velocity: Velocity | None = None
    loads: tuple[Load, ...] | None = None
    driving: bool
    paused: bool | None = None
    new_base_request: bool | None = None
    distance_since_last_node: float | None = None
    action_states: tuple[ActionState, ...]
    battery_state: BatteryState
    operating_mode: OperatingMode
    errors: tuple[Error, ...]
    information: tuple[Info, ...] | None = None
    safety_state: SafetyState


@slot_init
@dataclass(frozen=True, slots=True, kw_only=True)
class Visualization:
    """§6.13: position and velocity at a higher rate than ``state``."""

    header: Header = wire(flatten=True)
    agv_position: AgvPosition | None = None
    velocity: Velocity | None = None


@dataclass(frozen=True, slots=True, kw_only=True)
class Connection:
    """§6.14, sent retained; CONNECTIONBROKEN is the last will the broker sends."""

    header: Header = wire(flatten=True)
    connection_state: ConnectionState
