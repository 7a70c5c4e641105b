"""``vcran run SCENARIO --out DIR``: simulate with the scripted transport, as fast as possible."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from vcran.commands import load_scenario

HELP = "simulate a scenario with its message script, as fast as possible"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("scenario", type=Path, help="scenario file (TOML), or a bundled scenario by name (demo)")
    parser.add_argument("--out", type=Path, required=True, help="output folder (created if missing)")
    parser.add_argument("--quiet", action="store_true", help="print nothing but errors (no progress bar either)")
    parser.add_argument("--report", action="store_true",
                        help="then write the report (figures, KPI tables) into DIR/report; needs vcran[report]")


def run(args: argparse.Namespace) -> int:
    from transports.scripted import ScriptedTransport
    from vcran.io.progress import progress_bar
    from vcran.runner import run_to

    scenario = load_scenario(args.scenario)
    bar = progress_bar(sys.stderr, scenario.settings.duration, quiet=args.quiet)
    try:
        result = run_to(scenario, args.out, ScriptedTransport(scenario.messages()),
                        options={"transport": "scripted"}, progress=bar)
    finally:
        if bar is not None:
            bar.close()
    if not args.quiet:
        print_summary(result, args.out)
    if args.report:
        from vcran.commands.report import write

        return write(args.out, args.out / "report", quiet=args.quiet)
    return 0


def print_summary(result, out: Path) -> None:  # type: ignore[no-untyped-def]
    s = result.summary
    robots = s["robots"]
    done = sum(len(r["completed"]) for r in robots.values())
    cancelled = sum(len(r["cancelled"]) for r in robots.values())
    print(f"{s['scenario']}: {len(robots)} robot(s), {s['sim_time']:g} s simulated")
    print(f"  tasks completed {done}, cancelled {cancelled}, errors {s['errors']}, events {result.events}")
    if len(robots) <= 5:
        for rid, r in robots.items():
            cancelled_text = ", ".join(f"{c['task']} ({c['reason']})" for c in r["cancelled"]) or "none"
            print(f"  {rid}: completed {', '.join(r['completed']) or 'none'}; cancelled {cancelled_text}; "
                  f"distance {r['distance']:.2f} m")
    print(f"  wall time {result.wall_seconds:.3f} s, speed {result.speed:,.0f}x real time")
    print(f"  outputs in {out}/ (trace.jsonl, telemetry.bin, events.jsonl, summary.json)")
