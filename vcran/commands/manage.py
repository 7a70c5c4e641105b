"""``vcran manage SCENARIO --orion URL [--notify-url URL]``: a fleet manager against a real Orion (docs/contract.md §9).

The scenario's fleet manager (its ``[manager]``, or ``--manager module:Class``) runs in real time, scaled
by ``--factor``, against the robots Orion holds: ``vcran live`` on the same scenario, or a physical fleet.
Jobs come from the scenario's workload at their times (``--jobs N``: only the first N). The run ends when
the scenario's duration has passed, on Ctrl-C, or, with the scenario's ``until_idle``, once no job is to
come or open, no timer is pending and every write has reached Orion. The manager learns of the robots'
updates from a subscription (``--notify-url``: Orion must be able to reach vcran there) or, by default,
by polling Orion every ``--poll-interval`` simulated seconds. docs/live.md ("A fleet manager, live")
describes the wiring; :mod:`transports.orion.manage` and :mod:`transports.orion.link` the link.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from vcran.commands import MANAGER_OPTIONS, CommandError, add_scenario_argument, check_positive, load_scenario
from vcran.commands._orion import add_connection_arguments, check_notify_url, client_from_args, setup_logging
from vcran.commands._signals import StopSignals
from vcran.commands.view import add_live_argument, check_view, end_live, serve_live

HELP = "run the scenario's fleet manager against Orion in real time (next to vcran live or a real fleet)"

#: How often (simulated seconds) the run checks whether everything has ended.
CHECK_EVERY = 0.25
#: Default polling period (simulated seconds), as ``vcran live``'s.
POLL_INTERVAL = 0.25


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_scenario_argument(parser, " with the fleet and its jobs")
    add_connection_arguments(parser)
    parser.add_argument("--manager", metavar="MODULE:CLASS", help="the fleet manager (default: the scenario's [manager])" + MANAGER_OPTIONS)
    parser.add_argument("--notify-url", metavar="URL",
                        help="subscribe: Orion notifies the manager of the robots' updates at this URL (vcran "
                             "listens there); default: poll Orion, for a manager Orion cannot reach")
    parser.add_argument("--listen", metavar="HOST",
                        help="address the notification listener binds to (default 127.0.0.1); with --notify-url")
    parser.add_argument("--poll-interval", type=float, metavar="S",
                        help=f"polling period in simulated seconds (default {POLL_INTERVAL:g}); without --notify-url")
    parser.add_argument("--factor", type=float, default=1.0, help="simulated seconds per wall second (default 1)")
    parser.add_argument("--jobs", type=int, metavar="N", help="only the first N jobs of the workload")
    parser.add_argument("--out", type=Path, metavar="DIR", help="write the job events (events.jsonl.zst) and summary.json into DIR, as a run folder")
    parser.add_argument("--quiet", action="store_true", help="print nothing but errors")
    add_live_argument(parser)


def run(args: argparse.Namespace) -> int:
    from dataclasses import replace
    from itertools import islice

    from transports.orion.client import OrionError
    from transports.orion.link import LinkOptions
    from transports.orion.manage import OrionLoop, OrionManagerLink
    from vcran.api import ManagerError, build_manager
    from vcran.io.runfolder import RunFolderError
    from vcran.io.sinks import FolderSinks, MemorySinks, Sinks
    from vcran.sim.live import LiveEnvironment

    setup_logging(args.quiet)
    check_positive("--factor", args.factor)
    if args.jobs is not None and args.jobs < 0:
        raise CommandError("--jobs must not be negative")
    if args.notify_url is not None:
        check_notify_url(args.notify_url)
        if args.poll_interval is not None:
            raise CommandError("--poll-interval is the polling period: without --notify-url only")
    elif args.listen is not None:
        raise CommandError("--listen is where the notification listener binds: it needs --notify-url")
    elif args.poll_interval is not None:
        check_positive("--poll-interval", args.poll_interval)
    check_view(args.view, args.out)
    polling = args.notify_url is None
    poll_interval = POLL_INTERVAL if args.poll_interval is None else args.poll_interval
    listen = "127.0.0.1" if args.listen is None else args.listen
    scenario = load_scenario(args.scenario, "vcran manage")
    if args.jobs is not None:
        scenario = replace(scenario, jobs=tuple(islice(scenario.workload(), args.jobs)), job_stream=None)
    try:
        manager, name = build_manager(args.manager, scenario)
    except ManagerError as exc:
        raise CommandError(str(exc)) from None
    if manager is None:
        raise CommandError(f"{args.scenario}: names no fleet manager: give one with --manager module:Class")

    client = client_from_args(args)  # a URL or token file that cannot work: refused before any folder exists
    try:
        view = serve_live(args.view, args.out, args.quiet)  # a port in use: refused before anything runs
    except CommandError:
        client.close()
        raise
    # The run's sinks, as every run's (vcran.io.sinks): a folder written into <out>.incomplete and renamed
    # when the run has ended (a manager that raises leaves it incomplete, never new events beside an older
    # summary), its job events and summary but no trace (no model runs here); or memory without --out.
    try:
        sinks: Sinks = FolderSinks(args.out) if args.out is not None else MemorySinks()
    except RunFolderError:
        client.close()
        if view is not None:
            view.close()
        raise
    env = LiveEnvironment(speed=args.factor)
    options = LinkOptions(scenario.settings.entity_type, notify_url=args.notify_url, listen_host=listen,
                            poll_interval=poll_interval)
    loop = OrionLoop(scenario, manager, sinks.events.write, client, options)
    try:
        loop.attach(env, lambda _inbound: None)
    except (OSError, OrionError) as exc:
        client.close()
        sinks.discard()  # nothing ran: no folder left behind
        if view is not None:
            view.close()
        if isinstance(exc, OrionError) and polling:
            raise CommandError(f"cannot read the fleet from {args.orion}: {exc}") from None
        if isinstance(exc, OrionError):
            raise CommandError(f"cannot subscribe to the fleet on {args.orion}: {exc}") from None
        raise CommandError(f"cannot listen for notifications on {listen}, {args.notify_url}: {exc.strerror}") from None

    done = env.event()

    def finish(_: Any = None) -> None:
        if not done.triggered:
            done.succeed()

    def watch():  # type: ignore[no-untyped-def]
        while True:
            yield env.timeout(CHECK_EVERY)
            if scenario.settings.until_idle and loop.exhausted:
                finish()
                return

    env.process(watch())
    if scenario.settings.duration is not None:
        env.timeout(scenario.settings.duration).callbacks.append(finish)
    mode = f"polling every {poll_interval:g} s" if polling else f"subscription to {args.notify_url}"
    link = loop.link
    assert isinstance(link, OrionManagerLink)
    # SIGINT or SIGTERM: the normal end of the run (exit 0), as its duration's; a second one stops it at once
    try:
        with StopSignals(lambda: env.call_from_signal(finish)):
            if not args.quiet:
                print(f"manage: {name} on {len(scenario.robots)} robot(s) at {args.orion}, x{args.factor:g}, "
                      f"{mode}; Ctrl-C stops", flush=True)
            env.run(until=done)  # an exception the manager raises ends the run: the CLI says which hook and when
    finally:
        link.close()
        client.close()
        sinks.events.close()
        if view is not None and sys.exc_info()[0] is not None:
            view.close()
    t = env.now
    jobs = loop.jobs.summary(t)
    sinks.finish({"scenario": scenario.settings.name, "manager": name, "seed": scenario.settings.seed,
                  "sim_time": t, "fleet": [r.id for r in scenario.robots], "jobs": jobs})
    end_live(view)
    if not args.quiet:  # what reached the manager: notifications, or the reads of Orion when polling
        inbound = f"{link.reads} read(s)" if polling else f"{link.notifications} notification(s)"
        print(f"manage ended at {t:.1f} s: {jobs['arrived']} job(s) arrived, {jobs['completed']} completed, "
              f"{jobs['failed']} failed, {jobs['open']} open; {link.writes} write(s) in {link.updates} "
              f"request(s), {inbound}")
    return 0
