"""Scenario files (TOML): read the fleet, the stations, the settings and the message script, or the
closed loop's jobs, link and fleet manager (docs/contract.md §9), into a :class:`~vcran.core.scenario.Scenario`.

The format is documented with a complete annotated example in docs/scenarios.md. Loading is strict:
an unknown key, a wrong type or an impossible value fails with :class:`ScenarioError` naming the file,
the entry and the field, before anything runs. What a scenario may be is the model's to say
(:mod:`vcran.core.validity`, issue 30 item 3); this module turns TOML into the model. Each table is read with
its part's rules, which check every value as the file writes it; :func:`vcran.core.validity.validate` then
checks what relates values and parts, and its first problem is told at its place in the file. What stays
here is the file's own: its keys and types, unknown keys, what a file may write that the model holds once
(``agv_id`` and ``ranlogic_id``, a job stream's ``mean_interval``, a dock named by its roadmap node) and the
script's entries as the messages they send (:mod:`vcran.io.scenario_script`). The format's JSON Schema is
recorded from these readers (:mod:`vcran.io.scenario_schema`; the rules for writing a reader are in
:mod:`vcran.io.toml_table`).

A scenario argument that names no file but a bundled scenario (``demo``) loads that one: the repository's
``scenarios/`` folder, shipped inside the package as ``vcran/scenarios`` (docs/scenarios.md).
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from datetime import UTC, date, datetime, time
from importlib import resources
from pathlib import Path
from typing import Any

from vcran.core.battery import BatteryConfig
from vcran.core.faults import KINDS as FAULT_KINDS
from vcran.core.faults import FaultSpec, RandomFaults
from vcran.core.scenario import (
    ACTION_KINDS,
    OPIL,
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
    TrafficSettings,
)
from vcran.core.traffic.fields import FieldSpec
from vcran.core.traffic.roadmap import Edge, Node, Roadmap
from vcran.core.validity import Problem, validate
from vcran.core.validity.fleet import ACTION_DURATIONS, BATTERY, FINE_POSITIONING, ROBOT, SETTINGS, STATION
from vcran.core.validity.safety import FIELD, TRAFFIC
from vcran.core.validity.workload import (
    FAULT,
    JOB,
    JOB_STREAM,
    LINK,
    MANAGER,
    RANDOM_FAULTS,
    SCRIPT,
)
from vcran.io.scenario_script import check_in_run, script_entry
from vcran.io.scenario_vda5050 import Draft, stamped
from vcran.io.toml_table import ScenarioError, Table, read_toml

__all__ = ["ScenarioError", "bundled", "load", "parse", "read", "resolve"]


def bundled() -> dict[str, Path]:
    """The bundled scenarios, name -> file (``demo`` -> ``.../vcran/scenarios/demo.toml``)."""
    folder = Path(str(resources.files("vcran") / "scenarios"))
    return {f.stem: f for f in sorted(folder.glob("*.toml"))}


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
    schema generator passes a recording table). Each table is read with its part's rules, which check
    each value as the file writes it; what relates values and parts is :func:`vcran.core.validity.validate`'s,
    told here at its place in the file (:func:`_report`)."""
    settings = _settings(top.table("simulation", SETTINGS), default_name)
    robots = tuple(_robot(t) for t in top.tables("robots", ROBOT))
    roadmap_table = top.optional_table("roadmap")
    roadmap = None if roadmap_table is None else _roadmap(roadmap_table)
    stations = tuple(_station(t, roadmap) for t in top.tables("stations", STATION))
    traffic = _traffic(top.table("traffic", TRAFFIC))
    script_tables = top.tables("script", SCRIPT)
    job_tables, stream_table = top.tables("jobs", JOB), top.optional_table("job_stream", JOB_STREAM)
    link = _link(top.table("link", LINK))
    manager_table = top.optional_table("manager", MANAGER)
    manager = None if manager_table is None else _manager(manager_table)
    faults = [_fault(t) for t in top.tables("faults", FAULT)]
    random_faults = tuple(_random_faults(t) for t in top.tables("random_faults", RANDOM_FAULTS))
    top.done()
    jobs = [_job(t) for t in job_tables]
    stream = None if stream_table is None else _job_stream(stream_table, settings)
    script: list[ScriptEntry] = []
    owners: list[int] = []  # the [[script]] entry each message came from
    cycles: list[Cycle] = []
    cycle_owners: list[int] = []
    drafts: dict[int, Draft] = {}  # VDA 5050 messages, by their place in the script, stamped below
    for i, t in enumerate(script_tables):
        entry = script_entry(t)
        check_in_run(t, entry, settings.duration)
        if isinstance(entry, Cycle):
            cycles.append(entry)
            cycle_owners.append(i)
        elif isinstance(entry, Draft):
            drafts[len(script)] = entry
            script.append(None)  # type: ignore[arg-type]  # filled in below
            owners.append(i)
        else:
            script.extend(entry)
            owners.extend([i] * len(entry))
    if drafts:
        for place, stamped_entry in zip(drafts, stamped(list(drafts.values()), {r.id: r for r in robots}, settings)):
            script[place] = stamped_entry
    in_file = list(script)
    script.sort(key=_time)  # stable: equal times keep file order (so do jobs and faults)
    scenario = Scenario(settings, robots, stations, tuple(script), top.source, tuple(cycles),
                        faults=tuple(sorted(faults, key=_time)), random_faults=random_faults,
                        jobs=tuple(sorted(jobs, key=_time)), job_stream=stream, link=link, manager=manager,
                        roadmap=roadmap, traffic=traffic)
    problems = validate(scenario, fields_checked=True)
    if problems:
        _report(top, problems[0], {
            "faults": lambda k: _by_time(faults)[k], "jobs": lambda k: _by_time(jobs)[k],
            "script": lambda k: owners[_by_time(in_file)[k]], "cycles": cycle_owners.__getitem__,
        })
    return scenario


#: A path into a list the model holds in another order than the file: sorted by time, or expanded.
_REORDERED = re.compile(r"(jobs|faults|script|cycles)\[([0-9]+)\]")


def _report(top: Table, problem: Problem, in_file: dict[str, Callable[[int], int]]) -> None:
    """Fail with the model's ``problem``, told at its place in the file (``file: entry: field 'key':
    problem``, as every field is). Jobs and faults are the model's in time order, script entries in time
    order and a task's messages one each, cycles apart: ``in_file`` gives each one's [[section]] index."""
    path, message = problem
    match = _REORDERED.match(path)
    if match is not None:
        section = match.group(1)
        try:
            index = in_file[section](int(match.group(2)))
        except IndexError:  # a schema's recording: one sample entry of each
            index = int(match.group(2))
        path = f"{'script' if section == 'cycles' else section}[{index}]{path[match.end():]}"
    top.reject(str(Problem(path, message)))


def _by_time(items: list[Any]) -> list[int]:
    """The file indices of ``items`` in the model's order: by time, equal times in file order."""
    return sorted(range(len(items)), key=lambda i: items[i].t)


def _time(item: Any) -> float:
    return item.t  # type: ignore[no-any-return]


# --- sections -------------------------------------------------------------------------------------------


def _settings(t: Table, default_name: str) -> Settings:
    durations = t.table("action_durations", ACTION_DURATIONS)
    d = {k: durations.number(k, Settings().durations[k]) for k in ACTION_KINDS}
    fine = durations.number(FINE_POSITIONING, None)
    if fine is not None:  # only where given: a scenario without it is written and recorded as before
        d[FINE_POSITIONING] = fine
    durations.done()
    s = Settings(
        name=t.string("name", default_name),
        seed=t.integer("seed", 0),
        duration=t.number("duration", None),
        until_idle=t.boolean("until_idle", False),
        task_timeout=t.number("task_timeout", 30.0),
        history_limit=t.integer("history_limit", 10_000),
        telemetry_period=t.number("telemetry_period", 1.0),
        description_period=t.number("description_period", 60.0),
        entity_type=t.string("entity_type", "ROBOT"),
        durations=d,
        collisions=t.string("collisions", "report"),
        collision_resolution=t.number("collision_resolution", 0.05),
        protocol=t.choice("protocol", default=OPIL),
        epoch=_epoch(t),
        state_interval=t.number("state_interval", None),
    )
    t.done()
    return s


def _epoch(t: Table) -> str | None:
    """``epoch``, a text: a TOML date-time (the same written without quotes) has no JSON form for the trace
    header, which records the scenario, and would leave the file's schema."""
    v = t.data.get("epoch")
    if isinstance(v, (datetime, date, time)):
        utc = isinstance(v, datetime) and v.utcoffset() is not None
        shown = v.astimezone(UTC).isoformat().replace("+00:00", "Z") if utc else "2026-01-01T00:00:00Z"
        t.fail("epoch", f'a TOML date-time; write it in UTC as a string, in quotes: epoch = "{shown}"')
    return t.string("epoch", None)  # type: ignore[no-any-return]


def _robot(t: Table) -> RobotConfig:
    rid = t.string("id")
    for other in ("agv_id", "ranlogic_id"):  # the seed's two names for one robot, which the model has once
        value = t.string(other, rid)
        if value != rid:
            t.fail(other, f"{value!r} differs from the robot id {rid!r}: RanLogic and AGV of one robot must carry the same id (R11)")
    accel = t.number("max_acceleration", 0.0)
    actions = t.choices("actions", default=list(ACTION_KINDS))
    footprint = t.points("footprint", list(RobotConfig.__dataclass_fields__["footprint"].default))  # type: ignore[arg-type]
    r = RobotConfig(
        id=rid,
        pose=t.triple("pose", (0.0, 0.0, 0.0)),
        max_velocity=t.number("max_velocity", 1.0),
        max_acceleration=accel,
        max_deceleration=t.number("max_deceleration", accel),
        max_angular_velocity=t.number("max_angular_velocity", 0.0),
        footprint=tuple(footprint),
        actions=tuple(actions),
        capacity=t.integer("capacity", 1),
        carrying=t.integer("carrying", 0),
        vendor=t.text("vendor", "vcran"),
        battery=None if (battery := t.optional_table("battery", BATTERY)) is None else _battery(battery),
        field=None if (field := t.optional_table("field", FIELD)) is None else _field(field),
        manufacturer=t.string("manufacturer", None),  # a VDA 5050 vehicle's (docs/contract.md §11)
        serial_number=t.string("serial_number", None),
        interface_name=t.string("interface_name", None),
        version=t.choice("version", default=None),
    )
    t.done()
    return r


def _station(t: Table, roadmap: Roadmap | None) -> StationConfig:
    area = t.points("area", [])
    dock = t.place("dock", None)
    dock_node = None
    if isinstance(dock, str):  # a roadmap node: its position (validate says if there is none)
        dock_node, node = dock, roadmap.index().get(dock) if roadmap is not None else None
        dock = None if node is None else (node.x, node.y, None)
    s = StationConfig(
        id=t.string("id"),
        position=t.pair("position"),
        reach=t.number("reach", 1.0),
        area=tuple(area),
        parts=t.integer("parts", 0),
        capacity=t.integer("capacity", 1_000_000),
        produce_every=t.number("produce_every", 0.0),
        produce_start=t.number("produce_start", None),
        produce_limit=t.integer("produce_limit", 0),
        charger=t.boolean("charger", False),
        dock=dock,
        dock_node=dock_node,
    )
    t.done()
    return s


def _roadmap(t: Table) -> Roadmap:
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
    return Roadmap(tuple(nodes), tuple(edges))


def _field(t: Table) -> FieldSpec:
    f = FieldSpec(margin=t.number("margin"), reaction=t.number("reaction", 0.0), braking=t.boolean("braking", True),
                  side=t.number("side", 0.0))
    t.done()
    return f


def _traffic(t: Table) -> TrafficSettings:
    field = t.optional_table("field", FIELD)
    traffic = TrafficSettings(
        field=None if field is None else _field(field),
        deadlock_bound=t.number("deadlock_bound", None),
        on_deadlock=t.choice("on_deadlock", default="continue"),
    )
    t.done()
    return traffic


def _battery(t: Table) -> BatteryConfig:
    b = BatteryConfig(
        capacity=t.number("capacity"),
        initial=t.number("initial", None),
        per_metre=t.number("per_metre", 0.0),
        per_action_second=t.number("per_action_second", 0.0),
        per_idle_second=t.number("per_idle_second", 0.0),
        charge_rate=t.number("charge_rate", 0.0),
        low=t.number("low", 0.2),
        swap_after=t.number("swap_after", None),
        voltage=t.number("voltage", 24.0),
        resolution=t.number("resolution", 0.01),
    )
    t.done()
    return b


def _fault(t: Table) -> FaultSpec:
    time, robot, kind = t.number("t"), t.string("robot"), t.choice("kind")
    duration = t.number("duration") if FAULT_KINDS[kind] else 0.0  # only a fault that lasts has one
    t.done()
    return FaultSpec(time, robot, kind, duration)


def _random_faults(t: Table) -> RandomFaults:
    kind = t.choice("kind")
    start = t.number("start", 0.0)
    chosen = t.strings("robots", [])
    source = RandomFaults(
        kind=kind,
        mtbf=t.number("mtbf"),
        mttr=t.number("mttr") if FAULT_KINDS[kind] else 0.0,
        robots=tuple(chosen),
        start=start,
        until=t.number("until", math.inf),
    )
    t.done()
    return source


# --- the closed loop (docs/contract.md §9) --------------------------------------------------------------------------


def _job(t: Table) -> Job:
    job = Job(
        t=t.number("t"),
        id=t.name("id"),
        pickup=t.string("pickup"),
        dropoff=t.string("dropoff"),
        priority=t.integer("priority", 0),
        deadline=t.number("deadline", None),
    )
    t.done()
    return job


def _job_stream(t: Table, settings: Settings) -> JobStream:
    rate, interval = t.number("rate", None), t.number("mean_interval", None, positive=True)
    if (rate is None) == (interval is None):  # the model has the rate; a file may give its inverse
        t.fail("rate", "give exactly one of rate (jobs per hour) and mean_interval (seconds)")
    per_hour = rate if rate is not None else 3600.0 / interval  # JobStream.rate, as the file's key says
    start = t.number("start", 0.0)
    until = t.number("until", settings.duration)
    if until is None:
        t.fail("until", "missing (and [simulation] has no duration to default to)")
    stream = JobStream(
        rate=per_hour, pickups=tuple(t.weights("pickup")), dropoffs=tuple(t.weights("dropoff")), until=until,
        prefix=t.name("prefix", "job"), seed=t.integer("seed", settings.seed), start=start,
        priority=t.integer("priority", 0), deadline_after=t.number("deadline_after", None),
    )
    t.done()
    return stream


def _link(t: Table) -> LinkSettings:
    link = LinkSettings(
        latency=t.number("latency", 0.05),
        jitter=t.number("jitter", 0.0),
        inbound=t.choice("inbound", default=SUBSCRIPTION),
        poll_interval=t.number("poll_interval", 0.25),
        loss=t.number("loss", 0.0),
    )
    t.done()
    return link


def _manager(t: Table) -> ManagerSpec:
    path = t.string("class")
    options = t.table("options")
    options.used.update(options.data)  # the manager's own keywords, checked when it is built
    spec = ManagerSpec(path, tuple(options.data.items()))
    t.done()
    return spec


