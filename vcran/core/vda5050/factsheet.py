"""The ``factsheet`` (§6.15): what a vehicle type is and which parts of the protocol it supports.

Frozen models, the specification's names in snake case. Two fields of the 2.1.0 schema cannot validate as
the text defines them, so vcran never fills them (docs/vda5050.md, "Versions"): ``agvAction.blockingTypes``
(the schema puts a string ``enum`` on the array itself) and ``envelope3d.description`` (typed integer).
``vehicleConfig`` exists from 2.1.0 on.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from vcran.core.vda5050.enums import (
    ActionScope,
    AgvClass,
    AgvKinematic,
    BlockingType,
    LocalizationType,
    NavigationType,
    Support,
    ValueDataType,
    Version,
    WheelType,
)
from vcran.core.vda5050.fields import wire
from vcran.core.vda5050.header import Header
from vcran.core.vda5050.state import BoundingBoxReference, LoadDimensions


@dataclass(frozen=True, slots=True, kw_only=True)
class TypeSpecification:
    series_name: str
    series_description: str | None = None
    agv_kinematic: AgvKinematic
    agv_class: AgvClass
    max_load_mass: float
    localization_types: tuple[LocalizationType, ...]
    navigation_types: tuple[NavigationType, ...]


@dataclass(frozen=True, slots=True, kw_only=True)
class PhysicalParameters:
    speed_min: float
    speed_max: float
    angular_speed_min: float | None = None
    angular_speed_max: float | None = None
    acceleration_max: float
    deceleration_max: float
    height_min: float | None = None
    height_max: float
    width: float
    length: float


@dataclass(frozen=True, slots=True, kw_only=True)
class MaxStringLens:
    msg_len: int | None = None
    topic_serial_len: int | None = None
    topic_elem_len: int | None = None
    id_len: int | None = None
    id_numerical_only: bool | None = None
    enum_len: int | None = None
    load_id_len: int | None = None


@dataclass(frozen=True, slots=True, kw_only=True)
class MaxArrayLens:
    """The specification names these fields after the arrays they limit (``order.nodes``)."""

    order_nodes: int | None = wire(None, name="order.nodes")
    order_edges: int | None = wire(None, name="order.edges")
    node_actions: int | None = wire(None, name="node.actions")
    edge_actions: int | None = wire(None, name="edge.actions")
    actions_parameters: int | None = wire(None, name="actions.actionsParameters")
    instant_actions: int | None = wire(None, name="instantActions")
    trajectory_knot_vector: int | None = wire(None, name="trajectory.knotVector")
    trajectory_control_points: int | None = wire(None, name="trajectory.controlPoints")
    state_node_states: int | None = wire(None, name="state.nodeStates")
    state_edge_states: int | None = wire(None, name="state.edgeStates")
    state_loads: int | None = wire(None, name="state.loads")
    state_action_states: int | None = wire(None, name="state.actionStates")
    state_errors: int | None = wire(None, name="state.errors")
    state_information: int | None = wire(None, name="state.information")
    error_references: int | None = wire(None, name="error.errorReferences")
    info_references: int | None = wire(None, name="information.infoReferences")


@dataclass(frozen=True, slots=True, kw_only=True)
class Timing:
    min_order_interval: float
    min_state_interval: float
    default_state_interval: float | None = None
    visualization_interval: float | None = None


@dataclass(frozen=True, slots=True, kw_only=True)
class ProtocolLimits:
    max_string_lens: MaxStringLens
    max_array_lens: MaxArrayLens
    timing: Timing


@dataclass(frozen=True, slots=True, kw_only=True)
class OptionalParameter:
    parameter: str
    support: Support
    description: str | None = None


@dataclass(frozen=True, slots=True, kw_only=True)
class ActionParameterDefinition:
    """The factsheet's description of a parameter (not an order's key/value pair)."""

    key: str
    value_data_type: ValueDataType
    description: str | None = None
    is_optional: bool | None = None


@dataclass(frozen=True, slots=True, kw_only=True)
class AgvAction:
    action_type: str
    action_description: str | None = None
    action_scopes: tuple[ActionScope, ...]
    action_parameters: tuple[ActionParameterDefinition, ...] | None = None
    result_description: str | None = None
    #: Never sent by vcran: no array validates against the official schemas (module docstring).
    blocking_types: tuple[BlockingType, ...] | None = None


@dataclass(frozen=True, slots=True, kw_only=True)
class ProtocolFeatures:
    optional_parameters: tuple[OptionalParameter, ...]
    agv_actions: tuple[AgvAction, ...]


@dataclass(frozen=True, slots=True, kw_only=True)
class WheelPosition:
    x: float
    y: float
    theta: float | None = None


@dataclass(frozen=True, slots=True, kw_only=True)
class WheelDefinition:
    type: WheelType
    is_active_driven: bool
    is_active_steered: bool
    position: WheelPosition
    diameter: float
    width: float
    center_displacement: float | None = None
    constraints: str | None = None


@dataclass(frozen=True, slots=True, kw_only=True)
class PolygonPoint:
    x: float
    y: float


@dataclass(frozen=True, slots=True, kw_only=True)
class Envelope2d:
    set: str
    polygon_points: tuple[PolygonPoint, ...]
    description: str | None = None


@dataclass(frozen=True, slots=True, kw_only=True)
class Envelope3d:
    set: str
    format: str
    data: Any = None
    url: str | None = None
    #: Never sent by vcran: the official schema types it integer (module docstring).
    description: str | None = None


@dataclass(frozen=True, slots=True, kw_only=True)
class AgvGeometry:
    wheel_definitions: tuple[WheelDefinition, ...] | None = None
    envelopes2d: tuple[Envelope2d, ...] | None = None
    envelopes3d: tuple[Envelope3d, ...] | None = None


@dataclass(frozen=True, slots=True, kw_only=True)
class LoadSet:
    set_name: str
    load_type: str
    load_positions: tuple[str, ...] | None = None
    bounding_box_reference: BoundingBoxReference | None = None
    load_dimensions: LoadDimensions | None = None
    max_weight: float | None = None
    min_loadhandling_height: float | None = None
    max_loadhandling_height: float | None = None
    min_loadhandling_depth: float | None = None
    max_loadhandling_depth: float | None = None
    min_loadhandling_tilt: float | None = None
    max_loadhandling_tilt: float | None = None
    agv_speed_limit: float | None = None
    agv_acceleration_limit: float | None = None
    agv_deceleration_limit: float | None = None
    pick_time: float | None = None
    drop_time: float | None = None
    description: str | None = None


@dataclass(frozen=True, slots=True, kw_only=True)
class LoadSpecification:
    load_positions: tuple[str, ...] | None = None
    load_sets: tuple[LoadSet, ...] | None = None


@dataclass(frozen=True, slots=True, kw_only=True)
class VersionInfo:
    key: str
    value: str


@dataclass(frozen=True, slots=True, kw_only=True)
class Network:
    dns_servers: tuple[str, ...] | None = None
    local_ip_address: str | None = None
    ntp_servers: tuple[str, ...] | None = None
    netmask: str | None = None
    default_gateway: str | None = None


@dataclass(frozen=True, slots=True, kw_only=True)
class VehicleConfig:
    """2.1.0 only."""

    versions: tuple[VersionInfo, ...] | None = None
    network: Network | None = None


@dataclass(frozen=True, slots=True, kw_only=True)
class Factsheet:
    header: Header = wire(flatten=True)
    type_specification: TypeSpecification
    physical_parameters: PhysicalParameters
    protocol_limits: ProtocolLimits
    protocol_features: ProtocolFeatures
    agv_geometry: AgvGeometry
    load_specification: LoadSpecification
    vehicle_config: VehicleConfig | None = wire(None, since=Version.V2_1_0)
