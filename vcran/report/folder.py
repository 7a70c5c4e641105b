"""A run's output folder read back into a small data model, the one input of every figure and table.

``vcran run --out DIR`` writes ``summary.json``, ``events.jsonl.zst``, ``trace.jsonl.zst`` and ``legs.npy``
(docs/contract.md §8; format 1 folders, with ``telemetry.bin``, are read too). A report needs a little of each: the fleet's geometry from the trace header, where the robots
were from the telemetry, what happened from the events, the per-robot totals from the summary, and the
motion areas and targets that only the inbound assignments carry. Everything is checked here, so the
figures can trust what they get and a broken folder fails with one clear :class:`ReportError`, never a
traceback.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from vcran.core.traffic.roadmap import Roadmap
from vcran.io.trace import (
    LEGS_FILE,
    TRACE_FILE,
    check_whole,
    event_records,
    events_beside,
    read_header,
    records,
    robots_of,
    samples,
    trace_in,
)

if TYPE_CHECKING:
    from vcran.report.vda5050 import VdaTrace

FILES = ("summary.json",)  # and a trace with its events and leg log (or format 1's telemetry)
#: The fields the report reads from each kind of event (strings all).
EVENT_FIELDS = {
    "state": ("from", "to"),
    "task_queued": ("task",),
    "task_completed": ("task",),
    "task_cancelled": ("task", "reason"),
    "motion_finished": ("motion",),
    # docs/contract.md §12 (vcran.core.incidents): the robot that entered the field; a deadlock's kind
    "blocked": ("other",),
    "deadlock": ("kind",),
    # VDA 5050 (vcran.report.vda5050)
    "order_accepted": ("order_id",),
    "order_ended": ("order_id", "how"),
}

Point = tuple[float, float]


class ReportError(Exception):
    """The folder is not a complete, readable run output; the message says which file and why."""


@dataclass(frozen=True, slots=True)
class RobotSpec:
    """A robot as configured: where it started and the outline it occupies, in its own frame."""

    id: str
    pose: tuple[float, float, float]
    footprint: tuple[Point, ...]


@dataclass(frozen=True, slots=True)
class StationSpec:
    """A station: a point with a reach circle, or an area polygon when the scenario gave one."""

    id: str
    position: Point
    reach: float
    area: tuple[Point, ...]


@dataclass(frozen=True, slots=True)
class RobotResult:
    """What ``summary.json`` says of a robot that the report uses; distance is exact, from the kinematics."""

    distance: float
    parts_moved: int
    errors: int
    final_pose: tuple[float, float, float]
    #: docs/contract.md §4: charge drawn (Ah; None without a battery) and collisions, from the summary.
    energy_used: float | None = None
    collisions: int = 0


@dataclass(frozen=True, slots=True)
class MotionArea:
    """A non-empty ``motion_area`` polygon that a robot was sent, as the fleet manager drew it."""

    robot: str
    points: tuple[Point, ...]


@dataclass(frozen=True)
class Run:
    """Everything a report draws, from one run folder; robots in telemetry column order."""

    path: Path
    scenario: str
    seed: int
    sim_time: float
    #: The run's error count: every robot's rejected inputs and failures, and R11's unknown entities.
    errors: int
    robots: tuple[RobotSpec, ...]
    stations: tuple[StationSpec, ...]
    results: dict[str, RobotResult]
    events: list[dict[str, Any]]
    telemetry: np.ndarray
    motion_areas: tuple[MotionArea, ...] = ()
    #: (robot, motion label) -> the targets received for it, as (receive time, x, y), in arrival order.
    targets: dict[tuple[str, str], list[tuple[float, float, float]]] = field(default_factory=dict)
    #: robot -> its published ``battery_state`` as (t, percentage) points (docs/contract.md §4), for robots with a battery.
    batteries: dict[str, list[tuple[float, float]]] = field(default_factory=dict)
    #: A closed-loop run's job KPIs (summary.json's ``jobs``, and the fleet's utilisation); else None.
    jobs: JobFigures | None = None
    #: docs/contract.md §12: some robot had a protective field (the scenario's ``[traffic]`` or a ``[robots.field]``).
    fields: bool = False
    #: docs/contract.md §12: the scenario's roadmap (from the trace header), drawn under the paths; None without one.
    roadmap: Roadmap | None = None
    #: The scenario's protocol (the trace header's ``simulation.protocol``): ``opil`` or ``vda5050``.
    protocol: str = "opil"
    #: A VDA 5050 run's states and orders from its trace (:mod:`vcran.report.vda5050`); None for OPIL's.
    vda: VdaTrace | None = None

    @property
    def robot_ids(self) -> tuple[str, ...]:
        return tuple(r.id for r in self.robots)


def read_run(path: Path) -> Run:
    """Read and check the run folder ``path``; raise :class:`ReportError` naming what is wrong."""
    if not path.is_dir():
        raise ReportError(f"{path}: no such folder (expected the --out folder of `vcran run`)")
    missing = [name for name in FILES if not (path / name).is_file()]
    if missing:
        raise ReportError(f"{path}: not a complete run folder, missing {', '.join(missing)}")
    try:
        trace = trace_in(path)
    except ValueError:
        raise ReportError(f"{path}: not a complete run folder, missing {TRACE_FILE}") from None
    beside = [events_beside(trace)] + ([path / LEGS_FILE] if trace.name == TRACE_FILE else [])
    missing = [p.name for p in beside if not p.is_file()]
    if missing:
        raise ReportError(f"{path}: not a complete run folder, missing {', '.join(missing)}")
    with reading(trace):
        check_whole(trace)  # a finished run's trace (it has a summary), cut short
        header = read_header(trace)
        ids = robots_of(header)
        configs = {r["id"]: r for r in header["fleet"]["robots"]}
        robots = tuple(_robot(configs[rid]) for rid in ids)
        stations = tuple(_station(s) for s in header["fleet"].get("stations", []))
        fields = "traffic" in header["fleet"] or any("field" in r for r in header["fleet"]["robots"])
        roadmap = _roadmap(header["fleet"].get("roadmap"))
        protocol = str(header["fleet"].get("simulation", {}).get("protocol", "opil"))
    with reading(path / "summary.json"):
        summary = json.loads((path / "summary.json").read_text(encoding="utf-8"))
        results = {rid: _result(summary["robots"][rid]) for rid in ids}
        sim_time = float(summary["sim_time"])
        errors = int(summary["errors"])
        jobs = job_figures(summary) if "jobs" in summary else None
    with reading(trace):
        ticks = samples(trace)
    events = list(checked_events(events_beside(trace)))
    vda = None
    if protocol == "vda5050":
        from vcran.report.vda5050 import read_trace

        with reading(trace):
            vda = read_trace(trace, {rid for rid, r in configs.items() if r.get("battery")})
        areas, targets, batteries = (), {}, vda.batteries
    else:
        areas, targets, batteries = _assignments(trace)
    return Run(path, str(summary.get("scenario", header.get("scenario", ""))), int(summary.get("seed", 0)),
               sim_time, errors, robots, stations, results, events, ticks, areas, targets, batteries, jobs, fields,
               roadmap, protocol, vda)


def _roadmap(data: dict[str, Any] | None) -> Roadmap | None:
    """The header's roadmap (:meth:`Roadmap.as_dict`'s form) as the model's, or None for a run without one."""
    return Roadmap.from_dict(data) if data else None


@dataclass(frozen=True, slots=True)
class JobFigures:
    """summary.json's ``jobs`` section (docs/outputs.md) and the fleet's utilisation; lead times None
    when no job completed."""

    arrived: int
    completed: int
    failed: int
    open: int
    late: int
    done_per_hour: float
    lead_mean: float | None
    lead_p50: float | None
    lead_p95: float | None
    lead_max: float | None
    utilisation: float


def job_figures(summary: dict[str, Any]) -> JobFigures:
    j, lead = summary["jobs"], summary["jobs"]["lead_time"]

    def seconds(key: str) -> float | None:
        return float(lead[key]) if lead is not None else None

    return JobFigures(int(j["arrived"]), int(j["completed"]), int(j["failed"]), int(j["open"]), int(j["late"]),
                      float(j["done_per_hour"]), seconds("mean"), seconds("p50"), seconds("p95"), seconds("max"),
                      float(summary["utilisation"]["fleet"]))


@contextmanager
def reading(path: Path) -> Iterator[None]:
    """Whatever goes wrong reading ``path`` becomes one :class:`ReportError` that names it."""
    try:
        yield
    except (OSError, ValueError, KeyError, TypeError, IndexError) as exc:
        raise ReportError(f"{path}: unreadable ({_describe(exc)})") from None


def _result(robot: dict[str, Any]) -> RobotResult:
    pose = robot["final_pose"]
    battery = robot.get("battery")
    return RobotResult(float(robot["distance"]), int(robot["parts_moved"]), int(robot["errors"]),
                       (float(pose["x"]), float(pose["y"]), float(pose["theta"])),
                       float(battery["used"]) if battery is not None else None, int(robot.get("collisions", 0)))


def _robot(config: dict[str, Any]) -> RobotSpec:
    x, y, theta = (float(v) for v in config["pose"])
    return RobotSpec(config["id"], (x, y, theta), tuple((float(px), float(py)) for px, py in config["footprint"]))


def _station(config: dict[str, Any]) -> StationSpec:
    x, y = (float(v) for v in config["position"])
    area = tuple((float(px), float(py)) for px, py in config.get("area", []))
    return StationSpec(config["id"], (x, y), float(config.get("reach", 0.0)), area)


def checked_events(path: Path) -> Iterator[dict[str, Any]]:
    try:
        for n, event in enumerate(event_records(path), start=1):
            if not (isinstance(event, dict) and isinstance(event.get("t"), int | float)
                    and isinstance(event.get("robot"), str) and isinstance(event.get("event"), str)):
                raise ReportError(f"{path}:{n}: not an event (an object with t, robot and event expected)")
            missing = [f for f in EVENT_FIELDS.get(event["event"], ()) if not isinstance(event.get(f), str)]
            if missing:
                raise ReportError(f"{path}:{n}: {event['event']} event without {', '.join(missing)}")
            yield event
    except (OSError, ValueError) as exc:
        raise ReportError(f"{path}: unreadable ({_describe(exc)})") from None


def _assignments(path: Path) -> tuple[tuple[MotionArea, ...], dict[tuple[str, str], list[tuple[float, float, float]]],
                                       dict[str, list[tuple[float, float]]]]:
    """Motion areas and targets from the inbound ``motion_assignment`` records of the trace, and the
    published ``battery_state`` percentages (docs/contract.md §4), in one pass.

    A live run records its inbound payloads raw, as Orion delivered them; they are decoded here as the RAN
    decoded them, and one that does not decode (the RAN rejected it) is skipped.
    """
    areas: dict[tuple[str, tuple[Point, ...]], MotionArea] = {}
    targets: dict[tuple[str, str], list[tuple[float, float, float]]] = {}
    batteries: dict[str, list[tuple[float, float]]] = {}
    with reading(path):
        for n, record in records(path, attrs=("motion_assignment", "battery_state")):
            if record.get("attr") == "battery_state":
                try:
                    batteries.setdefault(record["robot"], []).append((float(record["t"]), float(record["value"]["percentage"])))
                except (KeyError, TypeError, ValueError) as exc:
                    raise ReportError(f"{path}:{n}: not a battery record ({_describe(exc)})") from None
                continue
            try:
                if record.get("dir") != "in" or record.get("attr") != "motion_assignment":
                    continue
                value = record["value"] if "value" in record else _decoded(record.get("raw"))
                if value is None:
                    continue
                robot = record["robot"]
                motion = _label(value["motion_id"])
                point = value["point"]
                targets.setdefault((robot, motion), []).append((record["t"], point["x"], point["y"]))
                polygon = tuple((p["x"], p["y"]) for p in value["motion_area"]["polygon"]["points"])
            except (KeyError, TypeError) as exc:
                raise ReportError(f"{path}:{n}: not a motion_assignment record ({_describe(exc)})") from None
            if polygon and (robot, polygon) not in areas:
                areas[robot, polygon] = MotionArea(robot, polygon)
    return tuple(areas.values()), targets, batteries


def _decoded(raw: Any) -> dict[str, Any] | None:
    from vcran.core.opil.codec import decode_attribute
    from vcran.core.opil.plain import to_plain

    try:
        return to_plain(decode_attribute("motion_assignment", raw))
    except ValueError:
        return None


def _label(ident: dict[str, Any]) -> str:
    """An id as events and summary name it (docs/contract.md §8): its description, else its canonical uuid."""
    return str(ident.get("description") or ident["uuid"])


def _describe(exc: BaseException) -> str:
    return f"missing field {exc}" if isinstance(exc, KeyError) else str(exc) or type(exc).__name__
