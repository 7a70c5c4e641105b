"""Reports a person can look at, from a run's output folder: a layout figure, a timeline, a KPI table.

``vcran report DIR --out REPORT_DIR`` and ``vcran run --report`` both call :func:`write_report`. The
figures need matplotlib, an optional extra (``pip install 'vcran[report]'``); it is imported only here,
when a report is asked for, so ``vcran run`` starts as fast without it. Figures are drawn on
``matplotlib.figure.Figure`` objects, never through pyplot, so no GUI backend is ever touched and a
report can be written from any thread or process: PNG goes through Agg, SVG through the SVG backend.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from vcran.report.folder import JobFigures, ReportError, Run, read_run
from vcran.report.kpi import Kpi, kpis
from vcran.report.spans import histories
from vcran.report.tables import csv_text, jobs_markdown, markdown

__all__ = [
    "FORMATS", "MatplotlibMissing", "Report", "ReportError", "Run", "read_run", "require_matplotlib", "write_report",
]

FORMATS = ("png", "svg")
#: Timeline pages drawn by default: 5 pages of 20, the first 100 robots.
TIMELINE_PAGES = 5


class MatplotlibMissing(ReportError):
    """The ``report`` extra is not installed."""


@dataclass(frozen=True, slots=True)
class Report:
    files: list[Path]
    kpis: list[Kpi]
    #: A closed-loop run's job KPIs, else None.
    jobs: JobFigures | None
    #: Robots the timeline left out (beyond its page limit); they are in the KPI tables all the same.
    robots_not_drawn: int
    #: What the folder could not give, said to the user (a ``vcran manage`` folder's); None for a run's.
    note: str | None = None


def require_matplotlib() -> None:
    """Fail with the install hint before any work is done, rather than half way through a report."""
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        raise MatplotlibMissing(
            "figures need matplotlib, which is not installed: pip install 'vcran[report]'"
        ) from None


def write_report(run_dir: Path, out: Path, fmt: str = "png", timeline_pages: int | None = None) -> Report:
    """Write ``layout``, ``timeline`` (paged above 20 robots, at most ``timeline_pages`` pages, default
    :data:`TIMELINE_PAGES`), ``battery`` (a run with batteries), for a closed-loop run ``fleet`` (jobs
    waiting, done, robots busy over time), ``kpi.md`` and ``kpi.csv`` into ``out``. A ``vcran manage``
    folder gets ``fleet`` and ``kpi.md`` (its jobs) only, and the report's ``note`` says why
    (:mod:`vcran.report.managed`)."""
    if fmt not in FORMATS:
        raise ValueError(f"format {fmt!r}: choose one of {', '.join(FORMATS)}")
    require_matplotlib()
    from vcran.report.managed import is_managed, read_managed, write_managed

    if is_managed(run_dir):
        managed = read_managed(run_dir)
        files, note = write_managed(managed, out, fmt)
        return Report(files, [], managed.jobs, 0, note)
    from vcran.report.layout import draw_layout
    from vcran.report.timeline import ROBOTS_PER_PAGE, draw_timeline, pages

    run = read_run(run_dir)
    out.mkdir(parents=True, exist_ok=True)
    history = histories(run)
    files = [out / f"layout.{fmt}"]
    draw_layout(run, history, files[0])

    chunks = pages(run.robot_ids, timeline_pages or TIMELINE_PAGES)
    drawn = sum(len(c) for c in chunks)
    for n, chunk in enumerate(chunks, start=1):
        if len(chunks) == 1 and drawn == len(run.robots):
            name, note = f"timeline.{fmt}", ""
        else:
            name = f"timeline-{n:02d}.{fmt}"
            first = (n - 1) * ROBOTS_PER_PAGE + 1
            note = f"page {n} of {len(chunks)}: robots {first}-{first + len(chunk) - 1} of {len(run.robots)}"
            if n == len(chunks) and drawn < len(run.robots):
                note += f"; the other {len(run.robots) - drawn} are in kpi.md only (raise --timeline-pages)"
        files.append(out / name)
        draw_timeline(run, history, chunk, files[-1], note)

    if run.batteries:  # docs/contract.md §4
        from vcran.report.battery import draw_battery

        files.append(out / f"battery.{fmt}")
        draw_battery(run, files[-1])

    if run.jobs is not None:  # a closed loop: the fleet over time
        from vcran.report.fleet import draw_fleet, fleet_series

        files.append(out / f"fleet.{fmt}")
        draw_fleet(run, fleet_series(run, history), files[-1])

    rows = kpis(run, history)
    for name, text in (("kpi.md", _kpi_markdown(run, rows)), ("kpi.csv", csv_text(rows))):
        (out / name).write_text(text, encoding="utf-8")
        files.append(out / name)
    return Report(files, rows, run.jobs, len(run.robots) - drawn)


def _kpi_markdown(run: Run, rows: list[Kpi]) -> str:
    text = (f"# KPIs: {run.scenario}\n\nSeed {run.seed}, {run.sim_time:g} s simulated, {len(run.robots)} robot(s). "
            "Columns are defined in vcran's docs/report.md.\n\n" + markdown(rows))
    if run.jobs is not None:
        text += "\n## Jobs\n\nA fleet manager ran this scenario's jobs (docs/outputs.md).\n\n" + jobs_markdown(run.jobs)
    return text
