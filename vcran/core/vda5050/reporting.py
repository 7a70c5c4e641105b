"""The messages a vehicle sends, built from its logic and a snapshot of its body; part of
:class:`~vcran.core.vda5050.vehicle.Vehicle`.

Each builder stamps its message with the next ``headerId`` of its topic (§6.4): call it once per message
sent. The parts of ``state`` that only change with events (nodeStates, edgeStates, actionStates, errors)
are kept between messages; a state costs the few objects that change with every tick (position,
velocity, battery).
"""

from __future__ import annotations

import math
from functools import cache
from typing import TYPE_CHECKING

from vcran.core.vda5050.effects import Body
from vcran.core.vda5050.enums import ConnectionState, EStop, MapStatus, OperatingMode, Version
from vcran.core.vda5050.factsheet import Factsheet
from vcran.core.vda5050.sheet import factsheet
from vcran.core.vda5050.state import (
    AgvPosition,
    BatteryState,
    Connection,
    EdgeState,
    Map,
    NodeState,
    SafetyState,
    State,
    Velocity,
    Visualization,
)

if TYPE_CHECKING:
    from vcran.core.vda5050.actions import ActionBook
    from vcran.core.vda5050.config import VehicleConfig
    from vcran.core.vda5050.errors import ErrorBook
    from vcran.core.vda5050.header import Stamper
    from vcran.core.vda5050.path import Path

_NO_FIELD = SafetyState(e_stop=EStop.NONE, field_violation=False)
_FIELD = SafetyState(e_stop=EStop.NONE, field_violation=True)


class ReportingMixin:
    """The message builders of a Vehicle (the attributes below are the Vehicle's)."""

    config: VehicleConfig
    stamper: Stamper
    actions: ActionBook
    errors: ErrorBook
    path: Path
    order_id: str | None
    order_update_id: int
    zone_set_id: str | None
    last_node_id: str
    last_node_sequence_id: int
    paused: bool
    charging: bool
    field_violation: bool
    _active: bool
    _odometer_at_node: float | None
    _graph: tuple[int, tuple[NodeState, ...], tuple[EdgeState, ...]] | None = None
    #: The last batteryState sent, sent again while the charge and charging stay (most states of a run).
    _battery: BatteryState | None = None
    #: (the configuration, the maps a state lists under it): :meth:`_maps`.
    _map_list: tuple[VehicleConfig, tuple[Map, ...] | None] | None = None

    if TYPE_CHECKING:
        @property
        def driving(self) -> bool: ...

    @property
    def new_base_request(self) -> bool:
        """§6.10.3: the order has a horizon and at most one released edge is left to drive: on the last edge
        of the base, or at its end (docs/vda5050.md)."""
        return self._active and self.path.short_of_base()

    def state(self, now: float, body: Body) -> State:
        """The ``state`` message now (§6.10.6), ``body`` giving position, velocity, battery and loads."""
        graph = self._graph
        if graph is None or graph[0] != self.path.version:
            graph = self._graph = (
                self.path.version,
                tuple([NodeState(node_id=n.node_id, sequence_id=n.sequence_id, node_description=n.node_description,
                                 released=n.released) for n in self.path.nodes]),
                tuple([EdgeState(edge_id=e.edge_id, sequence_id=e.sequence_id, edge_description=e.edge_description,
                                 released=e.released) for e in self.path.edges]),
            )
        at = self._odometer_at_node
        since = max(0.0, body.where.odometer - at) if at is not None and self.last_node_id else None
        charge = 100.0 if body.battery is None else min(100.0, max(0.0, body.battery))
        battery = self._battery
        # equal floats are written alike here (max() above never gives -0.0); an int charge is built anew
        if battery is None or battery.battery_charge != charge or battery.charging is not self.charging \
                or charge.__class__ is not float:
            battery = self._battery = BatteryState(battery_charge=charge, charging=self.charging)
        return State(
            header=self.stamper.stamp("state", now),
            maps=self._maps(),
            order_id=self.order_id or "",
            order_update_id=self.order_update_id,
            zone_set_id=self.zone_set_id,
            last_node_id=self.last_node_id,
            last_node_sequence_id=self.last_node_sequence_id,
            node_states=graph[1],
            edge_states=graph[2],
            agv_position=self._position(body),
            velocity=Velocity(vx=body.vx, vy=body.vy, omega=body.omega),
            loads=body.loads,
            driving=self.driving,
            paused=self.paused,
            new_base_request=self.new_base_request,
            distance_since_last_node=since,
            action_states=self.actions.states(),
            battery_state=battery,
            operating_mode=OperatingMode.AUTOMATIC,
            errors=self.errors.listed(),
            safety_state=_FIELD if self.field_violation else _NO_FIELD,
        )

    def visualization(self, now: float, body: Body) -> Visualization:
        """§6.13: position and velocity only, at a rate of the integrator's choosing."""
        return Visualization(header=self.stamper.stamp("visualization", now), agv_position=self._position(body),
                             velocity=Velocity(vx=body.vx, vy=body.vy, omega=body.omega))

    def connection(self, now: float, state: ConnectionState) -> Connection:
        """§6.14: ONLINE when connected, OFFLINE before a graceful disconnect, CONNECTIONBROKEN as last will."""
        return Connection(header=self.stamper.stamp("connection", now), connection_state=state)

    def factsheet(self, now: float) -> Factsheet:
        return factsheet(self.config, self.stamper.stamp("factsheet", now))

    def _position(self, body: Body) -> AgvPosition:
        w = body.where
        return AgvPosition(x=w.x, y=w.y, theta=math.remainder(w.theta, math.tau), map_id=self.config.map_id,
                           position_initialized=True)

    def _maps(self) -> tuple[Map, ...] | None:
        """§6.7.2 (2.1.0 only): the vehicle's one map, enabled; worked out once per configuration."""
        config = self.config
        known = self._map_list
        if known is None or known[0] is not config:
            maps = _enabled(config.map_id, config.map_version) if config.version.at_least(Version.V2_1_0) else None
            known = self._map_list = (config, maps)
        return known[1]


@cache
def _enabled(map_id: str, map_version: str) -> tuple[Map, ...]:
    """The one map, enabled: the same (frozen) tuple for every state that lists it."""
    return (Map(map_id=map_id, map_version=map_version, map_status=MapStatus.ENABLED),)
