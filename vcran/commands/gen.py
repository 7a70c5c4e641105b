"""``vcran gen --robots N --hours H --seed S``: print a generated fleet scenario (TOML)."""

from __future__ import annotations

import argparse
import sys

HELP = "print a generated fleet scenario: N robots kept busy for H hours (benchmarks, scale tests)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--robots", type=int, required=True, help="number of robots")
    parser.add_argument("--hours", type=float, required=True, help="simulated hours")
    parser.add_argument("--seed", type=int, default=0, help="layout seed (default 0)")


def run(args: argparse.Namespace) -> int:
    from vcran.commands import CommandError
    from vcran.io.gen import generate

    try:
        text = generate(args.robots, args.hours, args.seed)
    except ValueError as exc:
        raise CommandError(str(exc)) from None
    sys.stdout.write(text)
    return 0
