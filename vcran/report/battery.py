"""The battery figure (docs/contract.md §4): each robot's published charge over time, with its low level.

Drawn from the ``battery_state`` records of the trace, which change on every percent step (docs/robots.md), as
steps: what a fleet manager reading Orion saw. Runs without batteries get no such figure. Above
:data:`ROBOTS_DRAWN` robots the first ones are drawn and the title says so; every robot's energy is in the
KPI tables all the same.
"""

from __future__ import annotations

from pathlib import Path

from vcran.report.folder import Run
from vcran.report.style import INCIDENT_STYLE, robot_colour, save

ROBOTS_DRAWN = 20


def draw_battery(run: Run, path: Path) -> None:
    from matplotlib.figure import Figure

    fig = Figure(figsize=(11, 5), layout="constrained")
    ax = fig.subplots()
    drawn = [rid for rid in run.robot_ids if rid in run.batteries][:ROBOTS_DRAWN]
    for index, rid in enumerate(drawn):
        points = run.batteries[rid]
        ts = [t for t, _ in points] + [run.sim_time]
        ps = [100.0 * p for _, p in points] + [100.0 * points[-1][1]]
        ax.step(ts, ps, where="post", color=robot_colour(index), linewidth=1.4, label=rid)
    marker, colour, label = INCIDENT_STYLE["battery_empty"]
    empties = [(float(e["t"]), e["robot"]) for e in run.events if e["event"] == "battery_empty" and e["robot"] in drawn]
    if empties:
        ax.scatter([t for t, _ in empties], [0.0] * len(empties), marker=marker, color=colour, s=80, zorder=5,
                   label=label, clip_on=False)
    ax.set_xlim(0, max(run.sim_time, 1.0))
    ax.set_ylim(0, 100)
    ax.set_xlabel("simulated time (s)")
    ax.set_ylabel("battery (%), as published")
    ax.grid(True, color="#eeeeee", linewidth=0.6)
    more = len([r for r in run.robot_ids if r in run.batteries]) - len(drawn)
    ax.set_title(f"{run.scenario}: battery per robot" + (f" (first {len(drawn)}; {more} more in kpi.md)" if more else ""))
    fig.legend(loc="outside right upper", fontsize=8, frameon=False)
    save(fig, path)
