"""``vcran replay TRACE --out DIR [--verify]``: re-run a recorded trace, optionally checking every record.

With ``--verify`` the replay's folder is only a means to compare, so ``--out`` may be left out: the replay
then goes to a temporary folder, removed afterwards whatever the outcome (docs/outputs.md).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

HELP = "re-run a recorded trace as fast as possible; --verify exits 1 at the first difference"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("trace", type=Path,
                        help="a recorded run's folder or its trace (trace.jsonl.zst; format 1's trace.jsonl too)")
    parser.add_argument("--out", type=Path, metavar="DIR",
                        help="output folder of the replay (with --verify it may be left out: a temporary folder)")
    parser.add_argument("--verify", action="store_true",
                        help="compare every outbound record, leg (telemetry) and event with the recording")
    parser.add_argument("--quiet", action="store_true", help="print nothing but errors and differences")


def run(args: argparse.Namespace) -> int:
    import tempfile

    from vcran.commands import CommandError
    from vcran.io.trace import trace_in

    try:
        trace = trace_in(args.trace)
    except ValueError as exc:
        raise CommandError(str(exc)) from None
    if args.out is None:
        if not args.verify:
            raise CommandError("--out DIR is required (with --verify it may be left out: the replay then goes to "
                               "a temporary folder)")
        with tempfile.TemporaryDirectory(prefix="vcran-replay-") as folder:
            return _replay(args, trace, Path(folder))
    if args.out.resolve() == trace.parent.resolve():
        raise CommandError("--out must differ from the recording's folder")
    return _replay(args, trace, args.out)


def _replay(args: argparse.Namespace, trace: Path, out: Path) -> int:
    from transports.replay import ReplayTransport, TraceError
    from vcran.commands import CommandError
    from vcran.io.trace import events_beside
    from vcran.io.verify import recorded_end, scenario_from_trace, verify
    from vcran.runner import run_to

    try:
        scenario = scenario_from_trace(trace)
        end, complete = recorded_end(trace)
        if not complete and not args.quiet:
            print(f"vcran replay: {trace} has no end record (the run was killed?): an incomplete recording, "
                  f"replayed up to its last recorded instant, t={end:g}", file=sys.stderr)
        transport = ReplayTransport(trace)
        result = run_to(scenario, out, transport, options=transport.options())
    except (ValueError, TraceError) as exc:
        raise CommandError(str(exc)) from None
    if not args.quiet:
        print(f"replayed {trace}: {result.summary['sim_time']:g} s simulated in {result.wall_seconds:.3f} s")
    if not args.verify:
        return 0
    try:
        difference = verify(trace, out)
    except ValueError as exc:
        raise CommandError(f"--verify: {exc}") from None
    if difference is not None:
        print(f"vcran replay --verify: {difference}", file=sys.stderr)
        return 1
    if not args.quiet:
        recorded_events = events_beside(trace)
        what = ("every outbound record, leg (telemetry) and event matches the recording" if recorded_events.exists()
                else f"every outbound record and leg (telemetry) matches the recording; events not compared: "
                     f"{recorded_events} is missing")
        print(f"verify: {what}" + ("" if complete else " (as far as it goes)"))
    return 0
