"""Every rule a scenario must satisfy, on the model (issue 30 item 3): :func:`validate`.

A :class:`~vcran.core.scenario.Scenario` built in code (``dataclasses.replace`` of a loaded one, or made
from scratch) is checked here exactly as one read from a file: the scenario file's reader only turns TOML
into the model, calls :func:`validate` and says where in the file each problem lies. A problem is a
:class:`Problem`, ``(path, message)``, its path in the scenario's own terms (``robots[2].battery.capacity``,
``stations[0].dock``, ``jobs[1].pickup``; the file's keys), told as one line by ``str(problem)``.

The rules, by part: settings, robots and stations in :mod:`.fleet`; faults, the closed loop (jobs, job
stream, link, manager) and the script in :mod:`.workload`; what the scenario's protocol allows (VDA 5050
vehicles, and the script's messages) in :mod:`.protocol`; a roadmap's in
:func:`vcran.core.traffic.roadmap.validate`; safety fields and deadlock settings in :mod:`.safety`; the
rules between parts and of the whole scenario here. Each field's own rule (kind and bounds) is declared once
in those modules, and the file's reader applies it to the value as the file writes it (:mod:`.fields`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from vcran.core.scenario import RobotConfig, Scenario, Settings, StationConfig
from vcran.core.traffic import roadmap as traffic
from vcran.core.traffic.roadmap import Roadmap
from vcran.core.validity.fields import Problem, is_number
from vcran.core.validity.fleet import robot_problems, settings_problems, station_problems
from vcran.core.validity.protocol import duration_problems, trigger_problems, vehicle_problems
from vcran.core.validity.protocol import link_problems as protocol_link_problems
from vcran.core.validity.protocol import script_problems as protocol_script_problems
from vcran.core.validity.protocol import settings_problems as protocol_settings_problems
from vcran.core.validity.safety import traffic_problems
from vcran.core.validity.workload import (
    fault_problems,
    in_time_order,
    job_problems,
    job_stream_problems,
    link_problems,
    manager_problems,
    paused_forever,
    random_faults_problems,
    script_problems,
)

__all__ = ["Problem", "validate"]


def validate(scenario: Scenario, *, fields_checked: bool = False) -> list[Problem]:
    """Every problem of ``scenario``, part by part in the order of a file (settings, robots, stations, the
    roadmap, safety fields, link and manager, faults, jobs, the job stream, the script, then the whole);
    empty when it can run. A part whose own fields are broken is not related to the others (its relations would be about
    values it does not hold). ``fields_checked``: each field's own rule was applied already (by a file's
    reader, to the value as written); only what relates fields and parts is left.
    """
    if not isinstance(scenario, Scenario):
        return [Problem("", f"expected a Scenario, got {type(scenario).__name__}")]
    sc, own = scenario, not fields_checked
    out = settings_problems(sc.settings, own)
    if not out and isinstance(sc.settings, Settings):
        out += protocol_settings_problems(sc.settings)
    end = sc.settings.duration if isinstance(sc.settings, Settings) and is_number(sc.settings.duration) else None
    if not sc.robots:
        out.append(Problem("", "at least one [[robots]] entry is needed"))
    for i, r in enumerate(sc.robots):
        out += robot_problems(r, i, own)
    out += _unique("robots", sc.robots, RobotConfig)
    protocol = sc.settings.protocol if isinstance(sc.settings, Settings) else None
    if protocol is not None and not out:  # a robot's own fields first: its topics are made of them
        out += vehicle_problems(sc.robots, protocol)
        out += duration_problems(sc.settings.durations, protocol)
    stations = []
    for i, s in enumerate(sc.stations):
        stations += station_problems(s, i, own)
    out += stations + _unique("stations", sc.stations, StationConfig)
    if sc.roadmap is not None and not isinstance(sc.roadmap, Roadmap):
        out.append(Problem("roadmap", f"expected a Roadmap or None, got {type(sc.roadmap).__name__}"))
    elif not stations:  # the roadmap's rules read the stations' docks
        out += [Problem(*p) for p in traffic.validate(sc.roadmap, sc.stations)]
    out += traffic_problems(sc, own)
    link = link_problems(sc.link, own)
    out += link or (protocol_link_problems(sc.link, protocol) if protocol is not None else [])
    if sc.manager is not None:
        out += manager_problems(sc.manager, own)
    robots = _ids(sc.robots, RobotConfig)
    faults = [p for k, f in enumerate(sc.faults) for p in fault_problems(f, k, robots, end, own)]
    faults = faults or in_time_order("faults", sc.faults)
    out += faults
    for i, source in enumerate(sc.random_faults):
        out += random_faults_problems(source, i, robots, end, own)
    names = list(_ids(sc.stations, StationConfig))
    jobs = [p for k, j in enumerate(sc.jobs) for p in job_problems(j, k, names, end, own)]
    out += jobs or in_time_order("jobs", sc.jobs)
    out += _unique("jobs", sc.jobs)
    if sc.job_stream is not None:
        listed = [j.id for j in sc.jobs if isinstance(getattr(j, "id", None), str)]
        out += job_stream_problems(sc.job_stream, names, listed, end, own)
    script = script_problems(sc.script, sc.cycles, robots, end, own)
    if protocol is not None and not script:
        script = protocol_script_problems(sc.script, sc.cycles, protocol)
    if protocol is not None and not script and not faults:
        script = trigger_problems(sc.script, sc.faults, protocol, endless=sc.settings.duration is None)
    out += script
    return out + _whole(sc, faults_sound=not faults)


def _whole(sc: Scenario, faults_sound: bool) -> list[Problem]:
    """The rules of the scenario as a whole: how it ends, and who plays the fleet manager's part."""
    s = sc.settings
    if not isinstance(s, Settings):
        return []
    out = []
    if s.duration is None and not s.until_idle:
        out.append(Problem("", "[simulation]: set duration, or until_idle = true"))
    if s.duration is None and faults_sound:
        out += paused_forever(sc.faults)
    if sc.cycles and s.duration is None:
        out.append(Problem("", "[simulation]: a scenario with cycles needs a duration"))
    if (sc.script or sc.cycles) and (sc.jobs or sc.job_stream is not None or sc.manager is not None):
        out.append(Problem("", "[[script]] and a closed loop ([[jobs]], [job_stream], [manager]) exclude each other: "
                               "a script plays the fleet manager's part, jobs go to a fleet manager"))
    return out


def _ids(parts: Sequence[Any], kind: type[Any]) -> dict[str, None]:
    """The ids of ``parts`` that are ``kind`` with a string id, in order (a dict: ordered, quick to test)."""
    return {p.id: None for p in parts if isinstance(p, kind) and isinstance(p.id, str)}


def _unique(section: str, parts: Sequence[Any], kind: type[Any] | None = None) -> list[Problem]:
    seen: set[str] = set()
    out = []
    for i, p in enumerate(parts):
        x = getattr(p, "id", None) if kind is None or isinstance(p, kind) else None
        if not isinstance(x, str):
            continue
        if x in seen:
            out.append(Problem(f"{section}[{i}].id", f"duplicate id {x!r}"))
        seen.add(x)
    return out
