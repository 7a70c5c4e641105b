"""What the page shows, as plain data: protocol-neutral, so any run folder maps onto it (docs/contract.md §13).

Nothing here is OPIL's: a robot has a footprint and poses (from legs), and over time a state, a task, a
load, a battery level and a last error; a task (an OPIL task, a VDA 5050 order) has a robot, a label and
a life; a job is a fleet manager's unit of work made of tasks; an incident is something to jump to. A
run folder of another protocol (issue 31) fills the same fields; traffic (issue 32) adds a roadmap and
incident kinds.

Everything that changes over time is a :class:`Steps`: per owner (robot or station), the instants at
which the value changed and the value from then on; the page finds the value at its cursor by binary
search, so scrubbing costs the same at any instant of a long run.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

Point = tuple[float, float]


@dataclass(frozen=True)
class Steps:
    """Owner ``k``'s values change at ``t[offsets[k]:offsets[k + 1]]`` (sorted) to the ``value`` at the same
    index; before its first change an owner has its ``initial`` value (the same for all, or per owner)."""

    offsets: np.ndarray  # uint32, owners + 1
    t: np.ndarray  # float64
    value: np.ndarray

    @staticmethod
    def build(per_owner: list[list[tuple[float, Any]]], dtype: str) -> Steps:
        offsets = np.zeros(len(per_owner) + 1, dtype=np.uint32)
        offsets[1:] = np.cumsum([len(p) for p in per_owner])
        flat = [pair for p in per_owner for pair in p]
        return Steps(offsets, np.array([p[0] for p in flat], dtype=np.float64),
                     np.array([p[1] for p in flat], dtype=dtype))


@dataclass(frozen=True)
class Robot:
    id: str
    pose: tuple[float, float, float]
    #: corners in the robot's own frame; empty when the folder has no fleet geometry
    footprint: tuple[Point, ...]
    capacity: int = 1
    #: parts carried at the start
    carrying: int = 0


@dataclass(frozen=True)
class Station:
    """A station and how it produces (so that the page can count productions between transfers)."""

    id: str
    position: Point
    reach: float
    area: tuple[Point, ...]
    capacity: int
    produce_every: float
    produce_start: float
    charger: bool = False


@dataclass(frozen=True)
class Tasks:
    """Every task's life on its robot, one entry per (robot, task) in first-seen order (R1).

    ``started``: when it became the robot's current task (NaN: never, cancelled while queued); ``end``:
    when it completed or was cancelled (the run's end while open); ``outcome``: an index into
    ``outcomes`` (``completed``, ``open``, then the cancel reasons the run had)."""

    robot: np.ndarray  # int32
    label: np.ndarray  # int32, into labels
    queued: np.ndarray
    started: np.ndarray
    end: np.ndarray
    outcome: np.ndarray  # uint8, into outcomes
    labels: list[str]
    outcomes: list[str]


@dataclass(frozen=True)
class Job:
    """A fleet manager's job (docs/contract.md §9): its tasks are indices into :class:`Tasks`."""

    id: str
    arrived: float | None
    pickup: str
    dropoff: str
    priority: float | None
    deadline: float | None
    tasks: tuple[int, ...]
    robots: tuple[int, ...]
    status: str  # completed, failed, open
    ended: float | None
    lead_time: float | None
    reason: str = ""


@dataclass(frozen=True)
class Incident:
    """Something to jump to: ``kind`` is a key of :data:`vcran.view.incidents.KINDS`."""

    t: float
    kind: str
    robot: int  # -1: the fleet, or an entity outside it
    text: str


@dataclass
class ViewModel:
    title: str
    scenario: str
    seed: int | None
    end: float
    complete: bool
    source: str
    robots: list[Robot]
    stations: list[Station]
    #: (robot index, polygon) of the motion areas the robots were sent
    areas: list[tuple[int, tuple[Point, ...]]]
    #: nodes and edges of a traffic roadmap (docs/contract.md §12, issue 32), or None: ``{"nodes": [[x, y], ...],
    #: "edges": [[i, j], ...]}``
    roadmap: dict[str, Any] | None
    #: the leg log, rows grouped by robot in log order, and where each robot's rows start (robots + 1)
    legs: np.ndarray | None
    leg_offsets: np.ndarray
    states: Steps
    state_names: list[str]
    tasks: Tasks
    #: per robot: index into ``tasks`` of its current task, -1 for none
    current: Steps
    loads: Steps
    batteries: Steps
    errors: Steps
    error_texts: list[str]
    #: per station: ``value`` parts at ``t``; ``room`` how many productions may add to it until the next step
    parts: Steps
    parts_room: np.ndarray
    jobs: list[Job]
    incidents: list[Incident]
    notes: list[str] = field(default_factory=list)
    #: whether the folder has the fleet's geometry (a trace): without it nothing is drawn on the floor
    geometry: bool = True
