"""The layout figure: the floor seen from above, with stations, motion areas and where each robot drove.

Paths come from the 1 s telemetry, cut at the moments a task became current and ended
(:mod:`vcran.report.spans`) and coloured by that task. One-second samples cut corners: a robot that
reaches a point and turns in less than a second would seem to take a short cut. So the exact point of
every finished motion (its target, from the inbound assignment) is inserted at the instant the motion
finished, and the path bends where the robot really did.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Literal

import numpy as np

from vcran.report.folder import RobotSpec, Run
from vcran.report.incidents import incidents
from vcran.report.spans import History, TaskSpan
from vcran.report.style import (
    INCIDENT_STYLE,
    NO_TASK,
    REASON_STYLE,
    TASK_PALETTE,
    robot_colour,
    save,
    task_colours,
    task_name,
    unit,
)

if TYPE_CHECKING:  # matplotlib is an optional extra, imported when a figure is drawn
    from matplotlib.artist import Artist
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure
    from matplotlib.transforms import Bbox

#: Robot and station labels on the floor plan are drawn up to these counts; above, they would overlap.
LABELLED_ROBOTS = 20
LABELLED_STATIONS = 40

NO_TASK_NAME = "driven outside a task"
TOO_MANY = f"over {len(TASK_PALETTE)} tasks: too many to colour"

Piece = tuple[TaskSpan | None, np.ndarray]
Dashes = Literal["-", "--"]


@dataclass(frozen=True, slots=True)
class Label:
    """A name to write on the floor plan, with the places it may go: (x, y, above), best first."""

    text: str
    places: tuple[tuple[float, float, bool], ...]
    bold: bool = False


def path_pieces(run: Run, index: int, history: History, corners: list[tuple[float, float, float]]) -> list[Piece]:
    """The robot's driven path cut into pieces: one per task while it was current, ``None`` between tasks.

    ``corners`` are (t, x, y) points the robot is known to have passed exactly. A piece without motion
    is left out: a task that never moved draws nothing, nor does the waiting between tasks.
    """
    ticks = run.telemetry
    column = 1 + 5 * index
    t = np.concatenate([ticks[:, 0], [c[0] for c in corners]])
    x = np.concatenate([ticks[:, column], [c[1] for c in corners]])
    y = np.concatenate([ticks[:, column + 1], [c[2] for c in corners]])
    order = np.argsort(t, kind="stable")
    t, x, y = t[order], x[order], y[order]
    if t.size == 0:
        return []
    pieces: list[Piece] = []
    for start, end, span in _intervals([s for s in history.tasks if s.started is not None], run.sim_time):
        # A robot stands still when a task starts or ends, so its position then is the last one known.
        first, last = (max(int(np.searchsorted(t, u, side="right")) - 1, 0) for u in (start, end))
        keep = np.r_[first, np.flatnonzero((t > start) & (t < end)), last]
        if np.any(np.hypot(np.diff(x[keep]), np.diff(y[keep])) > 1e-9):
            pieces.append((span, np.column_stack([x[keep], y[keep]])))
    return pieces


def _intervals(spans: list[TaskSpan], end: float) -> list[tuple[float, float, TaskSpan | None]]:
    """[0, end] covered by the spans' current intervals (in start order) and the gaps between them."""
    out: list[tuple[float, float, TaskSpan | None]] = []
    cursor = 0.0
    for span in sorted(spans, key=lambda s: s.started or 0.0):
        started = span.started or 0.0
        if started > cursor:
            out.append((cursor, started, None))
        out.append((started, span.end, span))
        cursor = max(cursor, span.end)
    if end > cursor:
        out.append((cursor, end, None))
    return out


def corners_by_robot(run: Run) -> dict[str, list[tuple[float, float, float]]]:
    """(t, x, y) of every finished motion whose target the trace holds, per robot; of a VDA 5050 run, where
    every published state put the vehicle (its ``agvPosition``, at each node passed and every action's start)."""
    if run.vda is not None:
        return {rid: list(run.vda.points.get(rid, ())) for rid in run.robot_ids}
    out: dict[str, list[tuple[float, float, float]]] = {rid: [] for rid in run.robot_ids}
    for event in run.events:
        if event["event"] != "motion_finished" or event["robot"] not in out:
            continue
        t = float(event["t"])
        received = [p for p in run.targets.get((event["robot"], event.get("motion", "")), []) if p[0] <= t]
        if received:
            out[event["robot"]].append((t, received[-1][1], received[-1][2]))
    return out


def footprint_at(robot: RobotSpec, x: float, y: float, theta: float) -> np.ndarray:
    """The robot's footprint polygon placed at a pose on the floor."""
    c, s = math.cos(theta), math.sin(theta)
    return np.array([(x + c * px - s * py, y + s * px + c * py) for px, py in robot.footprint])


def draw_layout(run: Run, histories: dict[str, History], path: Path) -> None:
    from matplotlib.figure import Figure

    fig = Figure(figsize=(11, 7), layout="constrained")
    ax = fig.subplots()
    many_robots = len(run.robots) > LABELLED_ROBOTS
    labels: list[Label] = []
    handles = _floor(ax, run, labels) + _paths(ax, run, histories, arrows=not many_robots)
    handles += _poses(ax, run, labels, small=many_robots)
    handles += _incident_places(ax, run)
    ax.set_aspect("equal", adjustable="datalim")
    ax.autoscale_view()
    ax.margins(0.08)
    ax.grid(True, color="#eeeeee", linewidth=0.6, zorder=-1)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    robots = f"{len(run.robots)} robot" + ("s" if len(run.robots) != 1 else "")
    unlabelled = f"\n(robot labels and direction arrows left out above {LABELLED_ROBOTS} robots)" if many_robots else ""
    ax.set_title(f"{run.scenario}: layout and driven paths, {robots}, {run.sim_time:g} s simulated{unlabelled}")
    fig.legend(handles=handles, loc="outside right upper", fontsize=8, frameon=False)
    _place_labels(fig, ax, sorted(labels, key=lambda label: not label.bold))
    save(fig, path)


def _floor(ax: Axes, run: Run, labels: list[Label]) -> list[Artist]:
    """Motion areas and stations, under everything else; legend handles for what is there."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import Circle, Patch, Polygon

    handles: list[Artist] = []
    for area in run.motion_areas:
        ax.add_patch(Polygon(area.points, closed=True, facecolor="#fff4d6", edgecolor="#c9a227", hatch="..",
                             linewidth=0.8, zorder=0))
    if run.motion_areas:
        handles.append(Patch(facecolor="#fff4d6", edgecolor="#c9a227", hatch="..", label="motion area"))
    for st in run.stations:
        if st.area:
            ax.add_patch(Polygon(st.area, closed=True, facecolor="#e8e0d0", edgecolor="#6b5b3e", zorder=1))
        else:
            ax.add_patch(Circle(st.position, st.reach, facecolor="#f3eee4", edgecolor="#6b5b3e",
                                linestyle="--", zorder=1))
    handles += _roadmap(ax, run)
    if run.stations:
        ax.scatter([st.position[0] for st in run.stations], [st.position[1] for st in run.stations], marker="s",
                   s=18, color="#6b5b3e", zorder=2)
        handles.append(Line2D([], [], marker="s", color="#6b5b3e", markerfacecolor="#f3eee4", linestyle="--",
                              markersize=8, label="station and its reach"))
    if len(run.stations) <= LABELLED_STATIONS:
        for st in run.stations:
            top = max((p[1] for p in st.area), default=st.position[1] + st.reach)
            bottom = min((p[1] for p in st.area), default=st.position[1] - st.reach)
            labels.append(Label(st.id, ((st.position[0], top, True), (st.position[0], bottom, False))))
    return handles


def _roadmap(ax: Axes, run: Run) -> list[Artist]:
    """docs/contract.md §12: the roadmap's lanes (one-way ones dashed) and nodes (waiting bays hollow), over the
    stations and under the paths; no artist at all for a run without a roadmap."""
    from matplotlib.collections import LineCollection
    from matplotlib.lines import Line2D

    if run.roadmap is None:
        return []
    at = {n.id: (n.x, n.y) for n in run.roadmap.nodes}
    handles: list[Artist] = []
    for one_way, style, label in ((False, "-", "roadmap lane"), (True, "--", "one-way lane")):
        lanes = [(at[e.start], at[e.end]) for e in run.roadmap.edges if e.one_way == one_way]
        if lanes:
            ax.add_collection(LineCollection(lanes, colors="#9aa5b1", linewidths=2.5, linestyles=style, zorder=1.5,
                                             gid=label))
            handles.append(Line2D([], [], color="#9aa5b1", linewidth=2.5, linestyle=style, label=label))
    for waiting, face, label in ((False, "#9aa5b1", "roadmap node"), (True, "white", "waiting node")):
        nodes = [(n.x, n.y) for n in run.roadmap.nodes if n.waiting == waiting]
        if nodes:
            ax.scatter(*zip(*nodes), s=14, marker="o", facecolor=face, edgecolor="#6e7b88", zorder=1.6, gid=label)
            handles.append(Line2D([], [], marker="o", color="#6e7b88", markerfacecolor=face, linestyle="",
                                  label=label))
    return handles


def _paths(ax: Axes, run: Run, histories: dict[str, History], arrows: bool) -> list[Artist]:
    """Every robot's path, coloured by task (or by robot when tasks are too many to colour); the
    stretch of a task that was cancelled is dashed."""
    from matplotlib.collections import LineCollection
    from matplotlib.lines import Line2D

    colours = task_colours(histories)
    corners = corners_by_robot(run)
    segments: list[np.ndarray] = []
    styles: list[tuple[str, Dashes]] = []  # (colour, line style) per segment
    named: dict[str, tuple[str, Dashes]] = {}
    for i, robot in enumerate(run.robots):
        for span, points in path_pieces(run, i, histories[robot.id], corners[robot.id]):
            dashes: Dashes = "--" if span is not None and span.outcome in REASON_STYLE else "-"
            if span is None:
                colour, name = NO_TASK, NO_TASK_NAME.replace("task", unit(run.protocol))
            elif colours is not None:
                colour = colours[robot.id, span.task]
                name = f"{unit(run.protocol)} {task_name(robot.id, span.task, len(run.robots))}"
                name += f" ({span.outcome})" if span.outcome != "completed" else ""
            else:
                colour, name, dashes = robot_colour(i), f"path, one colour per robot\n({TOO_MANY})", "-"
            segments.append(points)
            styles.append((colour, dashes))
            named.setdefault(name, (colour, dashes))
            if arrows:
                _direction_arrow(ax, points, colour)
    ax.add_collection(LineCollection(segments, colors=[c for c, _ in styles], linestyles=[d for _, d in styles],
                                     linewidths=2.0, zorder=3))
    return [Line2D([], [], color=c, linestyle=d, linewidth=2.5, label=n) for n, (c, d) in named.items()]


def _direction_arrow(ax: Axes, points: np.ndarray, colour: str) -> None:
    """An arrowhead half way along a path piece, pointing the way the robot drove."""
    steps = np.diff(points, axis=0)
    along = np.concatenate([[0.0], np.cumsum(np.hypot(steps[:, 0], steps[:, 1]))])
    half = along[-1] / 2
    k = int(np.searchsorted(along, half)) - 1  # along[k] < half <= along[k + 1]: a step that moves
    mid = np.array([np.interp(half, along, points[:, 0]), np.interp(half, along, points[:, 1])])
    ax.annotate("", xy=tuple(mid + 1e-3 * steps[k]), xytext=tuple(mid),
                arrowprops={"arrowstyle": "-|>", "color": colour, "mutation_scale": 14, "linewidth": 0}, zorder=3)


def _incident_places(ax: Axes, run: Run) -> list[Artist]:
    """docs/contract.md §4 events that have a place: collisions and where batteries ran out."""
    handles: list[Artist] = []
    placed = [i for i in incidents(run) if i.place is not None]
    for kind, (marker, colour, label) in INCIDENT_STYLE.items():
        points = [i.place for i in placed if i.kind == kind and i.place is not None]
        if points:
            handles.append(ax.scatter([p[0] for p in points], [p[1] for p in points], marker=marker, s=140,
                                      color=colour, edgecolors="white", linewidths=0.6, zorder=6, label=label))
    return handles


def _poses(ax: Axes, run: Run, labels: list[Label], small: bool) -> list[Artist]:
    """Footprints at the start (dashed, a ring) and at the end (shaded, an arrow along the heading).

    A big fleet gets small rings and arrows and no robot names, or they would hide the paths."""
    from matplotlib.collections import PolyCollection
    from matplotlib.lines import Line2D

    finals = [run.results[r.id].final_pose for r in run.robots]
    start = [footprint_at(r, *r.pose) for r in run.robots]
    end = [footprint_at(r, *pose) for r, pose in zip(run.robots, finals)]
    ax.add_collection(PolyCollection(start, facecolors="none", edgecolors="#333333", linestyles="--",
                                     linewidths=0.9, zorder=4))
    ax.add_collection(PolyCollection(end, facecolors="#33333333", edgecolors="#333333", linewidths=0.9, zorder=4))
    ax.scatter([r.pose[0] for r in run.robots], [r.pose[1] for r in run.robots], s=20 if small else 90,
               facecolors="none", edgecolors="#333333", linewidths=0.8 if small else 1.2, zorder=5)
    x, y, theta = np.array(finals, dtype=float).reshape(-1, 3).T
    ax.quiver(x, y, np.cos(theta), np.sin(theta), angles="xy", scale_units="inches", scale=10 if small else 3.5,
              pivot="tail", width=0.003 if small else 0.004, headwidth=4, headlength=4, color="#333333", zorder=5)
    if not small:
        for r, outline in zip(run.robots, start):
            below, above = (r.pose[0], outline[:, 1].min(), False), (r.pose[0], outline[:, 1].max(), True)
            labels.append(Label(r.id, (below, above), bold=True))
    return [
        Line2D([], [], color="#333333", linestyle="--", marker="o", markerfacecolor="none", markersize=9,
               label="start pose, footprint"),
        Line2D([], [], color="#333333", marker=">", label="end pose (arrow: heading),\nfootprint shaded"),
    ]


def _place_labels(fig: Figure, ax: Axes, labels: list[Label]) -> None:
    """Write each label at its first place where it covers no label written before and stays inside the
    axes; a label with no such place is left out. Placed after the layout is final, so extents are exact."""
    fig.draw_without_rendering()
    frame = ax.get_window_extent()
    taken: list[Bbox] = []
    for label in labels:
        for x, y, above in label.places:
            text = ax.annotate(label.text, (x, y), xytext=(0, 3 if above else -3), textcoords="offset points",
                               ha="center", va="bottom" if above else "top", fontsize=8, in_layout=False,
                               fontweight="bold" if label.bold else "normal",
                               color="#222222" if label.bold else "#4a3f2b")
            box = text.get_window_extent()
            inside = frame.contains(box.x0, box.y0) and frame.contains(box.x1, box.y1)
            if inside and not any(box.overlaps(b) for b in taken):
                taken.append(box)
                break
            text.remove()
