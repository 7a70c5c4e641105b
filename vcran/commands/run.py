"""``vcran run SCENARIO --out DIR [--manager module:Class]``: simulate as fast as possible.

The scenario's message script plays the fleet manager, or, with ``--manager`` or a scenario that names
its ``[manager]``, a fleet manager runs its jobs in a closed loop (docs/contract.md §9). Both go through
:func:`vcran.api.run`, the path of :func:`vcran.simulate`.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from vcran.commands import MANAGER_OPTIONS, CommandError, add_scenario_argument, check_out, load_scenario
from vcran.commands._signals import StopSignals

if TYPE_CHECKING:
    from vcran.api import Result
    from vcran.sim.model import Model

HELP = "simulate a scenario with its message script, or its jobs with a fleet manager, as fast as possible"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_scenario_argument(parser, "")
    parser.add_argument("--out", type=Path, required=True, metavar="DIR", help="output folder (created if missing)")
    parser.add_argument("--manager", metavar="MODULE:CLASS",
                        help="run the scenario's jobs with this fleet manager (default: the scenario's [manager]), "
                             "e.g. vcran.managers:Dispatcher" + MANAGER_OPTIONS)
    parser.add_argument("--quiet", action="store_true", help="print nothing but errors (no progress bar either)")
    parser.add_argument("--report", action="store_true",
                        help="then write the report (figures, KPI tables) into DIR/report; needs vcran[report]")
    parser.add_argument("--view", action="store_true",
                        help="then write the run as one interactive page, DIR/view.html (vcran view; docs/view.md)")


def run(args: argparse.Namespace) -> int:
    from vcran.api import ManagerError
    from vcran.api import run as simulate
    from vcran.io.progress import progress_bar
    from vcran.io.scenario_file import ScenarioError

    scenario = load_scenario(args.scenario, None)
    check_out(args.out)
    if args.report:  # a missing extra is said at once, not after the run
        from vcran.report import ReportError, require_matplotlib

        try:
            require_matplotlib()
        except ReportError as exc:
            raise CommandError(str(exc)) from None
    bar = progress_bar(sys.stderr, scenario.settings.duration, quiet=args.quiet)
    models: list[Model] = []

    def progress(now: float, tasks_done: int) -> None:
        # the telemetry tick is the safe point to act on a signal (never inside a write or an event)
        if bar is not None:
            bar(now, tasks_done)
        if signals.requested is not None and models:
            models.pop().stop()

    try:
        with StopSignals() as signals:
            result = simulate(scenario, manager=args.manager, out=args.out, progress=progress, on_start=models.append)
    except (ScenarioError, ManagerError) as exc:
        raise CommandError(str(exc)) from None
    finally:
        if bar is not None:
            bar.close()
    if signals.requested is not None:
        print(f"vcran run: stopped by {signals.name} at t={result.summary['sim_time']:g} s; "
              f"outputs up to then in {args.out}/", file=sys.stderr)
        return signals.exit_code
    if not args.quiet:
        print_summary(result, args.out)
    if args.view:
        from vcran.commands.view import PAGE
        from vcran.commands.view import write as write_view

        write_view(args.out, args.out / PAGE, quiet=args.quiet)
    if args.report:
        from vcran.commands.report import write

        return write(args.out, args.out / "report", quiet=args.quiet)
    return 0


def print_summary(result: Result, out: Path) -> None:
    s = result.summary
    robots = s["robots"]
    done = sum(len(r["completed"]) for r in robots.values())
    cancelled = sum(len(r["cancelled"]) for r in robots.values())
    print(f"{s['scenario']}: {len(robots)} robot(s), {s['sim_time']:g} s simulated")
    print(f"  tasks completed {done}, cancelled {cancelled}, errors {s['errors']}, events {result.event_count}")
    jobs = s.get("jobs")
    if jobs is not None:
        lead = jobs["lead_time"]
        lead_text = f", lead time p50 {lead['p50']:.1f} s, p95 {lead['p95']:.1f} s" if lead else ""
        print(f"  jobs arrived {jobs['arrived']}, completed {jobs['completed']}, failed {jobs['failed']}, "
              f"open {jobs['open']}; {jobs['done_per_hour']:.1f} done per hour{lead_text}; "
              f"utilisation {s['utilisation']['fleet']:.0%}")
    if len(robots) <= 5:
        for rid, r in robots.items():
            cancelled_text = ", ".join(f"{c['task']} ({c['reason']})" for c in r["cancelled"]) or "none"
            print(f"  {rid}: completed {', '.join(r['completed']) or 'none'}; cancelled {cancelled_text}; "
                  f"distance {r['distance']:.2f} m")
    print(f"  wall time {result.wall_seconds:.3f} s, speed {result.speed:,.0f}x real time")
    print(f"  outputs in {out}/ (trace.jsonl.zst, legs.npy, events.jsonl.zst, summary.json)")
