"""``vcran sweep SWEEP --out DIR [--workers N] [--cluster ADDRESS] [--keep-runs]`` (docs/contract.md §10, docs/sweeps.md).

Runs every variant × seed of a sweep file, here (a local process pool sized to the machine) or on a Dask
cluster, and writes one row per run into ``DIR/runs.csv`` and ``DIR/runs.parquet``, plus comparison
figures when matplotlib is installed. Exit status: 0 when every run ran, 1 when some failed (their rows
say why), 2 for a sweep that cannot start or whose Dask scheduler went away part way, 130 on Ctrl-C (143 on
SIGTERM; in each case the rows done are written all the same, into ``DIR.incomplete``).

``DIR`` is written like a run folder (docs/contract.md §6, vcran.io.runfolder), by the code ``vcran.run_sweep`` and
``SweepResult.write`` use too (vcran.sweep.folder): everything, the kept runs of the workers included, goes
into ``DIR.incomplete``, renamed to ``DIR`` when the sweep has ended. A sweep that is interrupted or fails
leaves ``DIR.incomplete`` (the rows done are there) and any earlier ``DIR`` as it was; an earlier sweep's (or
run's) ``DIR`` is replaced whole, and any other folder refused before a run starts.
"""

from __future__ import annotations

import argparse
import shutil
import sys
import time
from pathlib import Path

from vcran.commands._pool import add_pool_arguments, check_pool_options, pool_for
from vcran.commands._signals import Terminated
from vcran.io.runfolder import SWEEP_FORMATS

HELP = "run a scenario's variants x seeds (a sweep file) into one KPI table, locally or on a Dask cluster"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("sweep", type=Path, help="sweep file (TOML): scenario, seeds, [grid], [[variants]]")
    parser.add_argument("--out", type=Path, required=True, metavar="DIR",
                        help="output folder, written as DIR.incomplete and renamed when the sweep has ended; an "
                             "earlier sweep's folder is replaced whole, a folder vcran did not write is refused")
    add_pool_arguments(parser, "the runs", "one per CPU")
    parser.add_argument("--keep-runs", action="store_true",
                        help="keep every run's folder (trace, events, summary, scenario.toml) in DIR/runs/NNNN")
    parser.add_argument("--format", choices=SWEEP_FORMATS, default="png", help="figure format (default: png)")
    parser.add_argument("--quiet", action="store_true", help="print nothing but errors (no progress either)")


def run(args: argparse.Namespace) -> int:
    from vcran.commands import CommandError
    from vcran.sweep.folder import compared, finish, have_matplotlib, open_folder
    from vcran.sweep.progress import Progress
    from vcran.sweep.runs import execute
    from vcran.sweep.spec import SweepError, load
    from vcran.sweep.table import have_parquet

    check_pool_options(args)
    try:
        sweep = load(args.sweep)
    except SweepError as exc:
        raise CommandError(str(exc)) from None
    runs = len(sweep.seeds) * len(sweep.variants)
    out: Path = args.out
    work = open_folder(out)  # refuses a folder vcran did not write (exit 2), before any run starts
    try:
        pool = pool_for(args, runs)
    except BaseException:
        shutil.rmtree(work, ignore_errors=True)  # nothing ran: no folder left behind
        raise
    if not args.quiet:
        print(f"sweep {sweep.name}: {len(sweep.variants)} variant(s) x {len(sweep.seeds)} seed(s) = {runs} runs "
              f"on {pool.name}", file=sys.stderr)
    progress = Progress(sys.stderr, runs, quiet=args.quiet)
    start = time.perf_counter()
    try:
        # the workers (local processes, or Dask's on a shared file system) write kept runs into the staging folder
        result = execute(sweep, pool, keep_runs=work.resolve() if args.keep_runs else None,
                         on_row=lambda row: progress.update(row["error"] is not None))
    finally:
        progress.close()
        pool.close()
    wall = time.perf_counter() - start

    # the tables and, unless interrupted, the figures, then DIR.incomplete renamed to DIR (run_sweep's code);
    # an interrupted sweep stays DIR.incomplete: its rows there, DIR untouched
    files = finish(work, out, sweep, result.rows, result.columns, interrupted=result.interrupted, fmt=args.format)
    if not have_parquet() and not args.quiet:
        print("vcran sweep: runs.parquet not written: pyarrow is not installed (pip install 'vcran[sweep]')",
              file=sys.stderr)
    if not result.interrupted and compared(sweep) and not have_matplotlib() and not args.quiet:
        print("vcran sweep: no figures: matplotlib is not installed (pip install 'vcran[report]')", file=sys.stderr)

    done, failed = len(result.rows), result.failed
    if result.lost is not None:  # the cluster went away: surroundings that refuse, the rows done kept
        raise CommandError(f"{result.lost}: {done} of {runs} runs done ({failed} failed); their rows are in "
                           f"{', '.join(str(f) for f in files)}")
    if result.interrupted:
        print(f"vcran sweep: interrupted: {done} of {runs} runs done ({failed} failed); their rows are in "
              f"{', '.join(str(f) for f in files)}", file=sys.stderr)
        return 143 if isinstance(result.interrupt, Terminated) else 130  # SIGTERM, as every command reports it
    if not args.quiet:
        print(f"{runs} runs in {wall:.1f} s: {done - failed} ran, {failed} failed")
        for r in [r for r in result.rows if r["error"] is not None][:5]:
            print(f"  run {r['run']} (seed {r['seed']}): {r['error']}")
        print(f"  written: {', '.join(str(f) for f in files)}")
    return 1 if failed else 0

