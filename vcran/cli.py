"""The ``vcran`` console command: one subcommand per module in :mod:`vcran.commands` (docs/contract.md §8).

Each command module exposes ``HELP`` (one line), ``add_arguments(parser)`` and ``run(args) -> int``.
Command modules import their heavy dependencies inside ``run`` so that ``vcran --help`` and the fast
commands start quickly; the CLI is the one place that wires scenario, environment and transport together.

:func:`main` is the one error boundary (README "Exit status"): whatever a command cannot do because of its
input or its surroundings ends as one line ``vcran COMMAND: message`` on stderr and exit status 2, never a
traceback. Commands say what went wrong with :class:`~vcran.commands.CommandError`; a file or folder the
system refuses (missing, a folder where a file was meant, read-only, a full disk) is an ``OSError`` that
reaches this boundary and is worded here. Anything else is a bug in vcran: one line too, exit status 70,
and ``VCRAN_DEBUG=1`` shows its traceback.
"""

from __future__ import annotations

import argparse
import difflib
import gc
import importlib
import os
import re
import sys
from collections.abc import Sequence
from typing import Any, NoReturn

from vcran import __version__
from vcran.commands import CommandError
from vcran.commands._signals import Terminated, terminate_like_interrupt
from vcran.io.runfolder import RunFolderError

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
    "sweep": "sweep",
    "report": "report",
    "view": "view",
    "broker": "broker",
    "decode": "decode",
    "schema": "schema",
}

#: Exit statuses (README "Exit status"); argparse's usage errors are 2 as well.
OK, FOUND, BAD_INPUT, BUG, INTERRUPTED, TERMINATED = 0, 1, 2, 70, 130, 143


class _UsageError(Exception):
    """argparse refused the command line; :func:`main` words it, after looking for unknown options."""

    def __init__(self, prog: str, message: str) -> None:
        super().__init__(message)
        self.prog = prog


class _Parser(argparse.ArgumentParser):
    """argparse with the boundary's manners: a usage error reaches :func:`main`, which says it as one line
    ``vcran COMMAND: message`` (the usage itself is one ``--help`` away), exit status 2. Options are spelled
    in full (``allow_abbrev`` off): docs/contract.md §8 lets options grow, and an abbreviation that is unique today
    (``--rep``) would change meaning or turn ambiguous the day a command gains an option, under a script
    that used it; a prefix is an unknown option, and the error names the option it is short for."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        kwargs.setdefault("allow_abbrev", False)
        super().__init__(*args, **kwargs)

    def error(self, message: str) -> NoReturn:
        raise _UsageError(self.prog, message)

    def _check_value(self, action: argparse.Action, value: Any) -> None:
        """argparse's check of a choice, with the nearest choice named first (``orion int`` -> ``init``)."""
        choices = action.choices
        if choices is None or value in choices:
            return
        listed = ", ".join(map(repr, choices))
        guess = _nearest(str(value), [str(choice) for choice in choices])
        meant = f"did you mean {guess!r}? " if guess else ""
        raise argparse.ArgumentError(action, f"invalid choice: {value!r} ({meant}choose from {listed})")


def build_parser(only: str | None = None) -> argparse.ArgumentParser:
    """The parser; with ``only``, just that command's module is imported and its parser built (the one
    that parses: a command's own usage and errors never name the others): start-up time counts when
    ``vcran run`` of a small scenario takes well under a second."""
    parser = _Parser(
        prog="vcran",
        description="Headless, deterministic fleet simulator for AGV fleet managers: OPIL/FIWARE robots (VC-RAN) and VDA 5050 vehicles.",
        epilog="Exit status: 0 done; 1 done, and it found what it looks for (a difference, a rule violation, "
               "a refused message, a fleet manager that raised); 2 bad input or usage; 70 a bug in vcran; "
               "130 interrupted (Ctrl-C); 143 terminated (SIGTERM).",
    )
    parser.add_argument("--version", action="version", version=f"vcran {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True, title="commands")
    for name, module_name in COMMANDS.items():
        if only is not None and name != only:
            continue
        module = importlib.import_module(f"vcran.commands.{module_name}")
        command = sub.add_parser(name, help=module.HELP, description=module.HELP)
        module.add_arguments(command)
        command.set_defaults(_run=module.run)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv:  # a bare `vcran` asks what there is
        build_parser().print_help()
        return OK
    named = argv[0] in COMMANDS
    if not named and not argv[0].startswith("-"):  # `vcran rn demo`: argparse would list all 13 commands
        guess = _nearest(argv[0], list(COMMANDS))
        meant = f" (did you mean {guess!r}?)" if guess else ""
        print(f"vcran: unknown command {argv[0]!r}{meant} (see vcran --help)", file=sys.stderr)
        return BAD_INPUT
    parser = build_parser(argv[0] if named else None)
    try:
        args, extra = parser.parse_known_args(argv)
    except _UsageError as exc:
        return _usage(parser, argv, exc.prog, str(exc))
    if extra:  # argparse would say so as "vcran:", though the command's own options are what was meant
        prog = f"vcran {args.command}" if named else "vcran"  # `vcran --bogus run ...`: not run's option
        return _usage(parser, argv, prog, f"unrecognized arguments: {' '.join(extra)}")
    try:
        with terminate_like_interrupt():  # SIGTERM ends any command as Ctrl-C does
            return int(args._run(args) or 0)
    except CommandError as exc:
        return _fail(args.command, str(exc), exc.code)
    except RunFolderError as exc:  # an --out that cannot receive a run, found where the run starts
        return _fail(args.command, str(exc), BAD_INPUT)
    except BrokenPipeError:  # `vcran gen ... | head`: the reader has all it wanted
        _silence_stdout()
        return OK
    except OSError as exc:
        return _fail(args.command, _os_message(exc), BAD_INPUT)
    except KeyboardInterrupt as exc:
        return _fail(args.command, "interrupted", TERMINATED if isinstance(exc, Terminated) else INTERRUPTED)
    except Exception as exc:
        if isinstance(exc, TypeError) and isinstance(exc.__cause__, KeyboardInterrupt):
            # orjson turns a Ctrl-C inside its ``default`` callback into a TypeError
            code = TERMINATED if isinstance(exc.__cause__, Terminated) else INTERRUPTED
            return _fail(args.command, "interrupted", code)
        if os.environ.get("VCRAN_DEBUG"):
            raise
        from vcran.sim.loop import manager_note

        note = manager_note(exc)
        if note is not None:  # the user's fleet manager failed, not vcran
            return _fail(args.command, f"the fleet manager raised {type(exc).__name__}: {exc} ({note}; VCRAN_DEBUG=1 "
                                       "shows the traceback)", FOUND)
        return _fail(args.command, f"internal error (a bug in vcran; VCRAN_DEBUG=1 shows where): "
                                   f"{type(exc).__name__}: {exc}", BUG)


def _usage(parser: argparse.ArgumentParser, argv: list[str], prog: str, message: str) -> int:
    """A usage error as one line, exit status 2. Unknown options come first, whatever argparse found: it
    checks the required options before it mentions an unknown one, so ``vcran run demo --outt x`` was
    "the following arguments are required: --out", the consequence and not the mistake."""
    unknown = _unknown_options(parser, argv)
    if unknown:
        prog = unknown[0][0]
        named = [f"{option} (did you mean {guess}?)" if guess else option for _, option, guess in unknown]
        message = f"unknown option{'s' if len(named) > 1 else ''} {', '.join(named)}"
    print(f"{prog}: {message} (see {prog} --help)", file=sys.stderr)
    return BAD_INPUT


def _unknown_options(parser: argparse.ArgumentParser, argv: list[str]) -> list[tuple[str, str, str | None]]:
    """(prog, option, nearest known option or None) for each option on ``argv`` its parser does not know:
    vcran's own before the command, the command's after it. A word counts as an option as argparse counts
    it: it starts with ``-``, and it is neither ``-`` alone, a negative number, a word with a space, nor
    anything after ``--``."""
    commands = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices
    prog, known = "vcran", _option_strings(parser)
    unknown: list[tuple[str, str, str | None]] = []
    for word in argv:
        if word == "--":
            break
        if prog == "vcran" and word in commands:
            prog, known = f"vcran {word}", _option_strings(commands[word])
            continue
        if not word.startswith("-") or word == "-" or " " in word or _NUMBER.match(word):
            continue
        option = word.split("=", 1)[0] if word.startswith("--") else word[:2]
        if option not in known:
            unknown.append((prog, option, _nearest(option, sorted(o for o in known if o.startswith("--")))))
    return unknown


#: What argparse takes for a negative number (a value, not an option), as its ``_negative_number_matcher``.
_NUMBER = re.compile(r"^-\d+$|^-\d*\.\d+$")


def _option_strings(parser: argparse.ArgumentParser) -> set[str]:
    return {option for action in parser._actions for option in action.option_strings}


def _nearest(word: str, candidates: list[str]) -> str | None:
    """The candidate ``word`` most likely misspells, if any is close: a unique one it is the start of
    (``--ou``, an abbreviation), else the closest by difflib's ratio of at least 0.6 (``--quite``)."""
    starts = [c for c in candidates if c.startswith(word) and len(word) > 2]
    if len(starts) == 1:
        return starts[0]
    close = difflib.get_close_matches(word, candidates, n=1)
    return close[0] if close else None


#: Allocations between young garbage collections in a ``vcran`` process (CPython's default: 700); the
#: same figure :mod:`vcran.runner` uses while a run is under way.
GC_THRESHOLD = 50_000


def console() -> NoReturn:
    """The ``vcran`` command (and ``python -m vcran``): :func:`main`, then the exit. Only here, never in
    :func:`main`, which tests call in process, is the process's garbage collector tuned, twice:

    * Start-up (imports, the scenario, the model) creates long-lived objects only: modules, classes,
      functions. With CPython's default threshold that is ~60 young and 5 middle collections before a
      small ``vcran run`` starts, each walking objects that are never garbage; one young collection per
      50,000 allocations makes it none (cycles are still collected, in larger batches).
    * Everything the command writes is closed by the time :func:`main` returns, so the interpreter's
      final collection, which walks every object still alive (numpy, SimPy, vcran's modules and classes:
      40-60 ms of CPU, a tenth of a small ``vcran run``), finds nothing that needs finalising; freezing
      the heap first lets the process end without that walk (frozen objects are left out of every
      collection).
    """
    gc.set_threshold(GC_THRESHOLD, *gc.get_threshold()[1:])
    code = main()
    gc.freeze()
    sys.exit(code)


def _fail(command: str, message: str, code: int) -> int:
    """``vcran COMMAND: message`` as one line on stderr; ``code`` is the exit status."""
    line = " ".join(part.strip() for part in message.splitlines() if part.strip())
    print(f"vcran {command}: {line}", file=sys.stderr)
    return code


def _os_message(exc: OSError) -> str:
    """``path: reason`` in the system's words (``out/x: Permission denied``), without errno numbers."""
    reason = exc.strerror or str(exc)
    if exc.filename is None:
        return reason
    if exc.filename2 is not None:
        return f"{exc.filename} -> {exc.filename2}: {reason}"
    if isinstance(exc, FileExistsError) and not os.path.isdir(exc.filename):
        reason = "exists and is not a folder"  # mkdir's "File exists" for an --out that is a file
    return f"{exc.filename}: {reason}"


def _silence_stdout() -> None:
    """Point stdout at /dev/null so that the interpreter's final flush cannot fail again (Python docs,
    "Note on SIGPIPE")."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError, AttributeError):  # stdout is no file (in-process tests)
        pass


if __name__ == "__main__":
    console()
