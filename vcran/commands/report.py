"""``vcran report DIR --out REPORT_DIR``: figures and KPI tables from a run's output folder (docs/contract.md §8)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

HELP = ("draw a run's layout and timeline and tabulate its KPIs, from the folder `vcran run --out` wrote (or "
        "`vcran live --out`; `vcran manage --out`: its jobs and fleet figure)")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("dir", type=Path, help="a run's output folder (summary.json, events.jsonl.zst, trace.jsonl.zst, legs.npy; format 1's files too)")
    parser.add_argument("--out", type=Path, required=True, metavar="REPORT_DIR", help="report folder (created if missing)")
    parser.add_argument("--format", choices=("png", "svg"), default="png", help="figure format (default: png)")
    parser.add_argument("--timeline-pages", type=_positive, default=None, metavar="N",
                        help="draw at most N timeline pages of 20 robots each (default: 5)")


def run(args: argparse.Namespace) -> int:
    return write(args.dir, args.out, args.format, args.timeline_pages)


def write(run_dir: Path, out: Path, fmt: str = "png", timeline_pages: int | None = None, quiet: bool = False) -> int:
    """Write the report and print the KPI table and the files (unless quiet). A folder that is no run's
    output, or no matplotlib, is a CommandError: one line on stderr and exit status 2."""
    from vcran.commands import CommandError
    from vcran.report import ReportError, write_report
    from vcran.report.tables import console, jobs_markdown

    try:
        report = write_report(run_dir, out, fmt, timeline_pages)
    except ReportError as exc:
        raise CommandError(str(exc)) from None
    if not quiet:
        if report.kpis:
            print(console(report.kpis), end="")
        if report.jobs is not None:
            print(jobs_markdown(report.jobs), end="")
        print(f"report in {out}/: {', '.join(f.name for f in report.files)}")
    if report.note is not None:
        print(f"vcran report: {report.note}", file=sys.stderr)
    return 0


def _positive(text: str) -> int:
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {value}")
    return value
