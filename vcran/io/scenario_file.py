"""Scenario files (TOML): read the fleet, the stations, the settings and the message script, or the
closed loop's jobs, link and fleet manager (SPEC §9), into a :class:`~vcran.core.scenario.Scenario`.

The format is documented with a complete annotated example in docs/scenarios.md. Loading is strict:
an unknown key, a wrong type or an impossible value fails with :class:`ScenarioError` naming the file,
the entry and the field, before anything runs. The format's JSON Schema is recorded from these readers
(:mod:`vcran.io.scenario_schema`; the rules for writing a reader are in :mod:`vcran.io.toml_table`).

A scenario argument that names no file but a bundled scenario (``demo``) loads that one: the repository's
``scenarios/`` folder, shipped inside the package as ``vcran/scenarios`` (docs/scenarios.md).
"""

from __future__ import annotations

import json
import math
import re
from importlib import resources
from pathlib import Path
from typing import Any

from vcran.core import build
from vcran.core.battery import BatteryConfig
from vcran.core.faults import KINDS as FAULT_KINDS
from vcran.core.faults import MIN_MEAN, RANDOM_KINDS, FaultSpec, RandomFaults
from vcran.core.ids import IdError
from vcran.core.messages import INBOUND
from vcran.core.orion_rules import identifier_error
from vcran.core.polygon import covers, polygon_problem
from vcran.core.scenario import (
    ACTION_KINDS,
    COLLISION_MODES,
    POLLING,
    SUBSCRIPTION,
    Cycle,
    Job,
    JobStream,
    LinkSettings,
    ManagerSpec,
    RobotConfig,
    Scenario,
    ScriptEntry,
    Settings,
    StationConfig,
    TaskSpec,
    task_entries,
)
from vcran.core.schema import MessageError
from vcran.core.traffic import roadmap as traffic
from vcran.core.traffic.roadmap import Edge, Node, Roadmap
from vcran.io.toml_table import ScenarioError, Table, read_toml

__all__ = ["ScenarioError", "bundled", "load", "parse", "read", "resolve"]


def bundled() -> dict[str, Path]:
    """The bundled scenarios, name -> file (``demo`` -> ``.../vcran/scenarios/demo.toml``)."""
    folder = Path(str(resources.files("vcran") / "scenarios"))
    return {f.stem: f for f in sorted(folder.glob("*.toml"))}

#: Actions a script may send: the configurable ones and ``charge`` (SPEC §4, a robot with a battery).
SCRIPT_ACTIONS = (*ACTION_KINDS, "charge")


def resolve(path: str | Path, folder: Path | None = None) -> Path:
    """``path`` (relative to ``folder`` when given: a sweep file's ``scenario`` is relative to the sweep
    file), or the bundled scenario of that name when no such file exists."""
    path = Path(path)
    where = folder / path if folder is not None else path
    if not where.exists() and path.name == str(path):
        names = bundled()
        if path.suffix or path.name not in names:
            raise ScenarioError(f"{where}: no such file (and no bundled scenario of that name; "
                                f"bundled: {', '.join(names)})")
        return names[path.name]
    return where


def load(path: str | Path) -> Scenario:
    """The scenario file at ``path``, or the bundled scenario of that name when no such file exists."""
    path = resolve(path)
    _, data = read_toml(path)
    return parse(data, str(path), default_name=path.stem)


def parse(data: dict[str, Any], source: str = "<scenario>", default_name: str = "scenario") -> Scenario:
    """The scenario in ``data`` (a TOML document as read by tomllib); ``source`` names it in errors."""
    if not isinstance(data, dict):  # TOML text itself, most likely: "<scenario>: : expected a table, got str"
        raise ScenarioError(f"{source}: expected the scenario as a table (a dict, as tomllib.loads(text) gives), "
                            f"got {type(data).__name__}")
    return read(Table(data, source, ""), default_name)


def read(top: Table, default_name: str = "scenario") -> Scenario:
    """The scenario in the top-level table ``top`` (:func:`parse` with the table already made; the
    schema generator passes a recording table)."""
    source = top.source
    settings = _settings(top.table("simulation"), default_name)
    robots = tuple(_robot(t) for t in top.tables("robots"))
    if not robots:
        top.reject("at least one [[robots]] entry is needed")
    roadmap_table = top.optional_table("roadmap")
    roadmap, located = (None, []) if roadmap_table is None else _roadmap(roadmap_table)
    station_tables = top.tables("stations")
    stations = tuple(_station(t, roadmap) for t in station_tables)
    script_tables = top.tables("script")
    job_tables, stream_table = top.tables("jobs"), top.optional_table("job_stream")
    link = _link(top.table("link"))
    manager_table = top.optional_table("manager")
    manager = None if manager_table is None else _manager(manager_table)
    known = {r.id for r in robots}
    faults = tuple(sorted((_fault(t, known, settings.duration) for t in top.tables("faults")), key=lambda f: f.t))
    random_faults = tuple(_random_faults(t, known, settings.duration) for t in top.tables("random_faults"))
    top.done()
    _unique(source, "robots", [r.id for r in robots])
    _unique(source, "stations", [s.id for s in stations])
    _report(top, [*located, *station_tables], traffic.validate(roadmap, stations))
    names = [s.id for s in stations]
    listed = [_job(t, names, settings.duration) for t in job_tables]
    _unique(source, "jobs", [j.id for j in listed])
    jobs = sorted(listed, key=lambda j: j.t)  # stable: equal times keep file order
    stream = None
    if stream_table is not None:
        stream = _job_stream(stream_table, names, settings, [j.id for j in jobs])
    script: list[ScriptEntry] = []
    cycles: list[Cycle] = []
    for t in script_tables:
        entry = _script_entry(t, known)
        _check_in_run(t, entry, settings.duration)
        if isinstance(entry, Cycle):
            cycles.append(entry)
        else:
            script.extend(entry)
    script.sort(key=lambda e: e.t)  # stable: equal times keep file order
    if settings.duration is None and not settings.until_idle:
        top.reject("[simulation]: set duration, or until_idle = true")
    if settings.duration is None:
        _check_resumed(top, faults)
    if cycles and settings.duration is None:
        top.reject("[simulation]: a scenario with cycles needs a duration")
    if (script or cycles) and (jobs or stream is not None or manager is not None):
        top.reject("[[script]] and a closed loop ([[jobs]], [job_stream], [manager]) exclude each other: a script "
                   "plays the fleet manager's part, jobs go to a fleet manager")
    return Scenario(settings, robots, stations, tuple(script), source, tuple(cycles), faults=faults,
                    random_faults=random_faults, jobs=tuple(jobs), job_stream=stream, link=link, manager=manager,
                    roadmap=roadmap)


def _report(top: Table, tables: list[Table], problems: list[traffic.Problem]) -> None:
    """Fail with the first of the model's ``problems`` (issue 30: the rules live with the model), told the
    way every other field is: ``file: entry: field 'key': problem``. ``tables`` are the entries read, by
    the path the model names them with; a whole entry (a path ending in ``]``) is rejected as such."""
    if not problems:
        return
    path, message = problems[0]
    by_path = {t.where: t for t in tables}
    where, _, key = path.rpartition(".")
    if path in by_path:
        by_path[path].reject(message)
    elif where in by_path:
        by_path[where].fail(key, message)
    else:
        top.reject(f"{path}: {message}")  # an entry not read as a table (a schema's recording)


def _check_in_run(t: Table, entry: list[ScriptEntry] | Cycle, duration: float | None) -> None:
    """An entry the run ends before would never be sent, and its task would time out for no visible
    reason: refuse it. A message at exactly ``duration`` is still played (inbound messages come first
    within an instant, docs/determinism.md)."""
    start = entry.t if isinstance(entry, Cycle) else max((e.t for e in entry), default=0.0)
    if duration is not None and start > duration:
        what = "starts" if isinstance(entry, Cycle) else "is sent" if len(entry) == 1 else "ends"
        t.fail("t", f"the entry {what} at t = {start:g}, after the run ends (duration = {duration:g})")


def _check_resumed(top: Table, faults: tuple[FaultSpec, ...]) -> None:
    """A run that ends only when idle never ends if a robot stays paused with work to do (it is never
    idle again): refuse a pause that no later resume ends when there is no duration to stop at."""
    paused: dict[str, float] = {}
    for f in faults:  # in time order, file order within an instant: the order they are applied
        if f.kind == "pause":
            paused.setdefault(f.robot, f.t)
        elif f.kind == "resume":
            paused.pop(f.robot, None)
    for robot, t in paused.items():
        top.reject(f"[[faults]]: {robot} is paused at t = {t:g} and never resumed, and [simulation] has no duration: "
                   "with until_idle the run would never end once the robot has work; add a resume or a duration")


def _check_time(t: Table, time: float, duration: float | None, what: str) -> None:
    """A job or a fault after the run's end would never happen, silently (like a late script entry,
    :func:`_check_in_run`): refuse it. One at exactly ``duration`` still happens (before the end,
    docs/determinism.md)."""
    if duration is not None and time > duration:
        t.fail("t", f"the {what} at t = {time:g}, after the run ends (duration = {duration:g})")


def _check_start(t: Table, start: float, duration: float | None, what: str) -> None:
    """A random source (faults, jobs) draws strictly after its ``start``: one starting when the run has
    ended would draw nothing, silently."""
    if duration is not None and start >= duration:
        t.fail("start", f"the {what} starts at t = {start:g}, when the run has ended (duration = {duration:g}): "
                        "it would draw nothing")


# --- sections -------------------------------------------------------------------------------------------


def _settings(t: Table, default_name: str) -> Settings:
    durations = t.table("action_durations")
    d = {k: durations.number(k, Settings().durations[k], minimum=0.0) for k in ACTION_KINDS}
    durations.done()
    s = Settings(
        name=t.string("name", default_name),
        seed=t.integer("seed", 0),
        duration=t.number("duration", None, minimum=0.0),
        until_idle=t.boolean("until_idle", False),
        task_timeout=t.number("task_timeout", 30.0, positive=True),
        history_limit=t.integer("history_limit", 10_000, minimum=1),
        telemetry_period=t.number("telemetry_period", 1.0, positive=True),
        description_period=t.number("description_period", 60.0, positive=True),
        entity_type=t.string("entity_type", "ROBOT"),
        durations=d,
        collisions=t.string("collisions", "report"),
        collision_resolution=t.number("collision_resolution", 0.05, positive=True),
    )
    if s.collisions not in COLLISION_MODES:
        t.fail("collisions", f"expected one of {', '.join(map(repr, COLLISION_MODES))}, got {s.collisions!r}")
    problem = identifier_error("entity type", s.entity_type)
    if problem:
        t.fail("entity_type", problem)
    t.done()
    return s


def _robot(t: Table) -> RobotConfig:
    rid = t.string("id")
    problem = identifier_error("entity id", rid)
    if problem:
        t.fail("id", f"{problem}: robot ids are Orion entity ids")
    for other in ("agv_id", "ranlogic_id"):
        value = t.string(other, rid)
        if value != rid:
            t.fail(other, f"{value!r} differs from the robot id {rid!r}: RanLogic and AGV of one robot must carry the same id (R11)")
    accel = t.number("max_acceleration", 0.0, minimum=0.0)
    if "charge" in t.strings("actions", []):  # an action a script sends, but not one listed here
        t.fail("actions", "'charge' is not listed among a robot's actions: a robot with [robots.battery] can charge "
                          f"(SPEC §4, docs/robots.md); the actions listed here are {', '.join(ACTION_KINDS)}")
    actions = t.choices("actions", ACTION_KINDS, list(ACTION_KINDS), what="action")
    footprint = t.points("footprint", list(RobotConfig.__dataclass_fields__["footprint"].default))  # type: ignore[arg-type]
    problem = polygon_problem(footprint) if footprint else None  # [] is no footprint: it never touches
    if problem:
        t.fail("footprint", f"{problem} (SPEC §4: a footprint is a simple polygon)")
    r = RobotConfig(
        id=rid,
        pose=t.triple("pose", (0.0, 0.0, 0.0)),
        max_velocity=t.number("max_velocity", 1.0, positive=True),
        max_acceleration=accel,
        max_deceleration=t.number("max_deceleration", accel, minimum=0.0),
        max_angular_velocity=t.number("max_angular_velocity", 0.0, minimum=0.0),
        footprint=tuple(footprint),
        actions=tuple(actions),
        capacity=t.integer("capacity", 1, minimum=0),
        carrying=t.integer("carrying", 0, minimum=0),
        vendor=t.text("vendor", "vcran"),
        battery=None if (battery := t.optional_table("battery")) is None else _battery(battery),
    )
    if r.carrying > r.capacity:
        t.fail("carrying", f"{r.carrying} exceeds capacity {r.capacity}")
    t.done()
    return r


def _station(t: Table, roadmap: Roadmap | None) -> StationConfig:
    area = t.points("area", [])
    problem = polygon_problem(area) if area else None
    if problem:
        t.fail("area", f"{problem} (a station's area is a simple polygon)")
    dock = t.place("dock", None)
    dock_node = None
    if isinstance(dock, str):  # a roadmap node: its position (traffic.validate says if there is none)
        dock_node, node = dock, roadmap.index().get(dock) if roadmap is not None else None
        dock = None if node is None else (node.x, node.y, None)
    s = StationConfig(
        id=t.string("id"),
        position=t.pair("position"),
        reach=t.number("reach", 1.0, positive=True),
        area=tuple(area),
        parts=t.integer("parts", 0, minimum=0),
        capacity=t.integer("capacity", 1_000_000, minimum=0),
        produce_every=t.number("produce_every", 0.0, minimum=0.0),
        produce_start=t.number("produce_start", None, minimum=0.0),
        produce_limit=t.integer("produce_limit", 0, minimum=0),
        charger=t.boolean("charger", False),
        dock=dock,
        dock_node=dock_node,
    )
    if s.parts > s.capacity:
        t.fail("parts", f"{s.parts} exceeds capacity {s.capacity}")
    if s.dock is not None:
        _check_dock(t, s)
    t.done()
    return s


def _check_dock(t: Table, s: StationConfig) -> None:
    """The dock is where a robot stands to load or unload (or charge) at the station: one beyond its reach
    made every such action there fail, robot after robot. Decided as the station decides reach
    (:meth:`vcran.core.stations.Station.within_reach`): the area polygon, outline included, else the circle."""
    assert s.dock is not None
    x, y = s.dock[0], s.dock[1]
    where = f"[{x:g}, {y:g}]"
    if s.area:
        if not covers(s.area, x, y):
            t.fail("dock", f"{where} is outside the station's area: a robot standing there cannot load or unload")
    elif (d := math.hypot(s.position[0] - x, s.position[1] - y)) > s.reach:
        t.fail("dock", f"{where} is {d:g} m from the station's position [{s.position[0]:g}, {s.position[1]:g}], "
                       f"beyond its reach {s.reach:g}: a robot standing there cannot load or unload")


def _roadmap(t: Table) -> tuple[Roadmap, list[Table]]:
    """The ``[roadmap]`` table as read, with its tables (to locate the model's problems: :func:`_report`)."""
    node_tables, edge_tables = t.tables("nodes"), t.tables("edges")
    nodes = []
    for n in node_tables:
        nodes.append(Node(n.string("id"), n.number("x"), n.number("y"), n.boolean("waiting", False)))
        n.done()
    edges = []
    for e in edge_tables:
        edges.append(Edge(e.string("from"), e.string("to"), e.boolean("one_way", False), e.number("speed", None)))
        e.done()
    t.done()
    return Roadmap(tuple(nodes), tuple(edges)), [t, *node_tables, *edge_tables]


def _battery(t: Table) -> BatteryConfig:
    capacity = t.number("capacity", positive=True)
    b = BatteryConfig(
        capacity=capacity,
        initial=t.number("initial", None, minimum=0.0),
        per_metre=t.number("per_metre", 0.0, minimum=0.0),
        per_action_second=t.number("per_action_second", 0.0, minimum=0.0),
        per_idle_second=t.number("per_idle_second", 0.0, minimum=0.0),
        charge_rate=t.number("charge_rate", 0.0, minimum=0.0),
        low=t.number("low", 0.2, minimum=0.0),
        swap_after=t.number("swap_after", None, minimum=0.0),
        voltage=t.number("voltage", 24.0, positive=True),
        resolution=t.number("resolution", 0.01, positive=True),
    )
    if b.initial is not None and b.initial > capacity:
        t.fail("initial", f"{b.initial} exceeds capacity {capacity}")
    if b.low >= 1.0:
        t.fail("low", f"a fraction of capacity below 1 is needed, got {b.low}")
    if b.resolution > 1.0:
        t.fail("resolution", f"a fraction of capacity up to 1 is needed, got {b.resolution}")
    t.done()
    return b


def _fault_robot(t: Table, robots: set[str]) -> str:
    robot = t.string("robot")
    if robot not in robots:
        t.fail("robot", f"no robot {robot!r} in this scenario; robots: {', '.join(sorted(robots))}")
    return robot


def _fault(t: Table, robots: set[str], end: float | None) -> FaultSpec:
    time = t.number("t", minimum=0.0)
    _check_time(t, time, end, "fault happens")
    robot = _fault_robot(t, robots)
    kind = t.choice("kind", tuple(FAULT_KINDS), what="fault")
    duration = t.number("duration", positive=True) if FAULT_KINDS[kind] else 0.0
    t.done()
    return FaultSpec(time, robot, kind, duration)


def _random_faults(t: Table, robots: set[str], end: float | None) -> RandomFaults:
    kind = t.choice("kind", tuple(RANDOM_KINDS), what="random fault")
    start = t.number("start", 0.0, minimum=0.0)
    _check_start(t, start, end, "random fault source")
    chosen = t.strings("robots", [])
    for i, r in enumerate(chosen):
        if r not in robots:
            t.fail("robots", f"no robot {r!r} in this scenario")
        if r in chosen[:i]:
            t.fail("robots", f"names {r!r} twice")
    source = RandomFaults(
        kind=kind,
        mtbf=_mean(t, "mtbf"),
        mttr=_mean(t, "mttr") if FAULT_KINDS[kind] else 0.0,
        robots=tuple(chosen),
        start=start,
        until=t.number("until", math.inf, minimum=0.0),
    )
    if source.until <= start:  # it draws strictly after start, before until: nothing, silently
        t.fail("until", f"{source.until:g} is not after start {start:g}: the source would draw nothing")
    t.done()
    return source


def _mean(t: Table, key: str) -> float:
    """``mtbf`` or ``mttr``: at least :data:`~vcran.core.faults.MIN_MEAN` (a tinier mean stalled time)."""
    value: float = t.number(key, positive=True)
    if value < MIN_MEAN:
        t.fail(key, f"must be at least {MIN_MEAN:g} s (R14: instants closer than 1 µs are one instant), got {value:g}")
    return value


#: The latest time a message can be stamped with: ROS time stamps hold int32 seconds (SPEC §2).
LAST_STAMP = 2**31 - 1


def _script_entry(t: Table, robots: set[str]) -> list[ScriptEntry] | Cycle:
    time = t.number("t", minimum=0.0)
    if time > LAST_STAMP:  # said of the field, before its messages are built (a stamp of 1e308 s overflows)
        t.fail("t", f"{time:g} s is later than a message's time stamp can say (int32 seconds: up to {LAST_STAMP} s)")
    robot = t.string("robot")
    if robot not in robots:
        t.fail("robot", f"no robot {robot!r} in this scenario (R11); robots: {', '.join(sorted(robots))}")
    kind = t.choice("kind", list(_EXPANDERS))
    try:
        entries = _EXPANDERS[kind](t, time, robot)
    except (MessageError, IdError) as exc:
        t.fail(kind, str(exc))
    t.done()
    return entries


def _motion(t: Table, time: float, robot: str) -> list[ScriptEntry]:
    seq, length = t.sequence("seq")
    x, y, theta = t.triple("point")
    m = build.motion(
        t.name("task"), t.name("id"), seq, length, x, y, theta,
        use_orientation=t.boolean("use_orientation", False),
        is_waypoint=t.boolean("is_waypoint", seq < length),
        max_velocity=t.number("max_velocity", 0.0, minimum=0.0),
        max_acceleration=t.number("max_acceleration", 0.0, minimum=0.0),
        area=t.points("area", []),
        stamp=time,
    )
    return [ScriptEntry(time, robot, "motion_assignment", m)]


def _action(t: Table, time: float, robot: str) -> list[ScriptEntry]:
    seq, length = t.sequence("seq")
    category, code = t.integer("category", None), t.integer("code", None)
    kind = t.choice("action", SCRIPT_ACTIONS, None, hint=" (or give category/code)")
    task, aid = t.name("task"), t.name("id")
    raw_codes = category is not None or code is not None
    if kind is not None and raw_codes:
        t.fail("action", "give either action or category/code, not both")
    if kind is None and not raw_codes:
        t.fail("action", f"missing; give action ({', '.join(SCRIPT_ACTIONS)}) or category/code")
    if kind is not None:
        a = build.action(task, aid, seq, length, kind)
    else:
        a = build.action(task, aid, seq, length, category=category or 0, code=code or 0)
    return [ScriptEntry(time, robot, "action_assignment", a)]


def _cancel(t: Table, time: float, robot: str) -> list[ScriptEntry]:
    motion, action = t.name("motion", None), t.name("action", None)
    return [ScriptEntry(time, robot, "cancel_order", build.cancel(t.name("task"), motion=motion, action=action))]


def _raw(t: Table, time: float, robot: str) -> list[ScriptEntry]:
    attribute = t.choice("attribute", list(INBOUND))
    value = t.raw("value")
    if isinstance(value, str):
        try:
            value = json.loads(value)
        except (ValueError, RecursionError) as exc:  # JSONDecodeError, or an integer of over 4300 digits
            t.fail("value", f"not valid JSON: {str(exc).split('; use sys.set_int_max_str_digits', 1)[0]}")
    try:  # what Orion could hold: TOML dates and times have no JSON form (NaN is kept, to test R12)
        json.dumps(value, allow_nan=True)
    except (TypeError, ValueError, RecursionError) as exc:
        t.fail("value", f"not a JSON value: {exc}")
    return [ScriptEntry(time, robot, attribute, raw=value)]


def _task(t: Table, time: float, robot: str) -> list[ScriptEntry]:
    """A whole task in one entry: its path's motions, then its actions, ``every`` seconds apart."""
    task = t.name("task")
    spec = _task_spec(t)
    every = t.number("every", 0.0, minimum=0.0)
    return list(task_entries(time, robot, task, spec, every, t.number("max_velocity", 0.0, minimum=0.0)))


def _cycle(t: Table, time: float, robot: str) -> Cycle:
    every = t.number("every", positive=True)
    specs = []
    for sub in t.tables("tasks"):
        specs.append(_task_spec(sub))
        sub.done()
    if not specs:
        t.fail("tasks", "a cycle needs at least one task")
    return Cycle(time, robot, every, t.number("until", math.inf, minimum=0.0), t.name("prefix", robot),
                 tuple(specs), t.number("max_velocity", 0.0, minimum=0.0))


def _task_spec(t: Table) -> TaskSpec:
    path = t.poses("path", [])
    actions = t.choices("actions", SCRIPT_ACTIONS, [], what="action")
    if not path and not actions:
        t.fail("path", "a task needs at least one point or one action")
    return TaskSpec(tuple(path), tuple(actions))


# --- the closed loop (SPEC §9) --------------------------------------------------------------------------


def _station_ref(t: Table, key: str, stations: list[str]) -> str:
    name = t.string(key)
    if name not in stations:
        t.fail(key, f"no station {name!r} in this scenario; stations: {', '.join(stations) or 'none'}")
    return name


def _job(t: Table, stations: list[str], end: float | None) -> Job:
    time = t.number("t", minimum=0.0)
    _check_time(t, time, end, "job arrives")
    job = Job(
        t=time,
        id=t.name("id"),
        pickup=_station_ref(t, "pickup", stations),
        dropoff=_station_ref(t, "dropoff", stations),
        priority=t.integer("priority", 0),
        deadline=t.number("deadline", None, minimum=0.0),
    )
    if job.pickup == job.dropoff:
        t.fail("dropoff", f"equals the pickup {job.pickup!r}: a job moves a part from one station to another")
    if job.deadline is not None and job.deadline <= job.t:
        t.fail("deadline", f"{job.deadline} is not after the job's time {job.t} (a deadline is an absolute time)")
    t.done()
    return job


def _job_stream(t: Table, stations: list[str], settings: Settings, listed: list[str]) -> JobStream:
    rate, interval = t.number("rate", None, positive=True), t.number("mean_interval", None, positive=True)
    if (rate is None) == (interval is None):
        t.fail("rate", "give exactly one of rate (jobs per hour) and mean_interval (seconds)")
    per_hour = rate if rate is not None else 3600.0 / interval  # JobStream.rate, as the file's key says
    start = t.number("start", 0.0, minimum=0.0)
    _check_start(t, start, settings.duration, "job stream")
    until = t.number("until", settings.duration, minimum=0.0)
    if until is None:
        t.fail("until", "missing (and [simulation] has no duration to default to)")
    if until <= start:
        t.fail("until", f"{until} is not after start {start}")
    pickups, dropoffs = _weights(t, "pickup", stations), _weights(t, "dropoff", stations)
    for p, _ in pickups:
        if not any(d != p for d, _ in dropoffs):
            t.fail("dropoff", f"offers no station other than the pickup {p!r}")
    prefix = t.name("prefix", "job")
    clash = next((j for j in listed if re.fullmatch(rf"{re.escape(prefix)}_[0-9]+", j)), None)
    if clash is not None:
        t.fail("prefix", f"the stream names its jobs {prefix}_1, {prefix}_2, ...; [[jobs]] id {clash!r} would clash")
    stream = JobStream(
        rate=per_hour, pickups=pickups, dropoffs=dropoffs, until=until,
        seed=t.integer("seed", settings.seed), start=start, prefix=prefix,
        priority=t.integer("priority", 0), deadline_after=t.number("deadline_after", None, positive=True),
    )
    t.done()
    return stream


def _weights(t: Table, key: str, stations: list[str]) -> tuple[tuple[str, float], ...]:
    """A list of station ids (equal weights) or a table ``{station = weight}``, each a station of this scenario."""
    pairs = t.weights(key)
    seen: set[str] = set()
    for name, _ in pairs:
        if name not in stations:
            t.fail(key, f"no station {name!r} in this scenario; stations: {', '.join(stations) or 'none'}")
        if name in seen:
            t.fail(key, f"names {name!r} twice")
        seen.add(name)
    return tuple(pairs)


def _link(t: Table) -> LinkSettings:
    link = LinkSettings(
        latency=t.number("latency", 0.05, positive=True),
        jitter=t.number("jitter", 0.0, minimum=0.0),
        inbound=t.choice("inbound", (SUBSCRIPTION, POLLING), SUBSCRIPTION),
        poll_interval=t.number("poll_interval", 0.25, positive=True),
    )
    t.done()
    return link


_MANAGER_PATH = re.compile(r"[A-Za-z_][\w.]*:[A-Za-z_][\w.]*")


def _manager(t: Table) -> ManagerSpec:
    path = t.string("class")
    if not _MANAGER_PATH.fullmatch(path):
        t.fail("class", f"expected 'module:Class' (e.g. 'vcran.managers:Dispatcher'), got {path!r}")
    options = t.table("options")
    options.used.update(options.data)  # the manager's own keywords, checked when it is built
    spec = ManagerSpec(path, tuple(options.data.items()))
    t.done()
    return spec


_EXPANDERS: dict[str, Any] = {"motion": _motion, "action": _action, "cancel": _cancel, "raw": _raw, "task": _task, "cycle": _cycle}


def _unique(source: str, section: str, ids: list[str]) -> None:
    seen: set[str] = set()
    for i, x in enumerate(ids):
        if x in seen:
            raise ScenarioError(f"{source}: {section}[{i}]: field 'id': duplicate id {x!r}")
        seen.add(x)
