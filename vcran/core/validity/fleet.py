"""The rules of a scenario's settings, robots (with their batteries) and stations (issue 30 item 3).

Each part has its fields' rules (a mapping keyed as a file names the fields, in the order a file's reader
reads them) and a function for what relates its fields: a robot carrying no more than it can hold, a dock
within its station's reach. A rule for a new robot field (a protocol's vehicle fields) is one entry in
:data:`ROBOT`, and one read of the key in the scenario file's reader.
"""

from __future__ import annotations

import math
from typing import Any

from vcran.core.battery import BatteryConfig
from vcran.core.epoch import epoch_problem
from vcran.core.orion_rules import identifier_error
from vcran.core.polygon import covers, polygon_problem
from vcran.core.scenario import (
    ACTION_KINDS,
    COLLISION_MODES,
    PROTOCOLS,
    VDA5050_STATE_INTERVAL,
    VDA5050_VERSIONS,
    RobotConfig,
    Settings,
    StationConfig,
)
from vcran.core.validity.fields import (
    Choices,
    Flag,
    Integer,
    Number,
    OneOf,
    Problem,
    Rule,
    Shape,
    Text,
    fields,
    pair_problem,
    place_problem,
    points_problem,
    shown,
    triple_problem,
)


def _entity_type(v: str) -> str | None:
    return identifier_error("entity type", v)


def _collision_mode(v: str) -> str | None:
    if v in COLLISION_MODES:
        return None
    return f"expected one of {', '.join(map(repr, COLLISION_MODES))}, got {v!r}"


def _state_interval(v: float) -> str | None:
    if v > VDA5050_STATE_INTERVAL:
        return (f"must be at most {VDA5050_STATE_INTERVAL:g} seconds, got {v} (VDA 5050 §6.10: a state \"at the "
                f"latest every 30s\")")
    return None


SETTINGS: dict[str, Rule] = {
    "name": Text(),
    "seed": Integer(),
    "duration": Number(minimum=0.0, absent=None),
    "until_idle": Flag(),
    "task_timeout": Number(positive=True),
    "history_limit": Integer(minimum=1),
    "telemetry_period": Number(positive=True),
    "description_period": Number(positive=True),
    "entity_type": Text(then=_entity_type),
    "collisions": Text(then=_collision_mode),
    "collision_resolution": Number(positive=True),
    "protocol": OneOf(PROTOCOLS, "protocol"),
    "epoch": Text(absent=None, then=epoch_problem),
    "state_interval": Number(positive=True, absent=None, then=_state_interval),
}
#: ``[simulation.action_durations]``: seconds per action (the model's :attr:`Settings.durations`); the optional
#: ``fine_positioning`` is a VDA 5050 vehicle's finePositioning (absent: it takes no time, docs/vda5050.md).
FINE_POSITIONING = "fine_positioning"
ACTION_DURATIONS: dict[str, Rule] = {kind: Number(minimum=0.0) for kind in (*ACTION_KINDS, FINE_POSITIONING)}


def _robot_id(v: str) -> str | None:
    problem = identifier_error("entity id", v)
    return f"{problem}: robot ids are Orion entity ids" if problem else None


def _footprint(v: Any) -> str | None:
    problem = polygon_problem(v) if v else None  # [] is no footprint: it never touches
    return f"{problem} (docs/contract.md §4: a footprint is a simple polygon)" if problem else None


#: ``charge`` is an action a script sends, not one a robot lists: it has a battery or not.
_CHARGE = ("'charge' is not listed among a robot's actions: a robot with [robots.battery] can charge "
           f"(docs/contract.md §4, docs/robots.md); the actions listed here are {', '.join(ACTION_KINDS)}")

#: What an MQTT topic level cannot hold: the separator, the wildcards, ``$`` (topics of the broker's own),
#: NUL. A VDA 5050 vehicle's identity is three levels of its topics (§6.3).
TOPIC_LEVEL_FORBIDDEN = "/+#$\0"


def _topic_level(v: str) -> str | None:
    bad = [c if c != "\0" else "NUL" for c in TOPIC_LEVEL_FORBIDDEN if c in v]
    if bad:
        return (f"contains {' '.join(bad)}, which an MQTT topic level cannot hold (VDA 5050 §6.3: it names the "
                "vehicle's topics)")
    return None


#: A VDA 5050 vehicle's identity (docs/contract.md §11): required or refused by the scenario's protocol
#: (:func:`vcran.core.validity.protocol.vehicle_problems`), so absent (None) here.
VEHICLE: dict[str, Rule] = {
    "manufacturer": Text(absent=None, then=_topic_level),
    "serial_number": Text(absent=None, then=_topic_level),
    "interface_name": Text(absent=None, then=_topic_level),
    "version": OneOf(VDA5050_VERSIONS, "VDA 5050 version", absent=None),
}

ROBOT: dict[str, Rule] = {
    "id": Text(then=_robot_id),
    "max_acceleration": Number(minimum=0.0),
    "actions": Choices(ACTION_KINDS, "action", hints={"charge": _CHARGE}),
    "footprint": Shape(points_problem, then=_footprint),
    "pose": Shape(triple_problem),
    "max_velocity": Number(positive=True),
    "max_deceleration": Number(minimum=0.0),
    "max_angular_velocity": Number(minimum=0.0),
    "capacity": Integer(minimum=0),
    "carrying": Integer(minimum=0),
    "vendor": Text(publishable=True),
    **VEHICLE,
}


def _below_one(v: float) -> str | None:
    return f"a fraction of capacity below 1 is needed, got {v}" if v >= 1.0 else None


def _up_to_one(v: float) -> str | None:
    return f"a fraction of capacity up to 1 is needed, got {v}" if v > 1.0 else None


BATTERY: dict[str, Rule] = {
    "capacity": Number(positive=True),
    "initial": Number(minimum=0.0, absent=None),
    "per_metre": Number(minimum=0.0),
    "per_action_second": Number(minimum=0.0),
    "per_idle_second": Number(minimum=0.0),
    "charge_rate": Number(minimum=0.0),
    "low": Number(minimum=0.0, then=_below_one),
    "swap_after": Number(minimum=0.0, absent=None),
    "voltage": Number(positive=True),
    "resolution": Number(positive=True, then=_up_to_one),
}


def _area(v: Any) -> str | None:
    problem = polygon_problem(v) if v else None
    return f"{problem} (a station's area is a simple polygon)" if problem else None


STATION: dict[str, Rule] = {
    "area": Shape(points_problem, then=_area),
    "dock": Shape(place_problem, absent=None),
    "id": Text(),
    "position": Shape(pair_problem),
    "reach": Number(positive=True),
    "parts": Integer(minimum=0),
    "capacity": Integer(minimum=0),
    "produce_every": Number(minimum=0.0),
    "produce_start": Number(minimum=0.0, absent=None),
    "produce_limit": Integer(minimum=0),
    "charger": Flag(),
}


def settings_problems(s: Any, fields_too: bool = True) -> list[Problem]:
    if not isinstance(s, Settings):
        return [Problem("simulation", f"expected a Settings, got {type(s).__name__}")]
    if not fields_too:
        return []
    out = fields(s, "simulation", SETTINGS)
    durations = s.durations
    if not isinstance(durations, dict):
        return [*out, Problem("simulation.action_durations", f"expected a table of seconds, got {shown(durations)!r}")]
    for kind, rule in ACTION_DURATIONS.items():
        if kind == FINE_POSITIONING and kind not in durations:
            continue
        problem = rule.check(durations[kind]) if kind in durations else "missing"
        if problem:
            out.append(Problem(f"simulation.action_durations.{kind}", problem))
    out += [Problem(f"simulation.action_durations.{k}", "unknown key (a typo?)") for k in durations
            if k not in ACTION_DURATIONS]
    return out


def robot_problems(r: Any, i: int, fields_too: bool = True) -> list[Problem]:
    """Robot ``i``'s problems: its fields, its battery's, then a load within its capacity."""
    where = f"robots[{i}]"
    if not isinstance(r, RobotConfig):
        return [Problem(where, f"expected a RobotConfig, got {type(r).__name__}")]
    out = fields(r, where, ROBOT) if fields_too else []
    b = r.battery
    if b is not None and not isinstance(b, BatteryConfig):
        out.append(Problem(f"{where}.battery", f"expected a BatteryConfig or None, got {type(b).__name__}"))
    elif b is not None:
        battery = fields(b, f"{where}.battery", BATTERY) if fields_too else []
        if not battery and b.initial is not None and b.initial > b.capacity:
            battery.append(Problem(f"{where}.battery.initial", f"{b.initial} exceeds capacity {b.capacity}"))
        out += battery
    if out:
        return out
    if r.carrying > r.capacity:
        out.append(Problem(f"{where}.carrying", f"{r.carrying} exceeds capacity {r.capacity}"))
    return out


def station_problems(s: Any, i: int, fields_too: bool = True) -> list[Problem]:
    """Station ``i``'s problems: its fields, then parts within its capacity and a dock within its reach."""
    where = f"stations[{i}]"
    if not isinstance(s, StationConfig):
        return [Problem(where, f"expected a StationConfig, got {type(s).__name__}")]
    out = fields(s, where, STATION, skip=("dock",)) + _dock_fields(s, where) if fields_too else []
    if out:
        return out
    if s.parts > s.capacity:
        return [Problem(f"{where}.parts", f"{s.parts} exceeds capacity {s.capacity}")]
    problem = _dock_problem(s)
    return [Problem(f"{where}.dock", problem)] if problem else []


def _dock_fields(s: StationConfig, where: str) -> list[Problem]:
    """A file's ``dock`` is a point or a roadmap node's id; the model holds the point in ``dock`` (the node's
    position for a named node) and the name in ``dock_node``."""
    if isinstance(s.dock, str):
        return [Problem(f"{where}.dock", f"a roadmap node's id goes in dock_node, got dock = {s.dock!r}")]
    problem = place_problem(s.dock) if s.dock is not None else None
    if problem is None and s.dock_node is not None and not (isinstance(s.dock_node, str) and s.dock_node):
        problem = place_problem(s.dock_node)
    return [Problem(f"{where}.dock", problem)] if problem else []


def _dock_problem(s: StationConfig) -> str | None:
    """The dock is where a robot stands to load or unload (or charge) at the station: one beyond its reach
    made every such action there fail, robot after robot. Decided as the station decides reach
    (:meth:`vcran.core.stations.Station.within_reach`): the area polygon, outline included, else the circle."""
    if s.dock is None:
        return None
    x, y = s.dock[0], s.dock[1]
    where = f"[{x:g}, {y:g}]"
    if s.area:
        if not covers(s.area, x, y):
            return f"{where} is outside the station's area: a robot standing there cannot load or unload"
    elif (d := math.hypot(s.position[0] - x, s.position[1] - y)) > s.reach:
        return (f"{where} is {d:g} m from the station's position [{s.position[0]:g}, {s.position[1]:g}], "
                f"beyond its reach {s.reach:g}: a robot standing there cannot load or unload")
    return None
