"""The scenario data model: the fleet, the stations, the settings, and what plays the fleet manager's part.

A scenario is plain data; the model builds the running objects from it, so one scenario can run any number
of times (fuzzing, determinism tests). The fleet manager's part is either a message script (the original VC-RAN's
JMeter file) or, in a closed loop (docs/contract.md §9), a workload of jobs for a fleet manager, the link between
that manager and the RAN, and which manager to run. Reading and writing scenario files (TOML) is
:mod:`vcran.io`'s part: :mod:`vcran.io.scenario_file` loads them strictly, :mod:`vcran.io.scenario_toml`
writes them back. A scenario speaks one protocol (``Settings.protocol``): OPIL, or VDA 5050, whose robots
carry a vehicle's identity and whose script sends VDA 5050 messages (docs/contract.md §11).

One concept, over 450 lines: the scenario as data, every part a frozen record the others refer to (the
script's lazy expansion with it, since it is what :meth:`Scenario.messages` returns); its rules are
:mod:`vcran.core.validity`'s.
"""

from __future__ import annotations

import heapq
import random
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from itertools import groupby
from typing import TYPE_CHECKING, Any

from vcran.core.battery import BatteryConfig
from vcran.core.faults import FaultSpec, RandomFaults
from vcran.core.opil import build
from vcran.core.opil.messages import ActionKind, Message, MotionAssignment
from vcran.core.slots import slot_init, unchecked
from vcran.core.traffic.fields import FieldSpec
from vcran.core.traffic.roadmap import Roadmap
from vcran.core.traffic.settings import TrafficSettings
from vcran.core.wire import Inbound

if TYPE_CHECKING:  # types only: the shared model imports no protocol package
    from vcran.core.vda5050.order import InstantActions, Order

    VdaMessage = Order | InstantActions

#: The actions a scenario names and configures (OPIL's and the original VC-RAN's); ``charge`` (a vcran extension)
#: is not among them: a robot can charge exactly when it has a battery.
ACTION_KINDS = tuple(k.value for k in ActionKind if k is not ActionKind.CHARGE)
#: ``collisions =`` (docs/contract.md §4): "report" (default), "stop", or "off" (no detection at all).
COLLISION_MODES = ("report", "stop", "off")
#: ``[simulation] protocol``: what the robots speak with their fleet manager, OPIL (docs/contract.md §2, the default) or
#: VDA 5050 (docs/contract.md §11).
OPIL, VDA5050 = "opil", "vda5050"
PROTOCOLS = (OPIL, VDA5050)
#: The VDA 5050 versions a vehicle may speak (its ``version``; docs/vda5050.md, "Versions").
VDA5050_VERSIONS = ("2.1.0", "2.0.0")
#: A VDA 5050 vehicle's ``interface_name`` unless it says otherwise (§6.3: "uagv").
INTERFACE_NAME = "uagv"
#: The topics a VDA 5050 script sends on (a script entry's ``attribute``).
VDA5050_TOPICS = ("order", "instantActions")
#: The longest a VDA 5050 vehicle goes without publishing its state (§6.10: "at the latest every 30s"), the
#: default and the upper bound of ``[simulation] state_interval``.
VDA5050_STATE_INTERVAL = 30.0


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
    #: What the robots speak: :data:`OPIL` or :data:`VDA5050` (docs/scenarios.md, "VDA 5050 vehicles").
    protocol: str = OPIL
    #: Where simulated time 0 falls on the calendar of a VDA 5050 scenario's headers, as ISO 8601 UTC text
    #: (``[simulation] epoch``, :mod:`vcran.core.epoch`); None: the protocol's default, 1970-01-01T00:00:00Z.
    epoch: str | None = None
    #: A VDA 5050 vehicle's state at least this often, seconds (``[simulation] state_interval``, at most
    #: :data:`VDA5050_STATE_INTERVAL`); None: the protocol's default, that same 30 s.
    state_interval: float | None = None


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
    #: The robot's protective field (docs/contract.md §12, ``[robots.field]``); None: the fleet's (``[traffic] field``).
    field: FieldSpec | None = None
    #: A VDA 5050 vehicle's identity (docs/contract.md §11; §6.3's topic levels and headers): required in a VDA 5050
    #: scenario, refused in an OPIL one. None: not given; ``interface_name`` then is :data:`INTERFACE_NAME`,
    #: ``version`` the first of :data:`VDA5050_VERSIONS` (:meth:`vda5050_identity`).
    manufacturer: str | None = None
    serial_number: str | None = None
    interface_name: str | None = None
    version: str | None = None

    @property
    def vda5050_identity(self) -> tuple[str, str, str, str]:
        """``(interface_name, manufacturer, serial_number, version)`` with the defaults filled in (the
        manufacturer and serial number, which have none, as given: a VDA 5050 scenario has them)."""
        return (self.interface_name or INTERFACE_NAME, self.manufacturer or "", self.serial_number or "",
                self.version or VDA5050_VERSIONS[0])

    @property
    def moves_parts(self) -> bool:
        """Configured for a transport job (docs/contract.md §9): to ``load`` and ``unload``, with room for a part."""
        return "load" in self.actions and "unload" in self.actions and self.capacity >= 1


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
    #: A charging point: ``charge`` actions in its reach refill the battery (docs/contract.md §4).
    charger: bool = False
    #: Where a robot stands to load or unload here, ``(x, y, theta)``; theta None: any heading. A fleet
    #: manager reads it to plan paths (:meth:`vcran.core.manager.Fleet.dock`); None means the position.
    dock: tuple[float, float, float | None] | None = None
    #: The roadmap node the dock is (docs/contract.md §12: ``dock = "id"`` in a file); ``dock`` then holds its position.
    dock_node: str | None = None


@slot_init
@dataclass(frozen=True, slots=True)
class ScriptEntry:
    """One message of the script: at ``t``, ``attribute`` of ``robot`` becomes ``message`` (or ``raw``).

    In a VDA 5050 scenario ``attribute`` is the topic (``order``, ``instantActions``), ``message`` the
    :class:`~vcran.core.vda5050.order.Order` or :class:`~vcran.core.vda5050.order.InstantActions` with its
    header, and ``raw`` a payload text sent as it is (a master's bad message: the vehicle refuses it).
    """

    t: float
    robot: str
    attribute: str
    message: Message | VdaMessage | None = None
    #: An NGSI attribute as JSON, decoded by the RAN like a live one: how scripts exercise R12.
    raw: Any = None
    #: The JSON text ``message`` was decoded from (a VDA 5050 script's stamped message), which its trace
    #: record is (:class:`~vcran.core.wire.Inbound`'s ``wire``); None: encoded from ``message`` when written.
    wire: bytes | None = field(default=None, compare=False, repr=False)


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


class _Repetitions:
    """One cycle's repetitions, each built when it is due.

    The first repetition is built and checked; the others differ from it only in names and times, so
    they are its messages built again under new names (:class:`vcran.core.opil.build.RepeatedTasks`), one
    header per repetition, not built field by field.
    """

    __slots__ = ("cycle", "_first", "_again", "_attributes")

    def __init__(self, cycle: Cycle) -> None:
        self.cycle = cycle
        first = [build.task(f"{cycle.prefix}_0_{i}", spec.path, spec.actions, max_velocity=cycle.max_velocity,
                            stamp=cycle.t) for i, spec in enumerate(cycle.tasks, start=1)]
        self._first = [message for messages in first for message in messages]
        self._again = build.RepeatedTasks(first)
        self._attributes = [_attribute(message) for message in self._first]

    def time(self, k: int) -> float | None:
        """When repetition ``k`` (from 1: the first is due at the cycle's very ``t``) is due, None if
        not before the cycle's end."""
        c = self.cycle
        start = c.t + k * c.every
        return start if start < c.until else None

    def inbound(self, k: int, start: float) -> list[Inbound]:
        """Repetition ``k``'s messages as the inbound records delivered at its time ``start``."""
        c = self.cycle
        if k == 0:
            messages = self._first
        else:
            names = [f"{c.prefix}_{k}_{i}" for i in range(1, len(c.tasks) + 1)]
            messages = self._again.build(names, build.header_at(start))
        robot = c.robot
        return [_inbound(robot, attribute, message) for attribute, message in zip(self._attributes, messages)]


class Script(Iterator[ScriptEntry]):
    """What :meth:`Scenario.messages` returns: the script's entries in time order and, for a transport,
    the same script in runs of one time as the inbound records it delivers (:meth:`runs`).

    A scripted run turns every entry into an :class:`Inbound`; built as those directly, a cycle's
    messages are one small object each, not an entry and then a record copied from it (and the
    transport compares one time per run, not per message). Read a script one way or the other,
    not both: the two share one lazy expansion.
    """

    __slots__ = ("_runs", "_entries")

    def __init__(self, runs: Iterator[tuple[float, Iterable[Inbound]]]) -> None:
        self._runs = runs
        self._entries = (_entry(t, i.entity, i.attribute, i.message, i.raw, i.wire) for t, run in runs for i in run)

    @classmethod
    def of(cls, entries: Iterable[ScriptEntry]) -> Script:
        """Any entries in time order as a script; an entry is pulled from ``entries`` once the one before
        it was delivered, as a transport consumes a script lazily."""
        return cls((t, (_inbound(e.robot, e.attribute, e.message, e.raw, e.wire) for e in run))
                   for t, run in groupby(entries, key=_time))

    def __next__(self) -> ScriptEntry:
        return next(self._entries)

    def runs(self) -> Iterator[tuple[float, Iterable[Inbound]]]:
        """The script's runs of entries of one time, as ``(time, inbound records)`` in order (runs in
        a row may share a time: the script's and each cycle's are separate)."""
        return self._runs


#: Entries and inbound records built from checked parts: the dataclass constructors without the class call.
_entry = unchecked(ScriptEntry)
_inbound = unchecked(Inbound)


# --- the closed loop (docs/contract.md §9): jobs, the link, the manager ----------------------------------------------


@dataclass(frozen=True, slots=True)
class Job:
    """A transport job: move a part from station ``pickup`` to station ``dropoff``.

    It reaches the fleet manager (never a robot) at ``t``. ``priority`` (higher first) and ``deadline``
    (an absolute simulated time, or None) are for the manager to use; vcran only reports lateness.
    """

    t: float
    id: str
    pickup: str
    dropoff: str
    priority: int = 0
    deadline: float | None = None


@dataclass(frozen=True, slots=True)
class JobStream:
    """Jobs generated by a seeded Poisson process: ``rate`` jobs per hour, exponential gaps of mean
    ``mean_interval`` = 3600 / ``rate`` seconds. ``rate`` is the scenario file's ``[job_stream] rate`` and a
    sweep's ``job_stream.rate`` (issue 29 item 13: the field was ``mean_interval``, the key ``rate``); a
    file's ``mean_interval`` loads as ``rate = 3600 / mean_interval``.

    Each job's pickup is drawn from ``pickups`` and its drop-off from ``dropoffs`` without the pickup,
    by weight; the ``n``-th job is named ``{prefix}_{n}`` (from 1). The stream draws from its own
    ``random.Random("job_stream:{seed}")`` (``seed`` defaults to the scenario's), so the same seed gives
    the same jobs on every machine and Python version, and no other draw of the run can shift them.
    """

    rate: float
    pickups: tuple[tuple[str, float], ...]
    dropoffs: tuple[tuple[str, float], ...]
    until: float
    seed: int
    start: float = 0.0
    prefix: str = "job"
    priority: int = 0
    deadline_after: float | None = None

    @property
    def mean_interval(self) -> float:
        """Seconds between arrivals on average: 3600 / ``rate``."""
        return 3600.0 / self.rate

    def jobs(self) -> Iterator[Job]:
        rng = random.Random(f"job_stream:{self.seed}")
        names, weights = [p for p, _ in self.pickups], [w for _, w in self.pickups]
        t, n = self.start, 0
        while True:
            t += rng.expovariate(1.0 / self.mean_interval)
            if t >= self.until:
                return
            n += 1
            pickup = rng.choices(names, weights)[0]
            choices = [(d, w) for d, w in self.dropoffs if d != pickup]
            dropoff = rng.choices([d for d, _ in choices], [w for _, w in choices])[0]
            deadline = t + self.deadline_after if self.deadline_after is not None else None
            yield Job(t, f"{self.prefix}_{n}", pickup, dropoff, self.priority, deadline)


#: How the RAN learns what the fleet manager wrote (docs/contract.md §7, §9).
SUBSCRIPTION, POLLING = "subscription", "polling"


@dataclass(frozen=True, slots=True)
class LinkSettings:
    """The link between a fleet manager and the RAN, standing for Orion (docs/contract.md §9, docs/loop.md).

    Every message takes ``latency`` plus a uniform draw from ``[0, jitter)`` seconds, in order per
    robot and direction. With ``inbound = "subscription"`` every change of an attribute reaches the RAN;
    with ``"polling"`` the RAN reads what Orion holds every ``poll_interval`` seconds, so a write that
    is overwritten before the next read is lost. ``loss`` is the probability that one message is lost on
    its way, each direction, drawn from the link's seed: VDA 5050's link only (MQTT's QoS 0, §6.2; an OPIL
    scenario refuses it, docs/loop.md).
    """

    latency: float = 0.05
    jitter: float = 0.0
    inbound: str = SUBSCRIPTION
    poll_interval: float = 0.25
    loss: float = 0.0

    def as_dict(self) -> dict[str, Any]:
        """The settings as a scenario file writes them; ``loss`` only when there is some (a run without loss
        writes the header it always wrote)."""
        out: dict[str, Any] = {"latency": self.latency, "jitter": self.jitter, "inbound": self.inbound,
                               "poll_interval": self.poll_interval}
        if self.loss:
            out["loss"] = self.loss
        return out


@dataclass(frozen=True, slots=True)
class ManagerSpec:
    """Which fleet manager runs a scenario: ``"module:Class"``, built with ``options`` as keywords."""

    path: str
    options: tuple[tuple[str, Any], ...] = ()


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
    jobs: tuple[Job, ...] = ()
    job_stream: JobStream | None = None
    link: LinkSettings = field(default_factory=LinkSettings)
    manager: ManagerSpec | None = None
    #: The lanes robots may drive (docs/contract.md §12); None: robots drive anywhere.
    roadmap: Roadmap | None = None
    #: Safety fields and deadlocks (docs/contract.md §12); the default has none.
    traffic: TrafficSettings = field(default_factory=TrafficSettings)

    def messages(self) -> Script:
        """The whole script in time order, cycles expanded lazily; equal times keep file order."""
        return Script(_merged(self.script, self.cycles))

    @property
    def has_workload(self) -> bool:
        """Jobs listed or generated: the scenario is meant for a fleet manager (docs/contract.md §9)."""
        return bool(self.jobs) or self.job_stream is not None

    def workload(self) -> Iterator[Job]:
        """Every job in arrival order, the stream generated lazily; at equal times listed jobs come first."""
        if self.job_stream is None:
            return iter(self.jobs)
        return heapq.merge(iter(self.jobs), self.job_stream.jobs(), key=lambda j: j.t)

    def fleet_dict(self) -> dict[str, Any]:
        """Everything but the script, as JSON that :func:`vcran.io.scenario_file.parse` reads back: a trace header carries it."""
        s = self.settings
        # Keys added with docs/contract.md §4 and docs/contract.md §12 appear only when set, so older scenarios keep their exact trace header.
        return _drop_none({
            "simulation": {
                "name": s.name, "seed": s.seed, "duration": s.duration, "until_idle": s.until_idle,
                "task_timeout": s.task_timeout, "history_limit": s.history_limit,
                "telemetry_period": s.telemetry_period, "description_period": s.description_period,
                "entity_type": s.entity_type, "action_durations": dict(s.durations),
                "collisions": s.collisions if s.collisions != "report" else None,
                "collision_resolution": s.collision_resolution if s.collision_resolution != 0.05 else None,
                "protocol": s.protocol if s.protocol != OPIL else None,
                "epoch": s.epoch,
                "state_interval": s.state_interval,
            },
            "robots": [
                {
                    "id": r.id, "pose": list(r.pose), "max_velocity": r.max_velocity,
                    "max_acceleration": r.max_acceleration, "max_deceleration": r.max_deceleration,
                    "max_angular_velocity": r.max_angular_velocity, "footprint": [list(p) for p in r.footprint],
                    "actions": list(r.actions), "capacity": r.capacity, "carrying": r.carrying, "vendor": r.vendor,
                    "battery": _battery_dict(r.battery), "field": r.field.as_dict() if r.field else None,
                    "manufacturer": r.manufacturer, "serial_number": r.serial_number,
                    "interface_name": r.interface_name, "version": r.version,
                }
                for r in self.robots
            ],
            "stations": [
                {
                    "id": st.id, "position": list(st.position), "reach": st.reach,
                    "area": [list(p) for p in st.area], "parts": st.parts, "capacity": st.capacity,
                    "produce_every": st.produce_every, "produce_start": st.produce_start,
                    "produce_limit": st.produce_limit, "charger": True if st.charger else None,
                    "dock": st.dock_node if st.dock_node is not None else _point(st.dock),
                }
                for st in self.stations
            ],
            "faults": [f.as_dict() for f in self.faults] or None,
            "random_faults": [r.as_dict() for r in self.random_faults] or None,
            "roadmap": self.roadmap.as_dict() if self.roadmap is not None else None,
            "traffic": self.traffic.as_dict(),
        })


def _battery_dict(b: BatteryConfig | None) -> dict[str, Any] | None:
    if b is None:
        return None
    return {name: getattr(b, name) for name in BatteryConfig.__dataclass_fields__}


def _point(p: tuple[float, float, float | None] | None) -> list[float] | None:
    if p is None:
        return None
    return [p[0], p[1]] if p[2] is None else [p[0], p[1], p[2]]


def _drop_none(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: _drop_none(v) for k, v in value.items() if v is not None}
    if isinstance(value, list):
        return [_drop_none(v) for v in value]
    return value


def task_entries(
    time: float, robot: str, task: str, spec: TaskSpec, every: float, speed: float
) -> Iterator[ScriptEntry]:
    """The messages of one task (:func:`vcran.core.opil.build.task`), the ``k``-th at ``time + (k - 1) * every``."""
    messages = build.task(task, spec.path, spec.actions, max_velocity=speed, stamp=time, every=every)
    for k, message in enumerate(messages):
        yield ScriptEntry(time + k * every, robot, _attribute(message), message)


def _merged(script: tuple[ScriptEntry, ...], cycles: tuple[Cycle, ...]) -> Iterator[tuple[float, Iterable[Inbound]]]:
    """The script's runs of equal times and the cycles' repetitions, in time order, as inbound records;
    at equal times the script first, then the cycles in file order.

    One heap entry per stream, ``(time, stream, run number)``, the run built when it is popped: what
    ``heapq.merge`` over a generator per cycle did with a key call, a generator resumption and a
    lookahead run per step (merge was a sixth of expanding a 1000-robot script). The stream number is
    unique, so ties never compare further.
    """
    runs = groupby(script, key=_time)  # lazily: a long script is not copied
    run = next(runs, None)
    plans = [_Repetitions(c) for c in cycles if c.t < c.until]
    heap = [(plan.cycle.t, n, 0) for n, plan in enumerate(plans, start=1)]
    if run is not None:
        heap.append((run[0], 0, 0))
    heapq.heapify(heap)
    while heap:
        t, n, k = heap[0]
        following: float | None
        if n == 0:
            assert run is not None
            yield t, [_inbound(e.robot, e.attribute, e.message, e.raw, e.wire) for e in run[1]]
            run = next(runs, None)
            following = None if run is None else run[0]
        else:
            plan = plans[n - 1]
            yield t, plan.inbound(k, t)
            following = plan.time(k + 1)
        if following is None:
            heapq.heappop(heap)
        else:
            heapq.heapreplace(heap, (following, n, k + 1))


def _time(entry: ScriptEntry) -> float:
    return entry.t


def _attribute(message: Message) -> str:
    return "motion_assignment" if isinstance(message, MotionAssignment) else "action_assignment"
