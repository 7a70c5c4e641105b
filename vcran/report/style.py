"""Colours and markers shared by the figures, so a task or a state looks the same in the layout and the timeline.

Tasks get colours of their own only while there are few enough to tell apart (:data:`TASK_PALETTE`,
nine colours); with more, a legend of colours stops meaning anything and the
layout colours paths by robot instead (docs/report.md).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from vcran.report.spans import History

DPI = 120

#: States in grey, darker the more the robot does: no state can be mistaken for a task's colour.
STATE_COLOURS = {
    "WAITING": "#f4f4f4",
    "TASK": "#c4c4c4",
    "MOTION": "#7a7a7a",
    "ACTION": "#2e2e2e",
    # a VDA 5050 vehicle's lane (vcran.report.vda5050): no order, an order standing, driving; ACTION as above
    "IDLE": "#f4f4f4",
    "ORDER": "#c4c4c4",
    "DRIVING": "#7a7a7a",
}

#: Cancel reason -> (marker, colour) on the timeline.
REASON_STYLE = {
    "timeout": ("X", "#c0392b"),
    "cancelled": ("D", "#7d3c98"),
    "action_failed": ("^", "#d35400"),
    # docs/contract.md §4: the robot stopped on its own
    "battery_empty": ("v", "#b7950b"),
    "motion_failed": ("s", "#a04000"),
    "collision": ("*", "#e74c3c"),
    # docs/contract.md §12: the scenario cancels deadlocked robots' tasks (on_deadlock = "cancel")
    "deadlock": ("h", "#1a5276"),
}
#: Reasons the legend always lists; the docs/contract.md §4 ones are listed when they occur.
CORE_REASONS = ("timeout", "cancelled", "action_failed")

#: docs/contract.md §4 and §12 incidents -> (marker, colour, legend label), on the timeline's state lane and, where the event
#: has a place, on the layout.
INCIDENT_STYLE = {
    "fault": ("P", "#6e2c00", "fault injected"),
    "battery_low": ("d", "#b7950b", "battery low"),
    "battery_empty": ("v", "#b7950b", "battery empty (robot stopped)"),
    "collision": ("*", "#e74c3c", "collision"),
    # docs/contract.md §12: a robot's protective field entered (where it began to brake), robots stopped on one another
    "blocked": ("o", "#f39c12", "blocked (field entered)"),
    "deadlock": ("h", "#1a5276", "deadlock"),
    # VDA 5050: an order or order update the vehicle refused (§6.6.4), which never becomes a bar
    "order_rejected": ("X", "#922b21", "order rejected"),
}

#: matplotlib's tab10 without its grey, which the states and "no task" use.
TASK_PALETTE = (
    "#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd",
    "#8c564b", "#e377c2", "#bcbd22", "#17becf",
)
#: Task bars when tasks are too many for colours of their own.
TASK_NEUTRAL = "#8da0cb"
NO_TASK = "#999999"


def task_colours(histories: dict[str, History]) -> dict[tuple[str, str], str] | None:
    """(robot, task) -> colour for every task of the run, or ``None`` when there are too many to colour."""
    tasks = [(h.robot, s.task) for h in histories.values() for s in h.tasks]
    if len(tasks) > len(TASK_PALETTE):
        return None
    return {key: TASK_PALETTE[i] for i, key in enumerate(tasks)}


def unit(protocol: str) -> str:
    """What a robot's unit of work is called in the figures: OPIL's task, a VDA 5050 order."""
    return "order" if protocol == "vda5050" else "task"


def robot_colour(index: int) -> str:
    return TASK_PALETTE[index % len(TASK_PALETTE)]


def task_name(robot: str, task: str, robots: int) -> str:
    """How a task is named in legends: its label, prefixed by its robot when there are several."""
    return task if robots == 1 else f"{robot}: {task}"


def save(fig: Any, path: Path) -> None:
    """Write a figure in the format its suffix names. An SVG gets no date and fixed element ids (matplotlib
    salts them with a random uuid by default), so that the same run gives the same file."""
    import matplotlib

    if path.suffix == ".svg":
        with matplotlib.rc_context({"svg.hashsalt": "vcran"}):
            fig.savefig(path, dpi=DPI, metadata={"Date": None})
    else:
        fig.savefig(path, dpi=DPI)
