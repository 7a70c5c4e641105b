"""The ``vcran`` console command: one subcommand per module in :mod:`vcran.commands` (SPEC §8).

Each command module exposes ``HELP`` (one line), ``add_arguments(parser)`` and ``run(args) -> int``.
Command modules import their heavy dependencies inside ``run`` so that ``vcran --help`` and the fast
commands start quickly; the CLI is the one place that wires scenario, environment and transport together.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence

from vcran.commands import CommandError
from vcran.commands._signals import Terminated, terminate_like_interrupt

#: Subcommand name -> module under vcran.commands. Order is the order of ``vcran --help``.
COMMANDS: dict[str, str] = {
    "run": "run",
    "replay": "replay",
    "live": "live",
    "manage": "manage",
    "send": "send",
    "orion": "orion",
    "gen": "gen",
    "fuzz": "fuzz",
    "report": "report",
    "broker": "broker",
    "decode": "decode",
}


def build_parser(only: str | None = None) -> argparse.ArgumentParser:
    """The parser; with ``only``, just that command's module is imported (the others stay known by
    name): start-up time counts when ``vcran run`` of a small scenario takes well under a second."""
    parser = argparse.ArgumentParser(
        prog="vcran",
        description="Headless, deterministic fleet simulator for FIWARE/OPIL robot fleets (VC-RAN).",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name, module_name in COMMANDS.items():
        if only is not None and name != only:
            sub.add_parser(name)
            continue
        module = importlib.import_module(f"vcran.commands.{module_name}")
        command = sub.add_parser(name, help=module.HELP, description=module.HELP)
        module.add_arguments(command)
        command.set_defaults(_run=module.run)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    args = build_parser(argv[0] if argv and argv[0] in COMMANDS else None).parse_args(argv)
    try:
        with terminate_like_interrupt():  # SIGTERM ends any command as Ctrl-C does
            return int(args._run(args) or 0)
    except CommandError as exc:
        print(f"vcran {args.command}: {exc}", file=sys.stderr)
        return exc.code
    except KeyboardInterrupt as exc:
        print("vcran: interrupted", file=sys.stderr)
        return 143 if isinstance(exc, Terminated) else 130
    except TypeError as exc:  # orjson turns a Ctrl-C inside its ``default`` callback into a TypeError
        if not isinstance(exc.__cause__, KeyboardInterrupt):
            raise
        print("vcran: interrupted", file=sys.stderr)
        return 143 if isinstance(exc.__cause__, Terminated) else 130
    except BrokenPipeError:
        return 0


if __name__ == "__main__":
    sys.exit(main())
