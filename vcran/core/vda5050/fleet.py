"""What a VDA 5050 master is told at the start (docs/contract.md §11, §9): the vehicles, the stations, the roadmap.

:class:`MasterFleet` is the master's counterpart of OPIL's ``vcran.Fleet`` with what a VDA 5050 master
needs besides: each vehicle's identity and capabilities (:class:`~vcran.core.vda5050.config.VehicleConfig`:
manufacturer, serialNumber, version, map, action catalogue; what its factsheet says) next to its body
(:class:`~vcran.core.scenario.RobotConfig`: start pose, speed, battery), and the layout's roadmap, on which
orders travel natively (docs/contract.md §12). Vehicles are named by serial number, as in the topics.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING

from vcran.core.traffic.paths import Graph
from vcran.core.traffic.roadmap import Roadmap
from vcran.core.vda5050.builder import Stop
from vcran.core.vda5050.config import STATE_INTERVAL, Physical, VehicleConfig
from vcran.core.vda5050.enums import Version
from vcran.core.vda5050.header import epoch_of

if TYPE_CHECKING:  # types only: VDA 5050 imports nothing of OPIL's, which the scenario module still does
    from vcran.core.scenario import LinkSettings, RobotConfig, Scenario, Settings, StationConfig


def vehicle_config(robot: RobotConfig, settings: Settings) -> VehicleConfig:
    """A robot's vehicle configuration: the identity and version a VDA 5050 scenario gives it, on the
    scenario's calendar (``settings.epoch``: the vehicles' headers, the master's and the connection
    topic's all read simulated time on it), publishing its state at least every ``settings.state_interval``
    (§6.10; unset: the configuration's 30 s); a robot without one (a layout of an OPIL scenario, in tests)
    is serial number its id, manufacturer its ``vendor``, version 2.1.0."""
    version = Version(robot.version) if robot.version is not None else Version.V2_1_0
    interval = STATE_INTERVAL if settings.state_interval is None else settings.state_interval
    return VehicleConfig(robot.manufacturer or robot.vendor, robot.serial_number or robot.id, version=version,
                         epoch=epoch_of(settings.epoch), state_interval=interval, physical=physical(robot))


def physical(robot: RobotConfig) -> Physical:
    """What the factsheet says of the robot's body (§6.15.1 physicalParameters, the footprint envelope): its speed
    and acceleration limits as the scenario gives them, so that a master planning with the factsheet plans with
    the body that drives. A deceleration of 0 is the acceleration's (docs/scenarios.md); an acceleration of 0
    (vcran's "changes speed at once") is sent as 0, the one number the schema allows for no limit
    (docs/vda5050.md). Width and length are the footprint's extent."""
    xs = [x for x, _ in robot.footprint]
    ys = [y for _, y in robot.footprint]
    return Physical(speed_max=robot.max_velocity, acceleration_max=robot.max_acceleration,
                    deceleration_max=robot.max_deceleration or robot.max_acceleration,
                    width=max(ys) - min(ys), length=max(xs) - min(xs), footprint=tuple(robot.footprint))


@dataclass(frozen=True, slots=True)
class Agv:
    """One vehicle of the fleet: its protocol identity and capabilities, and its body."""

    config: VehicleConfig
    robot: RobotConfig

    @property
    def serial_number(self) -> str:
        return self.config.serial_number

    def performs(self, action_type: str) -> bool:
        return self.config.action(action_type) is not None


@dataclass(frozen=True)
class MasterFleet:
    """The fleet as a master knows it; read-only. ``roadmap`` is None for a layout without lanes, where
    vehicles drive straight from point to point."""

    vehicles: tuple[Agv, ...]
    stations: tuple[StationConfig, ...]
    roadmap: Roadmap | None
    settings: Settings
    link: LinkSettings
    _vehicles: dict[str, Agv] = field(init=False, repr=False, compare=False)
    _stations: dict[str, StationConfig] = field(init=False, repr=False, compare=False)
    _graph: Graph | None = field(init=False, repr=False, compare=False)
    _headings: dict[str, float | None] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "_vehicles", {v.serial_number: v for v in self.vehicles})
        object.__setattr__(self, "_stations", {s.id: s for s in self.stations})
        object.__setattr__(self, "_graph", Graph(self.roadmap) if self.roadmap is not None else None)
        headings: dict[str, float | None] = {}  # dock node -> the heading to end in there (the first station's)
        if self.roadmap is not None:
            for s in self.stations:
                x, y, theta = self.dock(s.id)
                node = s.dock_node or next((n.id for n in self.roadmap.nodes if n.x == x and n.y == y), None)
                if node is not None:
                    headings.setdefault(node, theta)
        object.__setattr__(self, "_headings", headings)

    @classmethod
    def of(cls, scenario: Scenario, configs: Sequence[VehicleConfig] | None = None) -> MasterFleet:
        """The scenario's fleet, each robot paired with its vehicle configuration (in fleet order); without
        ``configs``, :func:`vehicle_config`'s. The settings are a copy: a master that writes to its
        ``durations`` changes nothing of the run."""
        if configs is None:
            configs = [vehicle_config(r, scenario.settings) for r in scenario.robots]
        if len(configs) != len(scenario.robots):
            raise ValueError(f"{len(configs)} vehicle configurations for {len(scenario.robots)} robots")
        settings = replace(scenario.settings, durations=dict(scenario.settings.durations))
        return cls(tuple(Agv(c, r) for c, r in zip(configs, scenario.robots)), scenario.stations,
                   scenario.roadmap, settings, scenario.link)

    @property
    def serials(self) -> tuple[str, ...]:
        return tuple(self._vehicles)

    @property
    def graph(self) -> Graph | None:
        """The roadmap ready for routing (:meth:`vcran.core.traffic.paths.Graph.route`), or None."""
        return self._graph

    def vehicle(self, serial: str) -> Agv:
        try:
            return self._vehicles[serial]
        except KeyError:
            raise KeyError(f"no vehicle {serial!r} in this fleet") from None

    def station(self, station_id: str) -> StationConfig:
        try:
            return self._stations[station_id]
        except KeyError:
            raise KeyError(f"no station {station_id!r} in this fleet") from None

    def chargers(self) -> tuple[str, ...]:
        return tuple(s.id for s in self.stations if s.charger)

    def dock(self, station_id: str) -> tuple[float, float, float | None]:
        """Where a vehicle stands to work at a station: its ``dock``, else its position."""
        s = self.station(station_id)
        return s.dock if s.dock is not None else (s.position[0], s.position[1], None)

    def dock_node(self, station_id: str) -> str | None:
        """The roadmap node of the station's dock (None without a roadmap)."""
        s = self.station(station_id)
        if self.roadmap is None:
            return None
        if s.dock_node is not None:
            return s.dock_node
        x, y, _ = self.dock(station_id)
        node = self.roadmap.node_at(x, y)
        if node is None:  # the scenario loader refuses such a layout (roadmap.validate); a layout built in code may not
            raise ValueError(f"station {station_id!r}: its dock ({x:g}, {y:g}) is no node of the roadmap")
        return node.id

    def node_at(self, x: float, y: float, tolerance: float = 0.0) -> str | None:
        """The first roadmap node within ``tolerance`` metres of ``(x, y)`` (in file order), or None."""
        if self.roadmap is None:
            return None
        return next((n.id for n in self.roadmap.nodes if math.hypot(n.x - x, n.y - y) <= tolerance), None)

    def stops(self, route: Sequence[str | Stop]) -> list[Stop]:
        """A route as stops: roadmap node ids looked up (a station's dock node ends facing the dock's theta,
        and carries the speed limit of the roadmap edge leading to it from the node before), ``Stop``\\ s
        as they are."""
        graph = self._graph
        out = []
        for i, item in enumerate(route):
            if isinstance(item, Stop):
                out.append(item)
                continue
            if graph is None:
                raise ValueError(f"node {item!r}: the layout has no roadmap")
            node = graph.nodes.get(item)
            if node is None:
                raise KeyError(f"no node {item!r} in the roadmap")
            speed = None
            before = route[i - 1] if i else None
            if isinstance(before, str):
                arc = next((a for a in graph.arcs[before] if a.target == item), None)
                if arc is None:
                    raise ValueError(f"no edge from {before!r} to {item!r} in the roadmap")
                speed = arc.speed
            out.append(Stop(item, node.x, node.y, self._headings.get(item), max_speed=speed))
        return out
