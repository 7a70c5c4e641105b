"""``vcran fuzz SCENARIO --examples N [--seed S] [--save PATH]``: perturb the script, check the rules.

Each example is the scenario with its message script perturbed the way a real fleet manager and broker
perturb it (reordered within a window, duplicated, delayed, dropped, cancels and malformed payloads
injected; :mod:`vcran.testing.scripts`). The variant is written as a scenario file, run in a temporary
folder, and its outputs are checked against the rules (:mod:`vcran.testing.checks`), then run again
(byte-identical, §5) and replayed (replay verification, §6) unless ``--fast``.

The search is hypothesis's :func:`~hypothesis.find` with no example database and a ``random.Random``
seeded by ``--seed``, so one seed always tries the same examples and shrinks to the same script. On a
violation the shrunk, minimal script is printed as a scenario file, saved to ``--save``, and the command
exits 1; ``vcran run`` on that file reproduces the failure.

A closed-loop scenario (jobs and a fleet manager, SPEC §9), or any scenario with ``--manager
module:Class``, is fuzzed the other way round: the manager is under test, so the workload, the pickup
stations' stock and the link vary (:mod:`vcran.testing.loop`), and each run is checked against the loop
properties (every job ends; no protocol error; no robot idles past ``--idle-bound`` while a job waits).
The shrunk failing scenario is saved the same way, naming its manager.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

HELP = "perturb a scenario's message script and check the rules on every variant"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("scenario", type=Path, help="scenario file (TOML)")
    parser.add_argument("--examples", type=int, default=100, help="perturbed variants to try (default 100)")
    parser.add_argument("--seed", type=int, default=0, help="search seed: same seed, same examples (default 0)")
    parser.add_argument("--save", type=Path, default=None,
                        help="where to write a failing script (default: SCENARIO-STEM.fuzz-failure.toml here)")
    parser.add_argument("--window", type=int, default=3, help="how far a reordering moves a message (default 3)")
    parser.add_argument("--max-ops", type=int, default=8, help="most perturbations per example (default 8)")
    parser.add_argument("--fast", action="store_true", help="skip the second run and the replay of each variant")
    loop = parser.add_argument_group("a fleet manager in the loop (SPEC §9)")
    loop.add_argument("--manager", metavar="MODULE:CLASS",
                      help="fuzz this fleet manager (default: the scenario's [manager], if it has one)")
    loop.add_argument("--jobs", type=int, default=8, metavar="N", help="most jobs per example (default 8)")
    loop.add_argument("--horizon", type=float, default=300.0, metavar="S",
                      help="jobs arrive within this many simulated seconds (default 300)")
    loop.add_argument("--idle-bound", type=float, default=60.0, metavar="S",
                      help="longest a robot may idle while a job waits (default 60)")


def run(args: argparse.Namespace) -> int:
    import importlib.util
    import random
    import tempfile
    import time

    from hypothesis import HealthCheck, find, settings
    from hypothesis.errors import NoSuchExample

    from vcran.commands import CommandError, load_scenario
    from vcran.testing.checks import run_variant
    from vcran.testing.scripts import Perturbation, load_text, perturbations, perturbed_toml

    if args.examples < 1:
        raise CommandError("--examples must be at least 1")
    base = load_scenario(args.scenario)
    if args.manager is not None or base.manager is not None:
        return _fuzz_manager(args, base)
    entries = list(base.messages())
    try:
        perturbed_toml(base, [])  # fail now, not mid-search, if the script cannot be written back
    except ValueError as exc:
        raise CommandError(str(exc)) from None
    malformed = importlib.util.find_spec("vcran.core.codec") is not None
    if not malformed:
        print("vcran fuzz: vcran.core.codec is not installed; malformed payloads are not injected", file=sys.stderr)
    strategy = perturbations(entries, [r.id for r in base.robots], window=args.window,
                             malformed=malformed, max_ops=args.max_ops)
    calls = {"generated": 0, "shrinking": 0}
    found = False

    def violated(ops: list[Perturbation]) -> bool:
        nonlocal found
        calls["shrinking" if found else "generated"] += 1
        with tempfile.TemporaryDirectory(prefix="vcran-fuzz-") as work:
            bad = bool(run_variant(load_text(perturbed_toml(base, ops)), Path(work), again=not args.fast))
        found = found or bad
        return bad

    options = settings(max_examples=args.examples, database=None, deadline=None,
                       suppress_health_check=list(HealthCheck))
    start = time.perf_counter()
    try:
        minimal = find(strategy, violated, settings=options, random=random.Random(args.seed))
    except NoSuchExample:
        wall = time.perf_counter() - start
        n = calls["generated"]
        rate = f", {60 * n / wall:,.0f} examples/min" if wall > 0 else ""
        print(f"vcran fuzz: {n} examples of {args.scenario} ran clean (seed {args.seed}): {wall:.1f} s{rate}")
        return 0
    wall = time.perf_counter() - start
    text = perturbed_toml(base, minimal)
    with tempfile.TemporaryDirectory(prefix="vcran-fuzz-") as work:
        problems = run_variant(load_text(text), Path(work), again=not args.fast)
    header = "\n".join([
        f"vcran fuzz {args.scenario} --examples {args.examples} --seed {args.seed}: a minimal failing script",
        f"perturbations: {minimal!r}",
        *(f"violation: {p}" for p in problems),
        "re-run: vcran run THIS_FILE --out DIR",
    ])
    text = perturbed_toml(base, minimal, header)
    save = args.save or Path(f"{args.scenario.stem}.fuzz-failure.toml")
    save.write_text(text, encoding="utf-8")
    print(text)
    print(f"vcran fuzz: rule violated after {calls['generated']} examples ({calls['shrinking']} shrinking runs, "
          f"{wall:.1f} s); the minimal script above is saved in {save}", file=sys.stderr)
    for p in problems:
        print(f"  {p}", file=sys.stderr)
    return 1


def _fuzz_manager(args: argparse.Namespace, base):  # type: ignore[no-untyped-def]
    import time
    from dataclasses import replace

    from vcran.api import ManagerError, build_manager
    from vcran.commands import CommandError
    from vcran.core.scenario import ManagerSpec
    from vcran.io.scenario_toml import dumps, loop_dict
    from vcran.testing.loop import fuzz_manager

    if args.jobs < 1 or not args.horizon > 0 or not args.idle_bound > 0:
        raise CommandError("--jobs, --horizon and --idle-bound must be positive")
    if base.script or base.cycles:
        raise CommandError(f"{args.scenario}: has a [[script]]; a fleet manager plays that part (remove one)")
    if args.manager is not None:
        base = replace(base, manager=ManagerSpec(args.manager))
    try:
        build_manager(None, base)  # a manager that cannot be built fails now, not as every example's crash
    except ManagerError as exc:
        raise CommandError(str(exc)) from None
    start = time.perf_counter()
    finding = fuzz_manager(base, None, examples=args.examples, seed=args.seed, bound=args.idle_bound,
                           max_jobs=args.jobs, horizon=args.horizon)
    wall = time.perf_counter() - start
    name = base.manager.path
    if finding is None:
        print(f"vcran fuzz: {name} kept the loop properties on {args.examples} examples of {args.scenario} "
              f"(seed {args.seed}): {wall:.1f} s")
        return 0
    header = "\n".join([
        f"vcran fuzz {args.scenario} --manager {name} --examples {args.examples} --seed {args.seed}: "
        "a minimal failing scenario",
        *(f"violation: {p}" for p in finding.problems),
        "re-run: vcran run THIS_FILE --out DIR",
    ])
    text = dumps(loop_dict(finding.scenario), header)
    save = args.save or Path(f"{args.scenario.stem}.fuzz-failure.toml")
    save.write_text(text, encoding="utf-8")
    print(text)
    print(f"vcran fuzz: {name} broke a loop property after {finding.examples} examples ({finding.shrinks} "
          f"shrinking runs, {wall:.1f} s); the minimal scenario above is saved in {save}", file=sys.stderr)
    for p in finding.problems:
        print(f"  {p}", file=sys.stderr)
    return 1
