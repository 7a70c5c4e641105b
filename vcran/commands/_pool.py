"""Where many runs execute, the options shared by ``vcran sweep`` and ``vcran fuzz`` (docs/contract.md §10)."""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

from vcran.commands import CommandError

if TYPE_CHECKING:
    from vcran.sweep.pool import Pool


def add_pool_arguments(parser: argparse.ArgumentParser, what: str, default: str) -> None:
    parser.add_argument("--workers", type=int, default=None, metavar="N",
                        help=f"{what} on N local processes (default: {default}; 1: in this process)")
    parser.add_argument("--cluster", metavar="ADDRESS", default=None,
                        help=f"{what} on a Dask scheduler instead, e.g. tcp://10.0.0.5:8786 (needs vcran[sweep])")


def check_pool_options(args: argparse.Namespace) -> None:
    """Refuse what cannot mean anything, before any work is done."""
    if args.workers is not None and args.workers < 1:
        raise CommandError("--workers must be at least 1")
    if args.workers is not None and args.cluster is not None:
        raise CommandError("--workers and --cluster exclude each other: a cluster's workers are its own")


def pool_for(args: argparse.Namespace, jobs: int) -> Pool:
    from vcran.sweep.pool import PoolError, open_pool

    try:
        pool = open_pool(args.workers, args.cluster, jobs=jobs)
    except PoolError as exc:
        raise CommandError(str(exc)) from None
    if args.cluster is not None:
        import logging

        # losing the scheduler is the command's one line (exit 2); Dask's client would log a traceback besides.
        # Set after open_pool: the first import of distributed, there, sets this logger's level from its config
        logging.getLogger("distributed.client").setLevel(logging.CRITICAL)
    return pool
