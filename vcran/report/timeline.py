"""The timeline figure (a Gantt chart): per robot, its RanLogic state over time and the life of each task.

Each robot gets a block of lanes: the top lane is its state band (WAITING / TASK / MOTION / ACTION), the
lanes below hold its tasks from first seen to completion or cancellation. Tasks that were alive at the
same time (one running, others queued behind it) go into separate lanes, so no bar hides another. A
bar is pale while the task waited in the queue and solid once it was the current task; a cancelled
task is hatched and ends in its reason's marker.

A page holds :data:`ROBOTS_PER_PAGE` robots, which keeps lanes and labels readable; bigger fleets get
several pages, up to a limit, and the last page says which robots were left out.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from vcran.report.folder import Run
from vcran.report.incidents import incidents
from vcran.report.spans import OPEN, STATES, History, TaskSpan
from vcran.report.style import (
    CORE_REASONS,
    DPI,
    INCIDENT_STYLE,
    REASON_STYLE,
    STATE_COLOURS,
    TASK_NEUTRAL,
    save,
    task_colours,
    unit,
)
from vcran.report.vda5050 import STATES as VDA_STATES

if TYPE_CHECKING:  # matplotlib is an optional extra, imported when a figure is drawn
    from matplotlib.axes import Axes

ROBOTS_PER_PAGE = 20
WIDTH_IN, LEFT, RIGHT = 13.0, 0.09, 0.97  # figure width; axes sides as fractions of it
TOP_IN, NOTE_IN, BOTTOM_IN = 0.45, 0.2, 1.25  # title; a page note; ticks, axis label and the legend below
LANE_IN = 0.24  # inches of paper per lane unit
STATE_LANE, TASK_LANE, PITCH, GAP = 0.8, 0.6, 0.75, 0.5  # lane heights and spacing, in lane units
LABEL_PT = 7


def pages(robots: tuple[str, ...], max_pages: int) -> list[tuple[str, ...]]:
    """The robots cut into pages of :data:`ROBOTS_PER_PAGE`, at most ``max_pages`` of them."""
    chunks = [robots[i:i + ROBOTS_PER_PAGE] for i in range(0, len(robots), ROBOTS_PER_PAGE)]
    return chunks[:max_pages]


def lanes(tasks: list[TaskSpan]) -> list[int]:
    """A lane per task such that tasks in one lane never overlap in time (greedy, in first-seen order)."""
    ends: list[float] = []
    out = []
    for span in tasks:
        lane = next((i for i, end in enumerate(ends) if end <= span.queued), len(ends))
        if lane == len(ends):
            ends.append(span.end)
        else:
            ends[lane] = span.end
        out.append(lane)
    return out


def draw_timeline(run: Run, histories: dict[str, History], robots: tuple[str, ...], path: Path, note: str = "") -> None:
    """Draw the ``robots`` (one page) into ``path``; ``note`` goes under the title (what this page is)."""
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    colours = task_colours(histories)
    blocks = []  # (robot, y of state lane, [(span, y)])
    y = 0.0
    for rid in robots:
        history = histories[rid]
        task_lanes = lanes(history.tasks)
        blocks.append((rid, y, [(s, y + PITCH * (1 + k)) for s, k in zip(history.tasks, task_lanes)]))
        y += PITCH * (1 + max(task_lanes, default=-1) + 1) + GAP
    top_in = TOP_IN + (NOTE_IN if note else 0.0)
    axes_in = max(y * LANE_IN, 0.9)
    height_in = top_in + axes_in + BOTTOM_IN
    fig = Figure(figsize=(WIDTH_IN, height_in))
    ax = fig.add_axes((LEFT, BOTTOM_IN / height_in, RIGHT - LEFT, axes_in / height_in))
    span_s = max(run.sim_time, 1.0)  # a run that ended at 0 s still gets a time axis
    px_per_s = (RIGHT - LEFT) * WIDTH_IN * DPI / span_s

    ax.set_xlim(0, span_s)
    ax.set_ylim(y - GAP / 2 - PITCH / 2, -PITCH / 2 - GAP / 2)
    marks = _Marks()
    for rid, y0, tasks in blocks:
        for band in histories[rid].bands:
            marks.bar(band.start, band.end, y0, STATE_LANE, STATE_COLOURS[band.state])
        for span, ty in tasks:
            _task(ax, marks, span, ty, colours[rid, span.task] if colours else TASK_NEUTRAL, px_per_s)
        ax.axhline(y0 - PITCH / 2 - GAP / 2, color="#bbbbbb", linewidth=0.6)
    state_lane = {rid: y0 for rid, y0, _ in blocks}
    marked = [i for i in incidents(run) if i.robot in state_lane]
    for incident in marked:  # docs/contract.md §4: on the robot's state lane, where it happened in time
        marker, colour, _ = INCIDENT_STYLE[incident.kind]
        marks.point(incident.t, state_lane[incident.robot], marker, colour)
    marks.draw(ax)

    ax.set_yticks([y0 for _, y0, _ in blocks], [rid for rid, _, _ in blocks], fontsize=8)
    ax.set_xlabel("simulated time (s)")
    ax.grid(True, axis="x", color="#e6e6e6", linewidth=0.6)
    ax.set_axisbelow(True)
    work, vda = unit(run.protocol), run.protocol == "vda5050"
    states, logic = (VDA_STATES, "vehicle") if vda else (STATES, "RanLogic")
    title = f"{run.scenario}: {logic} states and {work} lifetimes"
    fig.suptitle(title + (f"\n{note}" if note else ""), x=(LEFT + RIGHT) / 2, y=1 - 0.08 / height_in,
                 va="top", fontsize=11)

    handles: list[Line2D | Patch] = [Patch(facecolor=STATE_COLOURS[s], edgecolor="#999999", linewidth=0.5,
                                           label=s) for s in states]
    handles += [
        *(() if vda else (Patch(facecolor=TASK_NEUTRAL, alpha=0.35, label="task queued"),)),  # an order has no queue
        Patch(facecolor=TASK_NEUTRAL, label=f"{work} current"),
        Patch(facecolor="white", edgecolor="#555555", hatch="////", label=f"{work} {'not completed' if vda else 'cancelled'}"),
        *(Line2D([], [], marker=m, color=c, linestyle="none", label=f"{'ended' if vda else 'cancel'}: {reason}")
          for reason, (m, c) in REASON_STYLE.items()
          if (reason in CORE_REASONS and not vda) or any(s.outcome == reason for rid in robots for s in histories[rid].tasks)),
        *(Line2D([], [], marker=m, color=c, linestyle="none", label=label)
          for kind, (m, c, label) in INCIDENT_STYLE.items() if any(i.kind == kind for i in marked)),
        Line2D([], [], marker=">", color="#333333", linestyle="none", label=f"{work} open at end of run"),
    ]
    lanes_text = (f"top lane of each robot: its {logic} state; lanes below: its {work}s, "
                  f"from {'accepted' if vda else 'first seen'} to the end")
    fig.legend(handles=handles, loc="lower center", bbox_to_anchor=(0.5, 0.05 / height_in), ncol=6, fontsize=8,
               frameon=False, title=lanes_text + (" (colours as in the layout)" if colours else ""),
               title_fontsize=8)
    save(fig, path)


class _Marks:
    """Bars and markers collected while a page is laid out and drawn as one collection per look: a page
    of twenty busy robots has thousands of bars, which one call each would take tens of seconds to draw."""

    def __init__(self) -> None:
        self.bars: dict[str, tuple[list[list[tuple[float, float]]], list[tuple[str, float]]]] = {}  # hatch ->
        self.points: dict[tuple[str, str], tuple[list[float], list[float]]] = {}
        self.outlines: list[list[tuple[float, float]]] = []

    def bar(self, t0: float, t1: float, y: float, height: float, colour: str, alpha: float = 1.0,
            hatch: str = "") -> None:
        if t1 > t0:
            outlines, faces = self.bars.setdefault(hatch, ([], []))
            outlines.append(_rectangle(t0, t1, y, height))
            faces.append((colour, alpha))

    def outline(self, t0: float, t1: float, y: float, height: float) -> None:
        """A thin white frame: where one task ends as the next begins, the two bars stay apart."""
        self.outlines.append(_rectangle(t0, t1, y, height))

    def point(self, t: float, y: float, marker: str, colour: str) -> None:
        xs, ys = self.points.setdefault((marker, colour), ([], []))
        xs.append(t)
        ys.append(y)

    def draw(self, ax: Axes) -> None:
        from matplotlib.collections import PolyCollection
        from matplotlib.colors import to_rgba

        for hatch, (outlines, faces) in self.bars.items():
            rgba = [to_rgba(colour, alpha) for colour, alpha in faces]
            ax.add_collection(PolyCollection(outlines, facecolors=rgba, edgecolors="#555555" if hatch else "none",
                                             hatch=hatch or None, linewidths=0), autolim=False)
        ax.add_collection(PolyCollection(self.outlines, facecolors="none", edgecolors="white", linewidths=0.8),
                          autolim=False)
        for (marker, colour), (xs, ys) in self.points.items():
            ax.plot(xs, ys, linestyle="none", marker=marker, color=colour, markersize=7, markeredgecolor="white",
                    markeredgewidth=0.6, zorder=4, clip_on=False, scalex=False, scaley=False)


def _task(ax: Axes, marks: _Marks, span: TaskSpan, y: float, colour: str, px_per_s: float) -> None:
    """One task's bar (pale while queued, solid while current, hatched if cancelled), end marker, label."""
    started = span.started if span.started is not None else span.end
    cancelled = span.outcome in REASON_STYLE
    hatch = "////" if cancelled else ""
    marks.bar(span.queued, started, y, TASK_LANE, colour, 0.35, hatch)
    marks.bar(started, span.end, y, TASK_LANE, colour, 1.0, hatch)
    marks.outline(span.queued, span.end, y, TASK_LANE)
    if cancelled:
        marks.point(span.end, y, *REASON_STYLE[span.outcome])
    elif span.outcome == OPEN:
        marks.point(span.end, y, ">", "#333333")
    width_px = (span.end - span.queued) * px_per_s
    for text in ((f"{span.task} ({span.outcome})",) if cancelled else ()) + (span.task,):
        if _text_px(text) + 10 <= width_px:  # a label that fits inside its bar, or none: labels never overlap
            backing = {"boxstyle": "square,pad=0.1", "facecolor": "white", "alpha": 0.6, "linewidth": 0}
            ax.text((span.queued + span.end) / 2, y, text, ha="center", va="center", fontsize=LABEL_PT,
                    color="#111111", clip_on=True, bbox=backing if cancelled else None)  # legible on hatching
            break


def _rectangle(t0: float, t1: float, y: float, height: float) -> list[tuple[float, float]]:
    return [(t0, y - height / 2), (t1, y - height / 2), (t1, y + height / 2), (t0, y + height / 2)]


def _text_px(text: str) -> float:
    """A generous estimate of a label's width (0.62 em per character), so that it never spills out."""
    return len(text) * LABEL_PT * 0.62 * DPI / 72
