"""``vcran live SCENARIO --orion URL --out DIR``: the scenario's fleet, in real time, driven through Orion."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from vcran.commands import CommandError, add_scenario_argument, check_out, check_positive, load_scenario
from vcran.commands._orion import add_connection_arguments, check_notify_url, client_from_args, setup_logging
from vcran.commands._signals import StopSignals
from vcran.commands.view import add_live_argument, check_view, end_live, serve_live

if TYPE_CHECKING:
    from vcran.sim.model import Model

HELP = "run the scenario's robots and stations against Orion in real time (its message script is ignored)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_scenario_argument(parser, "; its [[script]] is not played")
    add_connection_arguments(parser)
    parser.add_argument("--out", type=Path, required=True, metavar="DIR", help="output folder (trace, events, summary)")
    parser.add_argument("--factor", type=float, default=1.0, help="simulated seconds per wall second (default 1)")
    parser.add_argument("--notify-url", metavar="URL",
                        help="subscribe, with notifications to this URL (vcran listens there); default: polling")
    parser.add_argument("--listen", default="127.0.0.1", metavar="HOST",
                        help="address the notification listener binds to (default 127.0.0.1)")
    parser.add_argument("--poll-interval", type=float, default=0.25, metavar="S",
                        help="polling period in simulated seconds (default 0.25)")
    parser.add_argument("--quiet", action="store_true", help="print nothing but errors")
    add_live_argument(parser)


def run(args: argparse.Namespace) -> int:
    import resource
    from collections import Counter
    from dataclasses import replace

    from transports.orion.link import LinkOptions
    from transports.orion.transport import OrionTransport
    from vcran.io.progress import LiveStatus, StatusLine
    from vcran.runner import run_to
    from vcran.sim.live import LiveEnvironment

    setup_logging(args.quiet)
    check_positive("--factor", args.factor)
    check_positive("--poll-interval", args.poll_interval)
    if args.notify_url is not None:
        check_notify_url(args.notify_url)
    scenario = load_scenario(args.scenario)
    check_out(args.out)
    check_view(args.view, args.out)
    # Live mode runs until the duration or a signal: robots wait for the fleet manager, never "idle out".
    scenario = replace(scenario, script=(), cycles=(), settings=replace(scenario.settings, until_idle=False))
    env = LiveEnvironment(speed=args.factor)
    options = LinkOptions(
        entity_type=scenario.settings.entity_type, robots=tuple(r.id for r in scenario.robots),
        notify_url=args.notify_url, listen_host=args.listen, poll_interval=args.poll_interval,
    )
    transport = OrionTransport(client_from_args(args), options)
    try:
        transport.open()  # bind the notification listener now: a busy port is an error, not a half run
    except OSError as exc:
        raise CommandError(f"cannot listen for notifications on {args.listen}, {args.notify_url}: {exc.strerror}") from None

    models: list[Model] = []
    line = None if args.quiet else StatusLine(sys.stderr)

    def on_signal() -> None:
        if models:
            env.call_from_signal(models[0].stop)

    signals = StopSignals(on_signal)  # SIGINT or SIGTERM: the normal end of a live run (exit 0)

    def on_start(model) -> None:  # type: ignore[no-untyped-def]
        models.append(model)
        if signals.requested is not None:  # a signal while the model was built: stop at once
            model.stop()

    def progress(now: float, tasks_done: int) -> None:
        if line is not None and models:
            states = Counter(node.logic.state.value for node in models[0].protocol.nodes)  # OPIL: RanLogic's
            line.update(LiveStatus(now, len(models[0].robots), tasks_done, transport.status(), states))

    mode = f"subscription to {args.notify_url}" if args.notify_url else f"polling every {args.poll_interval:g} s"
    if not args.quiet:
        print(f"live: {len(scenario.robots)} robot(s) on {args.orion}, x{args.factor:g}, {mode}; Ctrl-C stops",
              flush=True)
    try:
        view = serve_live(args.view, args.out, args.quiet)
    except CommandError:
        transport.close()
        raise
    try:
        with signals:
            result = run_to(scenario, args.out, transport, env=env, on_start=on_start, progress=progress,
                            flush_every_tick=True, options={"transport": "live", "factor": args.factor,
                                                            "inbound": "subscription" if args.notify_url else "polling"})
    finally:
        if line is not None:
            line.close()
        end_live(view)
    if not args.quiet:
        s = result.summary
        done = sum(len(r["completed"]) for r in s["robots"].values())
        usage = resource.getrusage(resource.RUSAGE_SELF)
        print(f"live run ended at {s['sim_time']:.3f} s simulated: {done} task(s) completed, {s['errors']} error(s)")
        print(f"  {transport.status()}")
        sent = transport.sender.counts
        print(f"  wall {result.wall_seconds:.1f} s, outbound {sent.attempts / result.wall_seconds:.1f} requests/s "
              f"({sent.accepted} of {sent.attempts} accepted), cpu {usage.ru_utime + usage.ru_stime:.1f} s")
        lat = transport.latency_stats()
        if lat:
            print(f"  inbound to effect: median {lat['median'] * 1000:.1f} ms, p99 {lat['p99'] * 1000:.1f} ms ({lat['count']:.0f} messages)")
        print(f"  outputs in {args.out}/")
    return 0
