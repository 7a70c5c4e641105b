"""``vcran send SCENARIO --orion URL [--factor F]``: play the message script into Orion (the JMeter role).

Each message is sent at its script time, scaled by the factor, but never sooner after the previous one
than the script spaces them: when a slow answer makes ``send`` fall behind, the rest of the script shifts
instead of bunching up. Bunched writes to one attribute would be overwritten before a polling RAN reads
them (docs/contract.md §7), which the original's JMeter file, with its constant timer between requests, never did.
"""

from __future__ import annotations

import argparse
import sys
import time

from vcran.commands import add_scenario_argument, check_positive, load_scenario
from vcran.commands._orion import add_connection_arguments, client_from_args, setup_logging
from vcran.commands._signals import StopSignals

HELP = "play the scenario's message script into Orion in real time, as the fleet manager would"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_scenario_argument(parser, " whose [[script]] is played")
    add_connection_arguments(parser)
    parser.add_argument("--factor", type=float, default=1.0, help="script seconds per wall second (default 1)")
    parser.add_argument("--quiet", action="store_true", help="print nothing but errors")


def run(args: argparse.Namespace) -> int:
    setup_logging(args.quiet)
    check_positive("--factor", args.factor)
    scenario = load_scenario(args.scenario, "vcran send")
    client = client_from_args(args)
    signals = StopSignals()  # stop between two messages, never in the middle of one
    try:
        with signals:
            failures, sent = _play(args, scenario, client, signals)
    finally:
        client.close()
    if signals.requested is not None:
        print(f"vcran send: stopped by {signals.name}: sent {sent} message(s), {failures} failed", file=sys.stderr)
        return signals.exit_code
    if not args.quiet:
        print(f"sent {sent} message(s), {failures} failed")
    return 1 if failures else 0


def _play(args: argparse.Namespace, scenario, client, signals: StopSignals) -> tuple[int, int]:  # type: ignore[no-untyped-def]
    """Send the script; returns (failures, sent). Stops early when a signal asks."""
    from transports.orion.client import OrionError, OrionRejected
    from vcran.core.opil.codec import encode_attribute

    entity_type = scenario.settings.entity_type
    start = time.monotonic()
    failures = 0
    sent = 0
    previous: tuple[float, float] | None = None  # (script time, wall time) of the last message sent
    for entry in scenario.messages():
        due = start + entry.t / args.factor
        if previous is not None:  # keep the script's spacing, like JMeter's constant timer (see below)
            due = max(due, previous[1] + (entry.t - previous[0]) / args.factor)
        while signals.requested is None and (delay := due - time.monotonic()) > 0:
            time.sleep(min(delay, 0.1))  # in slices: a signal is acted on within 0.1 s
        if signals.requested is not None:
            break
        previous = (entry.t, time.monotonic())
        value = entry.raw if entry.message is None else encode_attribute(entry.attribute, entry.message)
        try:
            client.append_attrs(entry.robot, entity_type, {entry.attribute: value})
            sent += 1
        except OrionRejected as exc:
            failures += 1
            hint = " (run vcran orion init first)" if exc.status == 404 else ""
            print(f"vcran send: t={entry.t:g} {entry.robot} {entry.attribute}: {exc}{hint}", file=sys.stderr)
        except (OrionError, ValueError) as exc:  # ValueError: a raw value with NaN is no JSON to send
            failures += 1
            print(f"vcran send: t={entry.t:g} {entry.robot} {entry.attribute}: {exc}", file=sys.stderr)
        else:
            if not args.quiet:
                print(f"t={entry.t:g} {entry.robot} {entry.attribute}", flush=True)
    return failures, sent
