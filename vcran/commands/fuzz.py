"""``vcran fuzz SCENARIO --examples N [--seed S] [--save PATH]``: perturb the script, check the rules.

Each example is the scenario with its message script perturbed the way a real fleet manager and broker
perturb it (reordered within a window, duplicated, delayed, dropped, cancels and malformed payloads
injected; :mod:`vcran.testing.scripts`). A VDA 5050 scenario's script is perturbed as a master perturbs
it (also stale and skipped orderUpdateIds, cancels, pauses; :mod:`vcran.testing.vda5050.fuzz`) and
checked against VDA 5050's properties (:mod:`vcran.testing.vda5050.checks`). The variant is written as a scenario file, run in a temporary
folder, and its outputs are checked against the rules (:mod:`vcran.testing.checks`), then run again
(byte-identical, docs/contract.md §5) and replayed (replay verification, docs/contract.md §6) unless ``--fast``.

The search is hypothesis's :func:`~hypothesis.find` with no example database and a ``random.Random``
seeded by ``--seed``, so one seed always tries the same examples and shrinks to the same script. On a
violation the shrunk, minimal script is printed as a scenario file, saved to ``--save``, and the command
exits 1; ``vcran run`` on that file reproduces the failure.

A closed-loop scenario (jobs and a fleet manager, docs/contract.md §9), or any scenario with ``--manager
module:Class``, is fuzzed the other way round: the manager is under test, so the workload, the pickup
stations' stock and the link vary (:mod:`vcran.testing.loop`), and each run is checked against the loop
properties (every job ends; no protocol error; no robot idles past ``--idle-bound`` while a job waits).
The shrunk failing scenario is saved the same way, naming its manager.

``--workers K`` or ``--cluster ADDRESS`` (docs/contract.md §10) split the examples, a script's or a manager's, into
searches of at most 25 with consecutive seeds from ``--seed`` (:func:`vcran.testing.campaign.chunks`)
and run them on a local process pool or a Dask cluster; the first failure stops them all, and its header
names the one search, ``--seed S --examples M``, that finds it again in a single process.
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from vcran.commands import MANAGER_OPTIONS, add_scenario_argument
from vcran.commands._pool import add_pool_arguments, check_pool_options, pool_for

if TYPE_CHECKING:
    from vcran.core.scenario import Scenario
    from vcran.testing.campaign import Failure, LoopOptions, Options, Outcome

HELP = ("perturb a scenario's message script and check the rules on every variant; with a fleet manager, vary "
        "its workload and link and check the loop properties")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_scenario_argument(parser, "")
    parser.add_argument("--examples", type=int, default=100, help="perturbed variants to try (default 100)")
    parser.add_argument("--seed", type=int, default=0, help="search seed: same seed, same examples (default 0)")
    parser.add_argument("--save", type=Path, default=None,
                        help="where to write a failing script (default: SCENARIO-STEM.fuzz-failure.toml here)")
    parser.add_argument("--window", type=int, default=SCRIPT_OPTIONS["window"],
                        help="how far a reordering moves a message (default 3)")
    parser.add_argument("--max-ops", type=int, default=SCRIPT_OPTIONS["max_ops"],
                        help="most perturbations per example (default 8)")
    parser.add_argument("--fast", action="store_true", help="skip the second run and the replay of each variant")
    add_pool_arguments(parser, "the examples, as searches of at most 25 with consecutive seeds,", "1")
    loop = parser.add_argument_group("a fleet manager in the loop (docs/contract.md §9)")
    loop.add_argument("--manager", metavar="MODULE:CLASS",
                      help="fuzz this fleet manager (default: the scenario's [manager], if it has one)" + MANAGER_OPTIONS)
    loop.add_argument("--jobs", type=int, default=LOOP_OPTIONS["jobs"], metavar="N",
                      help="most jobs per example (default 8)")
    loop.add_argument("--horizon", type=float, default=LOOP_OPTIONS["horizon"], metavar="S",
                      help="jobs arrive within this many simulated seconds (default 300)")
    loop.add_argument("--idle-bound", type=float, default=LOOP_OPTIONS["idle_bound"], metavar="S",
                      help="longest a robot may idle while a job waits (default 60)")


def run(args: argparse.Namespace) -> int:
    import importlib.util
    import os
    import time

    from vcran.commands import CommandError, check_mode, load_scenario
    from vcran.io.scenario_file import resolve
    from vcran.runner import CLOSED_LOOP

    if importlib.util.find_spec("hypothesis") is None:
        raise CommandError("fuzzing needs hypothesis, which is not installed: pip install 'vcran[fuzz]'")
    from vcran.testing.campaign import Options, search, search_loop

    if args.examples < 1:
        raise CommandError("--examples must be at least 1")
    if args.max_ops < 1:
        raise CommandError("--max-ops must be at least 1 (with none, every example is the unperturbed script)")
    if args.window < 1:
        raise CommandError(f"--window must be at least 1 (a swap moves a message by 1 to WINDOW positions), "
                           f"got {args.window}")
    check_pool_options(args)
    save = args.save or Path(f"{args.scenario.stem}.fuzz-failure.toml")
    if os.path.isdir(save) or not os.path.isdir(save.absolute().parent):  # now, not after a long search
        raise CommandError(f"--save {save}: {'is a folder' if os.path.isdir(save) else 'its folder does not exist'}")
    base = load_scenario(args.scenario, None)  # a scripted VDA 5050 scenario is fuzzed too (docs/fuzzing.md)
    loop = args.manager is not None or base.manager is not None
    if loop:
        check_mode(base, CLOSED_LOOP)  # a VDA 5050 master is fuzzed in the closed loop (docs/fuzzing.md)
    text = resolve(args.scenario).read_text(encoding="utf-8")  # a bundled scenario's too: workers get the text
    if loop:
        options: Options | LoopOptions = _loop_options(args, base, text)
        fn: Callable[..., Outcome] = search_loop
    else:
        _check_script(base)
        options = Options(window=args.window, max_ops=args.max_ops, fast=args.fast)
        fn = search
    start = time.perf_counter()
    if args.workers in (None, 1) and args.cluster is None:
        single: Outcome = fn(text, str(args.scenario), args.seed, args.examples, options)
        outcome: Outcome | None = single
        examples = single.examples
    else:
        outcome, examples = _campaign(args, fn, text, options)
    wall = time.perf_counter() - start
    name = args.manager or (base.manager.path if base.manager is not None else None)
    if outcome is None or outcome.failure is None:
        if loop:
            print(f"vcran fuzz: {name} kept the loop properties on {_examples(examples)} of {args.scenario} "
                  f"(seed {args.seed}): {wall:.1f} s")
        else:
            rate = f", {60 * examples / wall:,.0f} examples/min" if wall > 0 else ""
            print(f"vcran fuzz: {_examples(examples)} of {args.scenario} ran clean (seed {args.seed}): "
                  f"{wall:.1f} s{rate}")
        return 0
    failure = outcome.failure
    command = f"vcran fuzz {args.scenario}{f' --manager {name}' if loop else ''} --examples {outcome.asked} " \
              f"--seed {outcome.seed}{_search_options(args, loop)}: a minimal failing {'scenario' if loop else 'script'}"
    header = "\n".join([
        command,
        *([f"perturbations: {failure.ops!r}"] if failure.ops is not None else []),
        *(f"violation: {p}" for p in failure.problems),
        "re-run: vcran run THIS_FILE --out DIR",
    ])
    text = _failing_file(base, failure, header)
    print(text, flush=True)  # first: a file that cannot be written must not lose the finding
    try:
        save.write_text(text, encoding="utf-8")
        saved = f"is saved in {save}"
    except OSError as exc:
        saved = f"could not be saved in {save} ({exc.strerror or exc}): copy it from above"
    what = f"{name} broke a loop property" if loop else "rule violated"
    print(f"vcran fuzz: {what} after {_examples(examples)} ({outcome.shrinking} "
          f"shrinking runs, {wall:.1f} s); the minimal {'scenario' if loop else 'script'} above {saved}",
          file=sys.stderr)
    for p in failure.problems:
        print(f"  {p}", file=sys.stderr)
    return 1


#: The options besides --examples and --seed that decide which examples a search tries and what it finds,
#: with their defaults: a script's, and a fleet manager's (--fast: a script's second run and replay).
SCRIPT_OPTIONS = {"window": 3, "max_ops": 8}
LOOP_OPTIONS = {"jobs": 8, "horizon": 300.0, "idle_bound": 60.0}


def _search_options(args: argparse.Namespace, loop: bool) -> str:
    """Those of the options that are not their defaults, as typed: the failure's header names the one
    command that finds it again, which it would not with ``--jobs 3`` left out."""
    defaults = LOOP_OPTIONS if loop else SCRIPT_OPTIONS
    given = [f" --{key.replace('_', '-')} {getattr(args, key)!r}" for key, default in defaults.items()
             if getattr(args, key) != default]
    return "".join(given) + (" --fast" if args.fast and not loop else "")


def _examples(n: int) -> str:
    return f"{n} example{'' if n == 1 else 's'}"


def _check_script(base: Scenario) -> None:
    from vcran.commands import CommandError
    from vcran.testing.campaign import script_toml

    try:
        script_toml(base, [])  # fail now, not mid-search, if the script cannot be written back
    except ValueError as exc:
        raise CommandError(str(exc)) from None


def _loop_options(args: argparse.Namespace, base: Scenario, text: str) -> LoopOptions:
    """A fleet manager's campaign, checked before any example runs."""
    from vcran.api import ManagerError, build_manager
    from vcran.commands import CommandError, check_positive
    from vcran.testing.campaign import LoopOptions, loop_base

    for option, value in (("--jobs", args.jobs), ("--horizon", args.horizon), ("--idle-bound", args.idle_bound)):
        check_positive(option, value)  # inf too: the job strategy draws arrival tenths up to int(horizon * 10)
    if not math.isfinite(args.horizon * 10):  # finite, but that overflows all the same (1e308)
        raise CommandError(f"--horizon {args.horizon:g} is too large: instants are drawn at tenths of a second up to it")
    if base.script or base.cycles:
        raise CommandError(f"{args.scenario}: has a [[script]]; a fleet manager plays that part (remove one)")
    try:  # a manager that cannot be built fails now, not as every example's crash
        build_manager(None, loop_base(text, str(args.scenario), args.manager))
    except ManagerError as exc:
        raise CommandError(str(exc)) from None
    return LoopOptions(args.manager, args.jobs, args.horizon, args.idle_bound)


def _failing_file(base: Scenario, failure: Failure, header: str) -> str:
    from vcran.io.scenario_toml import dumps
    from vcran.testing.campaign import script_toml

    if failure.ops is not None:
        return script_toml(base, failure.ops, header)
    assert failure.scenario is not None
    return dumps(failure.scenario, header)


def _campaign(args: argparse.Namespace, fn: Callable[..., Outcome], text: str,
              options: Options | LoopOptions) -> tuple[Outcome | None, int]:
    """Searches with consecutive seeds on a pool (docs/contract.md §10); the first failure stops them all.
    Returns the failing outcome (or None) and the examples tried in all searches that finished."""
    from vcran.commands import CommandError
    from vcran.sweep.pool import PoolError
    from vcran.sweep.progress import Progress
    from vcran.testing.campaign import chunks

    plan = chunks(args.examples, args.workers or 1, args.seed)
    pool = pool_for(args, len(plan))
    print(f"vcran fuzz: {args.examples} examples as {len(plan)} searches (seeds {plan[0][0]}..{plan[-1][0]}) "
          f"on {pool.name}", file=sys.stderr)
    progress = Progress(sys.stderr, args.examples, "examples")
    examples = 0
    try:
        for i, outcome in pool.run(fn, [(text, str(args.scenario), seed, n, options) for seed, n in plan]):
            if isinstance(outcome, BaseException):
                pool.stop()
                raise CommandError(f"the search with seed {plan[i][0]} could not run: "
                                   f"{type(outcome).__name__}: {outcome}")
            examples += outcome.examples
            progress.update(outcome.failure is not None, outcome.examples)
            if outcome.failure is not None:
                pool.stop()
                return outcome, examples
    except KeyboardInterrupt:
        pool.stop()
        progress.close()
        print(f"vcran fuzz: interrupted after {examples} examples, all clean", file=sys.stderr)
        raise
    except PoolError as exc:  # the Dask scheduler went away: never "ran clean" on the searches it took along
        pool.stop()
        raise CommandError(f"{exc}: {examples} of {args.examples} examples ran, all clean") from None
    finally:
        progress.close()
        pool.close()
    return None, examples
