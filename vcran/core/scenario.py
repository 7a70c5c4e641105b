"""The scenario data model: the fleet, the stations, the settings and the fleet manager's message script.

A scenario is plain data; the model builds the running objects from it, so one scenario can run any number
of times (fuzzing, determinism tests). Reading and writing scenario files (TOML) is :mod:`vcran.io`'s part:
:mod:`vcran.io.scenario_file` loads them strictly, :mod:`vcran.io.scenario_toml` writes them back.
"""

from __future__ import annotations

import heapq
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

from vcran.core import build
from vcran.core.battery import BatteryConfig
from vcran.core.faults import FaultSpec, RandomFaults
from vcran.core.messages import ActionKind, Message

#: The actions a scenario names and configures (OPIL's and the seed's); ``charge`` (a vcran extension)
#: is not among them: a robot can charge exactly when it has a battery.
ACTION_KINDS = tuple(k.value for k in ActionKind if k is not ActionKind.CHARGE)
#: ``collisions =`` (SPEC §4): "report" (default), "stop", or "off" (no detection at all).
COLLISION_MODES = ("report", "stop", "off")


@dataclass(frozen=True, slots=True)
class Settings:
    name: str = "scenario"
    seed: int = 0
    duration: float | None = None
    until_idle: bool = False
    task_timeout: float = 30.0
    history_limit: int = 10_000
    telemetry_period: float = 1.0
    description_period: float = 60.0
    entity_type: str = "ROBOT"
    durations: dict[str, float] = field(default_factory=lambda: {"dummy": 1.0, "load": 5.0, "unload": 5.0})
    collisions: str = "report"
    #: Footprints are compared at least every this many metres of any point's travel (docs/robots.md).
    collision_resolution: float = 0.05


@dataclass(frozen=True, slots=True)
class RobotConfig:
    id: str
    pose: tuple[float, float, float] = (0.0, 0.0, 0.0)
    max_velocity: float = 1.0
    max_acceleration: float = 0.0
    max_deceleration: float = 0.0
    max_angular_velocity: float = 0.0
    footprint: tuple[tuple[float, float], ...] = ((0.27, 0.35), (-0.87, 0.35), (-0.87, -0.35), (0.27, -0.35))
    actions: tuple[str, ...] = ACTION_KINDS
    capacity: int = 1
    carrying: int = 0
    vendor: str = "vcran"
    battery: BatteryConfig | None = None


@dataclass(frozen=True, slots=True)
class StationConfig:
    id: str
    position: tuple[float, float]
    reach: float = 1.0
    area: tuple[tuple[float, float], ...] = ()
    parts: int = 0
    capacity: int = 1_000_000
    produce_every: float = 0.0
    produce_start: float | None = None
    produce_limit: int = 0
    #: A charging point: ``charge`` actions in its reach refill the battery (SPEC §4).
    charger: bool = False


@dataclass(frozen=True, slots=True)
class ScriptEntry:
    """One message of the script: at ``t``, ``attribute`` of ``robot`` becomes ``message`` (or ``raw``)."""

    t: float
    robot: str
    attribute: str
    message: Message | None = None
    #: An NGSI attribute as JSON, decoded by the RAN like a live one: how scripts exercise R12.
    raw: Any = None


@dataclass(frozen=True, slots=True)
class TaskSpec:
    """One task of a cycle: its path (points ``(x, y, theta or None)``) and its actions."""

    path: tuple[tuple[float, float, float | None], ...]
    actions: tuple[str, ...]


@dataclass(frozen=True, slots=True)
class Cycle:
    """A task cycle sent again and again: every ``every`` seconds from ``t`` while before ``until``.

    Long fleet runs (``vcran gen``) describe hours of work in a few lines this way; the entries are
    expanded lazily, so memory does not grow with the run length. Repetition ``k`` names its tasks
    ``{prefix}_{k}_{i}`` (i counts the cycle's tasks from 1).
    """

    t: float
    robot: str
    every: float
    until: float
    prefix: str
    tasks: tuple[TaskSpec, ...]
    max_velocity: float = 0.0

    def entries(self) -> Iterator[ScriptEntry]:
        k = 0
        while True:
            start = self.t + k * self.every
            if start >= self.until:
                return
            for i, spec in enumerate(self.tasks, start=1):
                yield from task_entries(start, self.robot, f"{self.prefix}_{k}_{i}", spec, 0.0, self.max_velocity)
            k += 1


@dataclass(frozen=True, slots=True)
class Scenario:
    settings: Settings
    robots: tuple[RobotConfig, ...]
    stations: tuple[StationConfig, ...]
    script: tuple[ScriptEntry, ...]
    source: str = "<scenario>"
    cycles: tuple[Cycle, ...] = ()
    #: Injected faults at given times (``[[faults]]``) and the seeded random source (``[random_faults]``).
    faults: tuple[FaultSpec, ...] = ()
    random_faults: tuple[RandomFaults, ...] = ()

    def messages(self) -> Iterator[ScriptEntry]:
        """The whole script in time order, cycles expanded lazily; equal times keep file order."""
        if not self.cycles:
            return iter(self.script)
        streams = [iter(self.script), *(c.entries() for c in self.cycles)]
        return heapq.merge(*streams, key=lambda e: e.t)

    def fleet_dict(self) -> dict[str, Any]:
        """Everything but the script, as JSON that :func:`vcran.io.scenario_file.parse` reads back: a trace header carries it."""
        s = self.settings
        # Keys added with §4 appear only when set, so older scenarios keep their exact trace header.
        return _drop_none({
            "simulation": {
                "name": s.name, "seed": s.seed, "duration": s.duration, "until_idle": s.until_idle,
                "task_timeout": s.task_timeout, "history_limit": s.history_limit,
                "telemetry_period": s.telemetry_period, "description_period": s.description_period,
                "entity_type": s.entity_type, "action_durations": dict(s.durations),
                "collisions": s.collisions if s.collisions != "report" else None,
                "collision_resolution": s.collision_resolution if s.collision_resolution != 0.05 else None,
            },
            "robots": [
                {
                    "id": r.id, "pose": list(r.pose), "max_velocity": r.max_velocity,
                    "max_acceleration": r.max_acceleration, "max_deceleration": r.max_deceleration,
                    "max_angular_velocity": r.max_angular_velocity, "footprint": [list(p) for p in r.footprint],
                    "actions": list(r.actions), "capacity": r.capacity, "carrying": r.carrying, "vendor": r.vendor,
                    "battery": _battery_dict(r.battery),
                }
                for r in self.robots
            ],
            "stations": [
                {
                    "id": st.id, "position": list(st.position), "reach": st.reach,
                    "area": [list(p) for p in st.area], "parts": st.parts, "capacity": st.capacity,
                    "produce_every": st.produce_every, "produce_start": st.produce_start,
                    "produce_limit": st.produce_limit, "charger": True if st.charger else None,
                }
                for st in self.stations
            ],
            "faults": [f.as_dict() for f in self.faults] or None,
            "random_faults": [r.as_dict() for r in self.random_faults] or None,
        })


def _battery_dict(b: BatteryConfig | None) -> dict[str, Any] | None:
    if b is None:
        return None
    return {name: getattr(b, name) for name in BatteryConfig.__dataclass_fields__}


def _drop_none(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: _drop_none(v) for k, v in value.items() if v is not None}
    if isinstance(value, list):
        return [_drop_none(v) for v in value]
    return value


def task_entries(time: float, robot: str, task: str, spec: TaskSpec, every: float, speed: float) -> Iterator[ScriptEntry]:
    """The messages of one task: motions ``{task}_m{i}`` then actions ``{task}_a{j}``, ``every`` apart.

    Only the last point's theta is used (with use_orientation); intermediate points are passed through.
    """
    length = len(spec.path) + len(spec.actions)
    for i, (x, y, theta) in enumerate(spec.path, start=1):
        at = time + (i - 1) * every
        last_with_theta = i == len(spec.path) and theta is not None
        m = build.motion(task, f"{task}_m{i}", i, length, x, y, theta or 0.0, use_orientation=last_with_theta,
                         is_waypoint=i < len(spec.path), max_velocity=speed, stamp=at)
        yield ScriptEntry(at, robot, "motion_assignment", m)
    for j, kind in enumerate(spec.actions, start=1):
        pos = len(spec.path) + j
        yield ScriptEntry(time + (pos - 1) * every, robot, "action_assignment", build.action(task, f"{task}_a{j}", pos, length, kind))

