"""``vcran replay TRACE --out DIR [--verify]``: re-run a recorded trace, optionally checking every record."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

HELP = "re-run a recorded trace as fast as possible; --verify exits non-zero on the first difference"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("trace", type=Path, help="trace.jsonl of a recorded run (telemetry.bin beside it)")
    parser.add_argument("--out", type=Path, required=True, help="output folder of the replay")
    parser.add_argument("--verify", action="store_true",
                        help="compare every outbound record, telemetry row and event with the recording")
    parser.add_argument("--quiet", action="store_true", help="print nothing but errors and differences")


def run(args: argparse.Namespace) -> int:
    from transports.replay import ReplayTransport, TraceError
    from vcran.io.verify import recorded_end, scenario_from_trace, verify
    from vcran.runner import run_to

    trace: Path = args.trace
    if trace.is_dir():
        trace = trace / "trace.jsonl"
    if args.out.resolve() == trace.parent.resolve():
        print("vcran replay: --out must differ from the recording's folder", file=sys.stderr)
        return 2
    try:
        scenario = scenario_from_trace(trace)
        end, complete = recorded_end(trace)
        if not complete and not args.quiet:
            print(f"vcran replay: {trace} has no end record (the run was killed?): an incomplete recording, "
                  f"replayed up to its last recorded instant, t={end:g}", file=sys.stderr)
        result = run_to(scenario, args.out, ReplayTransport(trace), options={"transport": "replay", "source": str(trace)})
    except (OSError, ValueError, TraceError) as exc:
        print(f"vcran replay: {exc}", file=sys.stderr)
        return 2
    if not args.quiet:
        print(f"replayed {trace}: {result.summary['sim_time']:g} s simulated in {result.wall_seconds:.3f} s")
    if not args.verify:
        return 0
    try:
        difference = verify(trace, args.out)
    except (OSError, ValueError) as exc:
        print(f"vcran replay --verify: {exc}", file=sys.stderr)
        return 2
    if difference is not None:
        print(f"vcran replay --verify: {difference}", file=sys.stderr)
        return 1
    if not args.quiet:
        print("verify: every outbound record, telemetry row and event matches the recording"
              + ("" if complete else " (as far as it goes)"))
    return 0
