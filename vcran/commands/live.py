"""``vcran live SCENARIO (--orion URL | --mqtt URL) --out DIR``: the scenario's fleet in real time, driven by a
fleet manager or master through a real broker (docs/live.md; docs/vda5050.md, "Live over MQTT").

What every live run shares is here: the options, the checks made before anything is connected or any folder
made, the LiveEnvironment, SIGINT/SIGTERM as the normal end, the status line and the run folder. What differs
is the edge, one module per protocol: :mod:`vcran.commands._live_orion` (OPIL robots through Orion) and
:mod:`vcran.commands._live_mqtt` (VDA 5050 vehicles on an MQTT broker).
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

from vcran.commands import CommandError, add_scenario_argument, check_out, check_positive, load_scenario
from vcran.commands._orion import add_connection_arguments, add_inbound_arguments, setup_logging
from vcran.commands._signals import StopSignals
from vcran.commands.view import add_live_argument, check_view, end_live, serve_live

if TYPE_CHECKING:
    from collections import Counter

    from vcran.core.scenario import Scenario
    from vcran.core.wire import Transport
    from vcran.sim.model import Model

HELP = ("run the scenario's fleet in real time: OPIL robots against Orion (--orion), VDA 5050 vehicles on an "
        "MQTT broker (--mqtt); its message script is ignored")


class Edge(Protocol):
    """One protocol's side of a live run, connected (:func:`run` builds it with the edge module's ``connect``)."""

    transport: Transport
    #: The trace header's ``options``: ``transport`` (``live``, ``live-mqtt``), ``factor`` and the edge's own.
    options: dict[str, Any]
    #: What a robot of the fleet completes (summary.json's ``completed``): ``task``, ``order``.
    unit: str
    #: The logic states the status line always shows.
    names: tuple[str, ...]

    def announce(self) -> str: ...
    def states(self, model: Model) -> Counter[str]: ...
    def traffic(self, wall: float) -> str: ...
    def latency(self) -> str | None: ...
    def close(self) -> None: ...


def on_wall_clock(scenario: Scenario, now: datetime | None = None) -> Scenario:
    """A VDA 5050 scenario on the calendar of a live run: simulated time 0 is the wall clock ``now`` (UTC, cut
    to the millisecond), so its headers are real time scaled by ``--factor`` from the start (VDA 5050 §6.4:
    "time when the message was sent"), unless the scenario sets its own ``[simulation] epoch``. Call it once,
    before anything is connected or recorded: the vehicles, a master and the connection topic all read the
    scenario's calendar, and the trace header records it, so a replay stamps the same bytes. An OPIL
    scenario, which has no calendar, is returned as it is. (``vcran live --mqtt``; ``vcran manage --mqtt``.)"""
    from vcran.core.epoch import epoch_text
    from vcran.core.scenario import VDA5050

    s = scenario.settings
    if s.protocol != VDA5050 or s.epoch is not None:
        return scenario
    return replace(scenario, settings=replace(s, epoch=epoch_text(datetime.now(UTC) if now is None else now)))


def latency_line(what: str, stats: dict[str, float], messages: str) -> str | None:
    """An end-of-run figure: median and 99th percentile of wall seconds, in ms (None without any)."""
    if not stats:
        return None
    return (f"{what}: median {stats['median'] * 1000:.1f} ms, p99 {stats['p99'] * 1000:.1f} ms "
            f"({stats['count']:.0f} {messages})")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_scenario_argument(parser, "; its [[script]] is not played")
    to = parser.add_mutually_exclusive_group(required=True)
    to.add_argument("--mqtt", metavar="URL",
                    help="the MQTT broker of a VDA 5050 scenario, mqtt://HOST[:PORT] (port 1883 by default)")
    add_connection_arguments(parser, to)
    parser.add_argument("--out", type=Path, required=True, metavar="DIR", help="output folder (trace, events, summary)")
    parser.add_argument("--factor", type=float, default=1.0, help="simulated seconds per wall second (default 1)")
    add_inbound_arguments(parser, "subscribe, with notifications to this URL (vcran listens there); default: polling")
    parser.add_argument("--quiet", action="store_true", help="print nothing but errors")
    add_live_argument(parser)


def run(args: argparse.Namespace) -> int:
    import resource

    from vcran.commands import _live_mqtt, _live_orion
    from vcran.io.progress import LiveStatus, StatusLine
    from vcran.io.sinks import FolderSinks
    from vcran.runner import execute
    from vcran.sim.live import LiveEnvironment

    setup_logging(args.quiet)
    check_positive("--factor", args.factor)
    side = _live_mqtt if args.mqtt is not None else _live_orion
    side.check(args)  # the edge's options, before the scenario is read
    scenario = load_scenario(args.scenario, f"vcran live {side.OPTION}")
    check_out(args.out)
    check_view(args.view, args.out)
    # Live mode runs until the duration or a signal: robots wait for the fleet manager, never "idle out".
    scenario: Scenario = replace(scenario, script=(), cycles=(), settings=replace(scenario.settings, until_idle=False))
    scenario = on_wall_clock(scenario)  # before connecting: the connection topic's ONLINE is on the calendar too
    env = LiveEnvironment(speed=args.factor)
    edge: Edge = side.connect(args, scenario)  # connected: a broker that cannot be reached is an error now

    models: list[Model] = []
    line = None if args.quiet else StatusLine(sys.stderr)

    def on_signal() -> None:
        if models:
            env.call_from_signal(models[0].stop)

    signals = StopSignals(on_signal)  # SIGINT or SIGTERM: the normal end of a live run (exit 0)

    def on_start(model: Model) -> None:
        models.append(model)
        if signals.requested is not None:  # a signal while the model was built: stop at once
            model.stop()

    if not args.quiet:
        print(edge.announce(), flush=True)
    try:
        view = serve_live(args.view, args.out, args.quiet)
        sinks = FolderSinks(args.out, scenario, edge.options, flush_every_tick=True)
    except CommandError:
        edge.close()
        raise
    # A protocol that sends no telemetry frame (VDA 5050) has its files handed on at each tick here, so that a
    # live page and a run killed outright see them as they go (docs/outputs.md).
    flush = None if edge.transport.wants_frames else sinks.after_frame

    def progress(now: float, tasks_done: int) -> None:
        if flush is not None:
            flush()
        if line is not None and models:
            line.update(LiveStatus(now, len(models[0].robots), tasks_done, edge.transport.status(),
                                   edge.states(models[0]), edge.names))

    try:
        with signals:
            result = execute(scenario, edge.transport, sinks, env=env, on_start=on_start, progress=progress)
    finally:
        if line is not None:
            line.close()
        end_live(view)
    if not args.quiet:
        s, wall = result.summary, result.wall_seconds
        done = sum(len(r["completed"]) for r in s["robots"].values())
        usage = resource.getrusage(resource.RUSAGE_SELF)
        print(f"live run ended at {s['sim_time']:.3f} s simulated: {done} {edge.unit}(s) completed, "
              f"{s['errors']} error(s)")
        print(f"  {edge.transport.status()}")
        print(f"  wall {wall:.1f} s, {edge.traffic(wall)}, cpu {usage.ru_utime + usage.ru_stime:.1f} s")
        latency = edge.latency()
        if latency is not None:
            print(f"  {latency}")
        print(f"  outputs in {args.out}/")
    return 0
