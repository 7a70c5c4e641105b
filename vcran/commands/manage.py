"""``vcran manage SCENARIO (--orion URL | --mqtt URL)``: the scenario's fleet manager live (docs/contract.md §9, §11).

The scenario's fleet manager (its ``[manager]``, or ``--manager module:Class``) runs in real time, scaled by
``--factor``, against a live fleet: an OPIL fleet manager (:class:`vcran.FleetManager`) against the robots
Orion holds (``--orion``), a VDA 5050 master (:class:`vcran.core.vda5050.master.Master`) against vehicles on
an MQTT broker (``--mqtt``); ``vcran live`` on the same scenario, or a physical fleet. Jobs come from the
scenario's workload at their times (``--jobs N``: only the first N). The run ends when the scenario's
duration has passed, on Ctrl-C or SIGTERM, or, with the scenario's ``until_idle``, once no job is to come or
open, no timer is pending and nothing is on its way between manager and fleet.

What both edges share is here: the options, the checks made before anything is connected or any folder
made, the LiveEnvironment, the end of the run, the run folder (job events, summary) and the end-of-run
line. What differs is the edge, one module per protocol, chosen once from the option given and then asked for
its ``check`` of the options, its ``OPTION`` (the scenario's protocol is checked against it) and its ``side``:
:mod:`vcran.commands._manage_orion` (docs/live.md, "A fleet manager, live") and :mod:`vcran.commands._manage_mqtt`
(docs/vda5050.md, "Live over MQTT").
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

from vcran.commands import MANAGER_OPTIONS, CommandError, add_scenario_argument, check_positive, load_scenario
from vcran.commands._orion import add_connection_arguments, add_inbound_arguments, setup_logging
from vcran.commands._signals import StopSignals
from vcran.commands.live import on_wall_clock
from vcran.commands.view import add_live_argument, check_view, end_live, serve_live

if TYPE_CHECKING:
    from vcran.core.jobs import Log
    from vcran.core.manager import Manager
    from vcran.sim.live import LiveEnvironment
    from vcran.sim.loop import Loop

HELP = ("run the scenario's fleet manager in real time: an OPIL one against Orion (--orion), a VDA 5050 master "
        "against vehicles on an MQTT broker (--mqtt); next to vcran live or a real fleet")

#: How often (simulated seconds) the run checks whether everything has ended.
CHECK_EVERY = 0.25


class Side(Protocol):
    """One protocol's side of ``vcran manage`` (built by the edge module's ``side(args, scenario)``, before
    any folder is made): :meth:`attach` connects and starts the manager's loop (a CommandError if it cannot)."""

    def attach(self, manager: Manager, log: Log, env: LiveEnvironment) -> Loop: ...
    def announce(self, name: str) -> str: ...
    def traffic(self) -> str: ...
    def close(self) -> None: ...


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_scenario_argument(parser, " with the fleet and its jobs")
    to = parser.add_mutually_exclusive_group(required=True)
    to.add_argument("--mqtt", metavar="URL",
                    help="the MQTT broker of a VDA 5050 scenario's vehicles, mqtt://HOST[:PORT] (port 1883 by "
                         "default): its master runs against them")
    add_connection_arguments(parser, to)
    parser.add_argument("--manager", metavar="MODULE:CLASS",
                        help="the fleet manager (default: the scenario's [manager]): a vcran.FleetManager for an OPIL "
                             "scenario, a vcran.core.vda5050.master.Master for a VDA 5050 one" + MANAGER_OPTIONS)
    add_inbound_arguments(parser, "subscribe, Orion notifies the manager of the robots' updates at this URL (vcran "
                                  "listens there); default: poll Orion, for a manager Orion cannot reach")
    parser.add_argument("--factor", type=float, default=1.0, help="simulated seconds per wall second (default 1)")
    parser.add_argument("--jobs", type=int, metavar="N", help="only the first N jobs of the workload")
    parser.add_argument("--out", type=Path, metavar="DIR", help="write the job events (events.jsonl.zst) and summary.json into DIR, as a run folder")
    parser.add_argument("--quiet", action="store_true", help="print nothing but errors")
    add_live_argument(parser)


def run(args: argparse.Namespace) -> int:
    from dataclasses import replace
    from itertools import islice

    from vcran.api import ManagerError, build_manager
    from vcran.commands import _manage_mqtt, _manage_orion
    from vcran.io.runfolder import RunFolderError
    from vcran.io.sinks import FolderSinks, MemorySinks, Sinks
    from vcran.sim.live import LiveEnvironment

    setup_logging(args.quiet)
    check_positive("--factor", args.factor)
    if args.jobs is not None and args.jobs < 0:
        raise CommandError("--jobs must not be negative")
    edge = _manage_mqtt if args.mqtt is not None else _manage_orion  # chosen once: the rest asks the edge
    edge.check(args)  # the edge's options, before the scenario is read
    check_view(args.view, args.out)
    # a scenario of the other protocol, or a manager of the other kind: refused before anything connects
    scenario = load_scenario(args.scenario, f"vcran manage {edge.OPTION}")
    if args.jobs is not None:
        scenario = replace(scenario, jobs=tuple(islice(scenario.workload(), args.jobs)), job_stream=None)
    scenario = on_wall_clock(scenario)  # a VDA 5050 master stamps its headers in real time, as vcran live's vehicles do
    try:
        manager, name = build_manager(args.manager, scenario)
    except ManagerError as exc:
        raise CommandError(str(exc)) from None
    if manager is None:
        raise CommandError(f"{args.scenario}: names no fleet manager: give one with --manager module:Class")

    side: Side = edge.side(args, scenario)
    try:
        view = serve_live(args.view, args.out, args.quiet)  # a port in use: refused before anything runs
    except CommandError:
        side.close()
        raise
    # The run's sinks, as every run's (vcran.io.sinks): a folder written into <out>.incomplete and renamed
    # when the run has ended (a manager that raises leaves it incomplete, never new events beside an older
    # summary), its job events and summary but no trace (no model runs here); or memory without --out.
    try:
        sinks: Sinks = FolderSinks(args.out) if args.out is not None else MemorySinks()
    except RunFolderError:
        side.close()
        if view is not None:
            view.close()
        raise
    env = LiveEnvironment(speed=args.factor)
    try:
        loop = side.attach(manager, sinks.events.write, env)
    except BaseException as exc:
        side.close()
        if isinstance(exc, CommandError):
            sinks.discard()  # nothing ran: no folder left behind
        else:
            sinks.events.close()  # the manager's on_start raised: its folder stays incomplete
        if view is not None:
            view.close()
        raise

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
    # SIGINT or SIGTERM: the normal end of the run (exit 0), as its duration's; a second one stops it at once
    try:
        with StopSignals(lambda: env.call_from_signal(finish)):
            if not args.quiet:
                print(f"manage: {side.announce(name)}; Ctrl-C stops", flush=True)
            env.run(until=done)  # an exception the manager raises ends the run: the CLI says which hook and when
    finally:
        side.close()
        sinks.events.close()
        if view is not None and sys.exc_info()[0] is not None:
            view.close()
    t = env.now
    jobs = loop.jobs.summary(t)
    sinks.finish({"scenario": scenario.settings.name, "protocol": scenario.settings.protocol, "manager": name,
                  "seed": scenario.settings.seed, "sim_time": t, "fleet": [r.id for r in scenario.robots], "jobs": jobs})
    end_live(view)
    if not args.quiet:
        print(f"manage ended at {t:.1f} s: {jobs['arrived']} job(s) arrived, {jobs['completed']} completed, "
              f"{jobs['failed']} failed, {jobs['open']} open; {side.traffic()}")
    return 0
