"""A run folder's files (:mod:`vcran.view.folder`) turned into what the page shows (:mod:`vcran.view.model`)."""

from __future__ import annotations

from typing import Any

import numpy as np

from vcran.core.motion import wrap
from vcran.core.traffic.roadmap import Roadmap
from vcran.view.folder import RunFiles
from vcran.view.incidents import incidents_of
from vcran.view.jobs import jobs_of
from vcran.view.model import Robot, Steps, ViewModel
from vcran.view.parts import stations_of, transfers
from vcran.view.poses import Poses
from vcran.view.timelines import battery_timelines, error_timelines, task_timelines


def build_model(files: RunFiles) -> ViewModel:
    fleet: dict[str, Any] = files.header["fleet"] if files.header is not None else {}
    configs = {str(r["id"]): r for r in fleet.get("robots", [])}
    robots = [_robot(rid, configs.get(rid)) for rid in files.robots]
    ids = files.robots
    states, state_names, tasks, current = task_timelines(ids, files.events, files.end)
    errors, error_texts = error_timelines(ids, files.events)
    notes = list(files.notes)
    poses = Poses([r.pose for r in robots], files.legs)
    if fleet:
        loads, parts, rooms, disagree = transfers(ids, fleet, files.events, files.actions, poses, files.end,
                                                  files.summary if files.complete else None)
        notes += disagree
    else:
        loads, parts, rooms = Steps.build([[] for _ in ids], "int16"), Steps.build([], "int32"), np.zeros(0, np.int32)
    legs, offsets = _grouped(files.legs, len(ids))
    index = {rid: i for i, rid in enumerate(ids)}
    header = files.header or {}
    summary = files.summary or {}
    scenario = str(summary.get("scenario", header.get("scenario", files.path.name)))
    seed = header.get("seed", summary.get("seed"))
    return ViewModel(
        title=f"{scenario}: {files.path.name}", scenario=scenario, seed=int(seed) if seed is not None else None,
        end=files.end, complete=files.complete, source=files.source, robots=robots, stations=stations_of(fleet),
        areas=[(index[rid], points) for rid, points in files.areas if rid in index], roadmap=roadmap_of(fleet),
        legs=legs, leg_offsets=offsets, states=states, state_names=state_names, tasks=tasks, current=current,
        loads=loads, batteries=battery_timelines(ids, files.batteries), errors=errors, error_texts=error_texts,
        parts=parts, parts_room=rooms, jobs=jobs_of(ids, files.events, tasks), incidents=incidents_of(ids, files.events),
        notes=notes, geometry=files.header is not None)


def roadmap_of(fleet: dict[str, Any]) -> dict[str, Any] | None:
    """The fleet's traffic roadmap (docs/contract.md §12) as the page draws it: nodes as ``[x, y]`` and edges as
    pairs of node indices, read from the trace header's ``fleet.roadmap`` (:meth:`Roadmap.from_dict`, as
    reports read it). A header whose roadmap cannot be read (a damaged folder) draws none."""
    data = fleet.get("roadmap")
    if not isinstance(data, dict):
        return None
    try:
        roadmap = Roadmap.from_dict(data)
    except (KeyError, TypeError, ValueError):
        return None
    index = {n.id: k for k, n in enumerate(roadmap.nodes)}
    return {"nodes": [[n.x, n.y] for n in roadmap.nodes],
            "edges": [[index[e.start], index[e.end]] for e in roadmap.edges if e.start in index and e.end in index]}


def _robot(rid: str, config: dict[str, Any] | None) -> Robot:
    if config is None:  # no fleet geometry (a vcran manage folder)
        return Robot(rid, (0.0, 0.0, 0.0), ())
    x, y, theta = (float(v) for v in config["pose"])
    return Robot(rid, (x, y, wrap(theta)), tuple((float(px), float(py)) for px, py in config.get("footprint", [])),
                 int(config.get("capacity", 1)), int(config.get("carrying", 0)))


def _grouped(rows: np.ndarray | None, robots: int) -> tuple[np.ndarray | None, np.ndarray]:
    """The leg log's rows grouped by robot, each robot's in log order, and where each robot's start."""
    offsets = np.zeros(robots + 1, dtype=np.uint32)
    if rows is None or len(rows) == 0:
        return rows, offsets
    rows = rows[rows["robot"] < robots]
    order = np.argsort(rows["robot"], kind="stable")
    offsets[1:] = np.cumsum(np.bincount(rows["robot"], minlength=robots))
    return rows[order], offsets
