"""Comparison figures of a sweep, in ``vcran report``'s style: each KPI against each swept parameter.

One figure per parameter (``kpi-by-simulation.task_timeout.png``), one panel per KPI. The parameter's
values are the x positions, in the order the sweep lists them (values may be numbers, names or poses, so
they are categories, not a scale), labelled as the runs table writes them (:mod:`vcran.sweep.labels`). A point is the mean over the runs with that value, its bar the range
(min to max) over them, and the faint dots the single runs: with one parameter, the spread over seeds.
With several, each combination of the other parameters is its own line while there are few enough to tell
apart (:data:`vcran.report.style.TASK_PALETTE`), and all are pooled otherwise. Failed runs have no KPIs
and are left out.
"""

from __future__ import annotations

import textwrap
from pathlib import Path
from typing import Any

from vcran.report.style import TASK_PALETTE, save
from vcran.sweep.labels import Labels
from vcran.sweep.spec import Sweep
from vcran.sweep.worker import Row

#: KPIs drawn, when the runs have them (closed-loop figures only for closed-loop runs, `rejected` for VDA 5050 ones).
DRAWN = ("sim_time", "tasks_completed", "tasks_cancelled", "rejected", "distance", "errors", "collisions", "battery_used",
         "blocked_time", "deadlocks", "jobs_done_per_hour", "jobs_lead_time_mean", "utilisation")
#: Drawn only when some run has any: most fleets never collide, and a panel of zeros says nothing new.
UNLESS_ALL_ZERO = frozenset({"collisions"})


def draw(sweep: Sweep, rows: list[Row], out: Path, fmt: str = "png") -> list[Path]:
    ok = [r for r in rows if r.get("error") is None]
    kpis = drawn(ok)
    if not ok or not kpis:
        return []
    parameters = (["label"] if sweep.labelled else []) + list(sweep.parameters)
    files = []
    for p in parameters:
        path = out / f"kpi-by-{_slug(p)}.{fmt}"
        save(figure(sweep, ok, p, [q for q in parameters if q != p], kpis), path)
        files.append(path)
    return files


def drawn(rows: list[Row]) -> list[str]:
    """The KPIs that get a panel: those the runs have (a closed loop's, a battery's), collisions if any."""
    return [k for k in DRAWN if any(r.get(k) is not None for r in rows)
            and (k not in UNLESS_ALL_ZERO or any(r.get(k) for r in rows))]


def figure(sweep: Sweep, rows: list[Row], parameter: str, others: list[str], kpis: list[str]) -> Any:
    """The matplotlib ``Figure`` of ``kpis`` against ``parameter``, one line per combination of ``others``."""
    from matplotlib.figure import Figure

    labels = {p: Labels(p, [r[p] for r in rows]) for p in [parameter, *others]}
    xs = list(dict.fromkeys(labels[parameter](r[parameter]) for r in rows))
    ticks = [_short(x) for x in xs]
    groups: dict[str, list[Row]] = {}
    for r in rows:
        groups.setdefault(", ".join(f"{q} = {labels[q](r[q])}" for q in others), []).append(r)
    if len(groups) > len(TASK_PALETTE):
        groups = {f"all {len(groups)} combinations of the other parameters": rows}
    columns = min(len(kpis), 3)
    lines = -(-len(kpis) // columns)
    fig = Figure(figsize=(4.2 * columns, 3.0 * lines + 0.8 + (0.3 + 0.16 * len(groups) if others else 0)))
    fig.suptitle(f"{sweep.name}: KPIs by {parameter} ({len(sweep.seeds)} seed(s) per variant)", fontsize=10)
    for n, kpi in enumerate(kpis):
        ax = fig.add_subplot(lines, columns, n + 1)
        for g, (name, members) in enumerate(groups.items()):
            colour = TASK_PALETTE[g % len(TASK_PALETTE)]
            shift = (g - (len(groups) - 1) / 2) * 0.08
            dots_x: list[float] = []
            dots_y: list[float] = []
            at: list[float] = []
            means: list[float] = []
            low: list[float] = []
            high: list[float] = []
            for i, x in enumerate(xs):
                values = [r[kpi] for r in members if labels[parameter](r[parameter]) == x and r.get(kpi) is not None]
                if values:
                    mean = sum(values) / len(values)
                    dots_x += [i + shift] * len(values)
                    dots_y += values
                    at.append(i + shift)
                    means.append(mean)
                    low.append(mean - min(values))
                    high.append(max(values) - mean)
            ax.scatter(dots_x, dots_y, s=8, color=colour, alpha=0.3, linewidths=0)
            ax.errorbar(at, means, yerr=[low, high], fmt="o-", color=colour, capsize=3, markersize=4,
                        linewidth=1, label=name if n == 0 else None)
        ax.set_title(kpi, fontsize=9)
        ax.set_xticks(range(len(xs)), ticks, fontsize=8)
        ax.set_xlabel(parameter, fontsize=8)
        ax.tick_params(axis="y", labelsize=8)
        ax.grid(True, axis="y", color="#e0e0e0", linewidth=0.6)
        ax.set_axisbelow(True)
    legend = 0.3 + 0.16 * len(groups) if others else 0.0  # inches below the panels
    height = fig.get_figheight()
    tall = 0.15 if any("\n" in t for t in ticks) else 0.0  # a tick label on two lines
    fig.subplots_adjust(left=0.07, right=0.98, top=1 - 0.55 / height, bottom=(legend + 0.5 + tall) / height,
                        hspace=0.55, wspace=0.25)
    if others:
        fig.legend(loc="lower center", fontsize=7, frameon=False, ncols=1)
    return fig


def _short(label: str, width: int = 18) -> str:
    """A tick label on at most two lines of ``width`` characters, broken at spaces, cut with ``…``."""
    if len(label) <= width:
        return label
    return "\n".join(textwrap.wrap(label, width, max_lines=2, placeholder="…", break_on_hyphens=False))


def _slug(name: str) -> str:
    return "".join(c if c.isalnum() or c in "._-" else "_" for c in name.replace("*", "each"))

