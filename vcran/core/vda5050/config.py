"""What one VDA 5050 vehicle is: its identity, protocol version, capabilities and the choices the
specification leaves to the vehicle (docs/vda5050.md, "Choices where the spec leaves room").

The action catalogue says which action types the vehicle performs, where (instant, node, edge), with which
blocking types, and whether a cancelOrder may interrupt them (§6.6.3: "If the action cannot be
interrupted, the actionState of that action should reflect that by reporting RUNNING while it is
running"). An order naming anything else is refused (§6.6.4.2); the factsheet lists the same catalogue.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from datetime import datetime

from vcran.core.vda5050.enums import ActionScope, BlockingType, ValueDataType, Version
from vcran.core.vda5050.factsheet import ActionParameterDefinition
from vcran.core.vda5050.header import DEFAULT_EPOCH

INSTANT, NODE, EDGE = ActionScope.INSTANT, ActionScope.NODE, ActionScope.EDGE
ANY_BLOCKING = frozenset(BlockingType)
#: §6.10: a state "at the latest every 30s", unless the scenario asks for more often (``[simulation]
#: state_interval``).
STATE_INTERVAL = 30.0


@dataclass(frozen=True, slots=True)
class ActionSpec:
    """One action type the vehicle can perform. ``body``: the body performs it (an ``Act``); otherwise the
    vehicle does it itself (pause, cancel, requests, initPosition)."""

    action_type: str
    scopes: frozenset[ActionScope]
    blocking: frozenset[BlockingType] = ANY_BLOCKING
    interruptible: bool = True
    body: bool = True
    description: str = ""
    parameters: tuple[ActionParameterDefinition, ...] = ()


def _param(key: str, kind: ValueDataType, optional: bool = True, description: str | None = None
           ) -> ActionParameterDefinition:
    return ActionParameterDefinition(key=key, value_data_type=kind, is_optional=optional, description=description)


_S = ValueDataType.STRING
_N = ValueDataType.NUMBER

#: The predefined actions of §6.8.1 that vcran performs.
PREDEFINED: tuple[ActionSpec, ...] = (
    ActionSpec("pick", frozenset({NODE}), frozenset({BlockingType.SOFT, BlockingType.HARD}), interruptible=False,
               description="Take the load from the station in reach (SOFT or HARD: the vehicle stands).",
               parameters=(_param("stationName", _S), _param("stationType", _S), _param("loadType", _S),
                           _param("loadId", _S))),
    ActionSpec("drop", frozenset({NODE}), frozenset({BlockingType.SOFT, BlockingType.HARD}), interruptible=False,
               description="Put the load on the station in reach (SOFT or HARD: the vehicle stands).",
               parameters=(_param("stationName", _S), _param("stationType", _S), _param("loadType", _S),
                           _param("loadId", _S))),
    ActionSpec("startCharging", frozenset({INSTANT, NODE}),
               description="Start charging at the charger in reach; FINISHED once charging runs."),
    ActionSpec("stopCharging", frozenset({INSTANT, NODE}), description="Stop charging."),
    ActionSpec("finePositioning", frozenset({INSTANT, NODE}),
               frozenset({BlockingType.SOFT, BlockingType.HARD}),
               description="Align on the station in reach, in place.",
               parameters=(_param("stationName", _S), _param("stationType", _S))),
    ActionSpec("waitForTrigger", frozenset({INSTANT, NODE}),
               description="Wait for the trigger the scenario gives; fails when the order is cancelled.",
               parameters=(_param("triggerType", _S, optional=False),)),
    ActionSpec("startPause", frozenset({INSTANT}), body=False, description="Stop at once; resumable."),
    ActionSpec("stopPause", frozenset({INSTANT}), body=False, description="Resume after startPause."),
    ActionSpec("cancelOrder", frozenset({INSTANT}), body=False,
               description="Stop at the next node (or at once, where configured) and cancel the order."),
    ActionSpec("initPosition", frozenset({INSTANT}), body=False,
               description="Set the pose; not while an order runs.",
               parameters=(_param("x", _N, False), _param("y", _N, False), _param("theta", _N, False),
                           _param("mapId", _S, False), _param("lastNodeId", _S, False))),
    ActionSpec("stateRequest", frozenset({INSTANT}), body=False, description="Publish a state now."),
    ActionSpec("factsheetRequest", frozenset({INSTANT}), body=False, description="Publish the factsheet now."),
)


@dataclass(frozen=True, slots=True)
class Physical:
    """What the factsheet says of the vehicle's body (§6.15.1 physicalParameters, typeSpecification)."""

    speed_max: float = 1.0
    acceleration_max: float = 0.5
    deceleration_max: float = 0.5
    width: float = 0.6
    length: float = 0.9
    height_max: float = 0.4
    max_load_mass: float = 100.0
    #: The outline in vehicle coordinates (x forward), for the factsheet's envelope; empty: none sent.
    footprint: tuple[tuple[float, float], ...] = ()


@dataclass(frozen=True, slots=True)
class VehicleConfig:
    """One vehicle. ``manufacturer`` and ``serial_number`` name it in topics and headers (§6.3)."""

    manufacturer: str
    serial_number: str
    version: Version = Version.V2_1_0
    #: The map the vehicle drives on: orders on other maps are refused (§6.7.1).
    map_id: str = "map"
    map_version: str = "1"
    #: "within the normal tolerance of the AGV manufacturer" (§6.6.6, allowedDeviationXY = 0), metres.
    node_tolerance: float = 0.05
    #: cancelOrder while driving: stop at once (True) or at the next node (False, the default) (§6.6.3).
    stop_between_nodes: bool = False
    #: §6.10: a state at least this often, seconds.
    state_interval: float = STATE_INTERVAL
    #: Report a paused action as PAUSED (the text, §6.11) instead of RUNNING: the official state schemas of
    #: both versions leave PAUSED out of actionStatus, so the default sends what they accept.
    report_paused: bool = False
    actions: tuple[ActionSpec, ...] = PREDEFINED
    physical: Physical = field(default_factory=Physical)
    series_name: str = "vcran"
    #: Where simulated time 0 falls on the calendar in headers (a live run passes its start).
    epoch: datetime = DEFAULT_EPOCH
    #: Seconds between visualization messages, for the factsheet (None: the integrator's choice, unsaid).
    visualization_interval: float | None = None

    def __post_init__(self) -> None:
        for name in ("manufacturer", "serial_number"):
            value = getattr(self, name)
            if not value or any(c in value for c in "/$#+"):
                raise ValueError(f"{name} {value!r}: must be non-empty, without / $ # + (topic levels, §6.3)")
        if self.node_tolerance < 0 or self.state_interval <= 0:
            raise ValueError("node_tolerance must be >= 0 and state_interval > 0")
        types = [a.action_type for a in self.actions]
        if len(set(types)) != len(types):
            raise ValueError("an action type is listed twice in the catalogue")

    def action(self, action_type: str) -> ActionSpec | None:
        for spec in self.actions:
            if spec.action_type == action_type:
                return spec
        return None
