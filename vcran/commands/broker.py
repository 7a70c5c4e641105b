"""``vcran broker``: run vcran's own NGSI v2 broker, a stand-in for Orion when none is at hand (docs/contract.md §8)."""

from __future__ import annotations

import argparse

HELP = (
    "run vcran's own in-memory NGSI-v2 broker (an Orion 4.7 stand-in) until interrupted; "
    "data lives in memory only and is lost on exit"
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--port", type=int, default=1026, help="port to listen on (default: 1026, Orion's; 0: any free port)"
    )
    parser.add_argument("--host", default="127.0.0.1", help="address to bind (default: 127.0.0.1)")
    parser.add_argument("-v", "--verbose", action="store_true", help="log every request and failed notification")


def run(args: argparse.Namespace) -> int:
    import logging
    import time

    from vcran.broker import start_broker
    from vcran.commands import CommandError
    from vcran.commands._signals import StopSignals

    logging.basicConfig(level=logging.INFO if args.verbose else logging.WARNING, format="%(asctime)s %(message)s")
    if not 0 <= args.port <= 65535:
        raise CommandError(f"--port {args.port}: out of range (0..65535; 0 picks a free port)")
    with StopSignals() as signals:  # SIGINT or SIGTERM: the normal end (exit 0)
        try:
            handle = start_broker(args.host, args.port)
        except OSError as exc:  # in use, not an address of this machine, a privileged port
            reason = exc.strerror or str(exc)
            raise CommandError(f"cannot listen on {args.host}:{args.port}: {reason}") from None
        print(f"vcran broker listening on {handle.url} (in memory only: data is lost on exit)", flush=True)
        try:
            while signals.requested is None:
                time.sleep(0.2)  # not an Event: setting one from a signal handler can deadlock on its lock
        finally:
            handle.stop()
    return 0
