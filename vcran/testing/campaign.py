"""One fuzz search as a pure function of plain data: scenario text, search seed, examples -> outcome.

A search perturbs a scenario's message script and checks the rules (:func:`search`), or varies a
closed loop's workload, stock and link and checks its fleet manager (:func:`search_loop`). ``vcran fuzz``
runs one search in this process, or, with ``--workers``/``--cluster`` (docs/contract.md §10), many searches with
consecutive seeds on a pool, each exactly what ``vcran fuzz --seed S --examples M`` runs alone: a
campaign's failure is reproduced by its search's command line as well as by the saved scenario. A
search is hypothesis's :func:`~hypothesis.find` with no example database and a ``random.Random`` seeded
by the search seed, so one seed always tries the same examples and shrinks to the same failure.
"""

from __future__ import annotations

import random
import tempfile
import time
import tomllib
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from vcran.core.scenario import VDA5050, ManagerSpec, Scenario
from vcran.io.scenario_file import parse
from vcran.testing.checks import run_variant
from vcran.testing.scripts import Perturbation, load_text, perturbations, perturbed_toml


@dataclass(frozen=True, slots=True)
class Options:
    """How variants are drawn and checked (``vcran fuzz`` --window, --max-ops, --fast)."""

    window: int = 3
    max_ops: int = 8
    fast: bool = False


@dataclass(frozen=True, slots=True)
class Outcome:
    """What one search found: ``failure`` is None when every example ran clean."""

    seed: int
    #: Examples asked for (``--examples`` of the search) and examples tried before the end or a failure.
    asked: int
    examples: int
    shrinking: int
    wall_seconds: float
    failure: Failure | None = None


@dataclass(frozen=True, slots=True)
class Failure:
    """A search's shrunk failure: the violations, and what to write as the failing scenario file."""

    problems: tuple[str, ...]
    #: A script's search: the shrunk perturbations (plain frozen dataclasses); ``script_toml(base, ops)``.
    ops: list[Any] | None = None
    #: A fleet manager's search: the shrunk failing scenario as plain data (``scenario_toml.dumps`` writes it).
    scenario: dict[str, Any] | None = None


@dataclass(frozen=True, slots=True)
class LoopOptions:
    """How a fleet manager is fuzzed (``vcran fuzz`` --manager, --jobs, --horizon, --idle-bound)."""

    manager: str | None = None
    max_jobs: int = 8
    horizon: float = 300.0
    bound: float = 60.0


def base_scenario(text: str, source: str) -> Scenario:
    """The scenario a search perturbs, read as :func:`vcran.io.scenario_file.load` reads its file."""
    return parse(tomllib.loads(text), source, default_name=Path(source).stem)


def search(text: str, source: str, seed: int, examples: int, options: Options = Options()) -> Outcome:
    """Try ``examples`` perturbed variants of the scenario ``text``; shrink the first that breaks a rule."""
    from hypothesis import HealthCheck, find, settings
    from hypothesis.errors import NoSuchExample

    base = base_scenario(text, source)
    if base.settings.protocol == VDA5050:  # its own perturbations and properties (docs/fuzzing.md)
        from vcran.testing.vda5050_runs import perturbations as vda_perturbations

        strategy: Any = vda_perturbations(base, window=options.window, max_ops=options.max_ops)
    else:
        strategy = perturbations(list(base.messages()), [r.id for r in base.robots], window=options.window,
                                 max_ops=options.max_ops)
    calls = {"generated": 0, "shrinking": 0}
    found = False

    def violated(ops: list[Perturbation]) -> bool:
        nonlocal found
        calls["shrinking" if found else "generated"] += 1
        bad = bool(check(base, ops, options))
        found = found or bad
        return bad

    hypothesis_settings = settings(max_examples=examples, database=None, deadline=None,
                                   suppress_health_check=list(HealthCheck))
    start = time.perf_counter()
    try:
        minimal = find(strategy, violated, settings=hypothesis_settings, random=random.Random(seed))
    except NoSuchExample:
        return Outcome(seed, examples, calls["generated"], 0, time.perf_counter() - start)
    wall = time.perf_counter() - start
    failure = Failure(tuple(check(base, minimal, options)), ops=minimal)
    return Outcome(seed, examples, calls["generated"], calls["shrinking"], wall, failure)


def search_loop(text: str, source: str, seed: int, examples: int, options: LoopOptions) -> Outcome:
    """Search for a workload, stock and link under which the fleet manager (``options.manager``, else the
    scenario's own) breaks a loop property (:func:`vcran.testing.loop.fuzz_manager`)."""
    from vcran.io.scenario_toml import loop_dict
    from vcran.testing.loop import fuzz_manager

    base = loop_base(text, source, options.manager)
    start = time.perf_counter()
    finding = fuzz_manager(base, None, examples=examples, seed=seed, bound=options.bound,
                           max_jobs=options.max_jobs, horizon=options.horizon)
    wall = time.perf_counter() - start
    if finding is None:
        return Outcome(seed, examples, examples, 0, wall)
    failure = Failure(tuple(finding.problems), scenario=loop_dict(finding.scenario))
    return Outcome(seed, examples, finding.examples, finding.shrinks, wall, failure)


def loop_base(text: str, source: str, manager: str | None) -> Scenario:
    """The closed-loop scenario a manager's search varies, with ``manager`` in place of its own, and the
    options :func:`vcran.api.manager_options` gives it (the saved failing scenario names both)."""
    from vcran.api import manager_options

    base = base_scenario(text, source)
    if manager is None:
        return base
    return replace(base, manager=ManagerSpec(manager, tuple(manager_options(base.manager, manager).items())))


def check(base: Scenario, ops: list[Any], options: Options) -> list[str]:
    """The rule violations of one variant, run in a temporary folder (:func:`run_variant`; a VDA 5050
    scenario's, :func:`vcran.testing.vda5050_runs.run_variant`)."""
    variant = load_text(script_toml(base, ops))
    with tempfile.TemporaryDirectory(prefix="vcran-fuzz-") as work:
        if base.settings.protocol == VDA5050:
            from vcran.testing.vda5050_runs import run_variant as vda_variant

            return vda_variant(variant, Path(work), again=not options.fast)
        return run_variant(variant, Path(work), again=not options.fast)


def script_toml(base: Scenario, ops: list[Any], header: str = "") -> str:
    """``base`` with its script perturbed by ``ops`` as a scenario file, for either protocol (OPIL's
    :func:`~vcran.testing.scripts.perturbed_toml`, VDA 5050's :func:`vcran.testing.vda5050_runs.perturbed_toml`)."""
    if base.settings.protocol == VDA5050:
        from vcran.testing.vda5050_runs import perturbed_toml as vda_toml

        return vda_toml(base, ops, header)
    return perturbed_toml(base, ops, header)


def chunks(examples: int, workers: int, seed: int, most: int = 25) -> list[tuple[int, int]]:
    """(search seed, examples) for a campaign of ``examples`` on ``workers``: consecutive seeds from
    ``seed``, at most ``most`` examples each (a failure stops the campaign within one chunk's time, and
    a slow chunk does not hold the others up), never fewer chunks than workers while examples last."""
    size = max(1, min(most, -(-examples // max(workers, 1))))
    n = -(-examples // size)
    return [(seed + i, min(size, examples - i * size)) for i in range(n)]
