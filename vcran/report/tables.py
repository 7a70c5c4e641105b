"""The KPI table written out: Markdown for people (``kpi.md``, and stdout), CSV for spreadsheets (``kpi.csv``).

Both come from one column list, so the two files always have the same columns in the same order. The
Markdown rounds for reading (shares in percent); the CSV keeps plain numbers (shares as fractions) and
leaves a cell empty where there is no value (no completed task: no latency).
"""

from __future__ import annotations

import csv
import io
from collections.abc import Callable
from dataclasses import dataclass

from vcran.report.folder import JobFigures
from vcran.report.kpi import Kpi

#: Above this many robots, stdout shows the first ones and the fleet row; the files have every robot.
CONSOLE_ROBOTS = 20


@dataclass(frozen=True, slots=True)
class Column:
    title: str  # Markdown header
    name: str  # CSV header
    value: Callable[[Kpi], float | int | str | None]
    text: Callable[[float | int | str], str] = str


def _pct(v: float | int | str) -> str:
    return f"{float(v):.1%}"


def _fixed(digits: int) -> Callable[[float | int | str], str]:
    return lambda v: f"{float(v):.{digits}f}"


COLUMNS = (
    Column("robot", "robot", lambda k: k.robot),
    Column("completed", "completed", lambda k: k.completed),
    Column("timed out", "cancelled_timeout", lambda k: k.cancelled["timeout"]),
    Column("cancelled", "cancelled_cancelled", lambda k: k.cancelled["cancelled"]),
    Column("action failed", "cancelled_action_failed", lambda k: k.cancelled["action_failed"]),
    Column("distance (m)", "distance_m", lambda k: k.distance, _fixed(2)),
    Column("busy", "busy_share", lambda k: k.busy_share, _pct),
    Column("idle", "idle_share", lambda k: k.idle_share, _pct),
    Column("mean latency (s)", "mean_latency_s", lambda k: k.latency, _fixed(1)),
    Column("parts moved", "parts_moved", lambda k: k.parts_moved),
    Column("errors", "errors", lambda k: k.errors),
)
#: A VDA 5050 run's (docs/report.md "VDA 5050 runs"): orders for tasks; a vehicle has no task timeout, it
#: rejects orders (§6.6.4) instead. The other names are OPIL's, for the analogous counts.
VDA_COLUMNS = tuple(Column("rejected", "rejected", lambda k: k.rejected) if c.name == "cancelled_timeout" else c
                    for c in COLUMNS)
#: docs/contract.md §4 columns, shown when a run has any battery, downtime, collision or docs/contract.md §4 cancel (docs/report.md).
S4_COLUMNS = (
    Column("battery empty", "cancelled_battery_empty", lambda k: k.cancelled["battery_empty"]),
    Column("motion failed", "cancelled_motion_failed", lambda k: k.cancelled["motion_failed"]),
    Column("collision", "cancelled_collision", lambda k: k.cancelled["collision"]),
    Column("energy per job (Ah)", "energy_per_job_ah", lambda k: k.energy_per_job, _fixed(4)),
    Column("downtime (s)", "downtime_s", lambda k: k.downtime, _fixed(1)),
    Column("collisions", "collisions", lambda k: k.collisions),
)

#: docs/contract.md §12 columns, shown when the run's robots had safety fields (docs/report.md).
S12_COLUMNS = (
    Column("deadlock", "cancelled_deadlock", lambda k: k.cancelled["deadlock"]),
    Column("blocks", "blocks", lambda k: k.blocks),
    Column("blocked (s)", "blocked_s", lambda k: k.blocked_time, _fixed(1)),
    Column("deadlocks", "deadlocks", lambda k: k.deadlocks),
)


def columns(rows: list[Kpi]) -> tuple[Column, ...]:
    """The table's columns (a VDA 5050 run's :data:`VDA_COLUMNS`): the docs/contract.md §4 ones only when the
    run has something to show in them, the docs/contract.md §12 ones when its robots had safety fields."""
    s4 = any(k.energy_per_job is not None or k.downtime or k.collisions or any(c.value(k) for c in S4_COLUMNS[:3])
             for k in rows)
    s12 = any(k.blocks is not None for k in rows)
    first = VDA_COLUMNS if any(k.rejected is not None for k in rows) else COLUMNS
    return first + (S4_COLUMNS if s4 else ()) + (S12_COLUMNS if s12 else ())


def markdown(rows: list[Kpi]) -> str:
    """A Markdown table with padded columns, so it reads as well in a terminal as rendered."""
    cols = columns(rows)
    cells = [[c.title for c in cols]]
    for row in rows:
        values = [c.value(row) for c in cols]
        cells.append(["–" if v is None else c.text(v) for c, v in zip(cols, values)])
    if len(rows) > 1:  # the fleet row, in bold
        cells[-1] = [f"**{text}**" for text in cells[-1]]
    widths = [max(len(line[i]) for line in cells) for i in range(len(cols))]

    def line(texts: list[str]) -> str:
        padded = [t.ljust(w) if i == 0 else t.rjust(w) for i, (t, w) in enumerate(zip(texts, widths))]
        return "| " + " | ".join(padded) + " |"

    rule = "|" + "|".join("-" * (w + 1) + (":" if i else "-") for i, w in enumerate(widths)) + "|"
    return "\n".join([line(cells[0]), rule, *(line(c) for c in cells[1:])]) + "\n"


def console(rows: list[Kpi]) -> str:
    """The Markdown table for stdout: at most :data:`CONSOLE_ROBOTS` robot rows and the fleet row."""
    robots, fleet = rows[:-1], rows[-1]
    if len(robots) <= CONSOLE_ROBOTS:
        return markdown(rows)
    shown = markdown([*robots[:CONSOLE_ROBOTS], fleet])
    return shown + f"({len(robots) - CONSOLE_ROBOTS} more robots in kpi.md and kpi.csv)\n"


def csv_text(rows: list[Kpi]) -> str:
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    cols = columns(rows)
    writer.writerow([c.name for c in cols])
    for row in rows:
        writer.writerow(["" if (v := c.value(row)) is None else _plain(v) for c in cols])
    return out.getvalue()


def _plain(value: float | int | str) -> str:
    """Floats to four decimals (0.1 mm, 0.1 ms, 0.01 %), without trailing zeros: 18.8284, 57, 0.5."""
    return f"{value:.4f}".rstrip("0").rstrip(".") if isinstance(value, float) else str(value)


def jobs_markdown(jobs: JobFigures) -> str:
    """A closed-loop run's job KPIs (docs/contract.md §9) as a two-column Markdown table."""
    def seconds(v: float | None) -> str:
        return "–" if v is None else f"{v:.1f}"

    rows = [
        ("jobs arrived", str(jobs.arrived)), ("completed", str(jobs.completed)), ("failed", str(jobs.failed)),
        ("open at the end", str(jobs.open)), ("late", str(jobs.late)), ("done per hour", f"{jobs.done_per_hour:.1f}"),
        ("lead time mean (s)", seconds(jobs.lead_mean)), ("lead time p50 (s)", seconds(jobs.lead_p50)),
        ("lead time p95 (s)", seconds(jobs.lead_p95)), ("lead time max (s)", seconds(jobs.lead_max)),
        ("fleet utilisation", f"{jobs.utilisation:.1%}"),
    ]
    width = max(len(k) for k, _ in rows)
    value_width = max(len(v) for _, v in rows)
    lines = [f"| {'job KPI'.ljust(width)} | {'value'.rjust(value_width)} |",
             f"|{'-' * (width + 2)}|{'-' * (value_width + 1)}:|"]
    lines += [f"| {k.ljust(width)} | {v.rjust(value_width)} |" for k, v in rows]
    return "\n".join(lines) + "\n"
