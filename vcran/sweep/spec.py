"""Sweep files (TOML): a scenario, seeds, and the variants to run it as (docs/contract.md §10, docs/sweeps.md).

::

    scenario = "../scenarios/demo.toml"   # relative to this file, or a bundled scenario's name ("demo")
    seeds = {from = 1, count = 5}         # or seeds = [1, 2, 3]

    [grid]                                # every combination
    "simulation.task_timeout" = [10.0, 30.0]
    "robots.*.max_velocity" = [0.5, 1.0]

    [[variants]]                          # listed by hand; each is crossed with the grid
    name = "slow start"
    "robots.robot_1.pose" = [1.0, 0.0, 0.0]

Loading is as strict as a scenario's: an unknown key, a wrong type, an empty list, a path that leads
nowhere or a value the scenario refuses fails with :class:`SweepError` naming the file, the variant and
the field, before anything runs. Every variant is validated by loading the overridden scenario with the
scenario loader itself (:mod:`vcran.sweep.overrides`), so a sweep accepts exactly what a scenario does.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from vcran.io.scenario_file import parse, resolve
from vcran.io.toml_table import INT64, ScenarioError, Table, read_toml
from vcran.sweep.overrides import OverrideError, apply, canonical

SEED_PATH = "simulation.seed"


class SweepError(ScenarioError):
    """A sweep that cannot run; the message names the file, the variant and the field."""


@dataclass(frozen=True, slots=True)
class Variant:
    """One way to run the scenario: its label (``[[variants]]`` ``name``, if any) and its overrides."""

    index: int
    label: str | None
    params: tuple[tuple[str, Any], ...]


@dataclass(frozen=True, slots=True)
class RunSpec:
    """One run of a sweep: a variant with a seed, numbered in sweep order (variant-major)."""

    index: int
    variant: Variant
    seed: int

    @property
    def overrides(self) -> list[tuple[str, Any]]:
        return [*self.variant.params, (SEED_PATH, self.seed)]


@dataclass(frozen=True, slots=True)
class Sweep:
    """A loaded sweep file: the scenario (its path and text) and every variant, each validated."""

    source: str
    name: str
    scenario_path: Path
    #: The scenario file's text: what is shipped to a worker, which need not see the file system.
    scenario_text: str
    seeds: tuple[int, ...]
    variants: tuple[Variant, ...]
    #: The swept paths as written in the file, in column order.
    parameters: tuple[str, ...]

    @property
    def labelled(self) -> bool:
        return any(v.label is not None for v in self.variants)

    def runs(self) -> list[RunSpec]:
        seeds = self.seeds
        return [RunSpec(v.index * len(seeds) + i, v, s) for v in self.variants for i, s in enumerate(seeds)]


def load(path: str | Path) -> Sweep:
    """The sweep file at ``path``, checked through: :class:`SweepError` names what is wrong and where."""
    path = Path(path)
    try:
        _, data = read_toml(path, "sweep")
    except ScenarioError as exc:
        raise SweepError(str(exc)) from None
    return parse_sweep(data, path)


def parse_sweep(data: dict[str, Any], path: Path) -> Sweep:
    source = str(path)
    try:
        top = Table(data, source, "")
        scenario = top.string("scenario")
        name = top.string("name", path.stem)
        seeds = _seeds(top)
        grid = _flat_table(top.table("grid"), lists=True)
        variants = [_variant(t) for t in top.tables("variants")]
        top.done()
    except SweepError:
        raise
    except ScenarioError as exc:
        raise SweepError(str(exc)) from None
    try:  # a file beside the sweep file, or a bundled scenario by name, as every command takes SCENARIO
        scenario_path = resolve(scenario, path.parent)
        text, base = read_toml(scenario_path)
        parse(base, str(scenario_path), default_name=scenario_path.stem)
    except ScenarioError as exc:  # the scenario's own message, which names its file
        raise SweepError(f"{source}: field 'scenario': {exc}") from None

    for _label, params in [*variants, (None, grid)]:
        for key, _ in params:
            if canonical(key) == SEED_PATH:
                raise SweepError(f"{source}: {key!r}: the seed is swept by 'seeds', not by a path")
    labels = [label for label, _ in variants if label is not None]
    if len(set(labels)) != len(labels):
        twice = next(label for label in labels if labels.count(label) > 1)
        raise SweepError(f"{source}: [[variants]]: two are named {twice!r}; a name is the variant's label in the table")
    grid_keys = {canonical(k): k for k, _ in grid}
    built: list[Variant] = []
    for label, params in variants or [(None, [])]:
        for key, _ in params:
            if canonical(key) in grid_keys:
                raise SweepError(f"{source}: variant {label or len(built)}: {key!r} is also in [grid]; set it in one place")
        for combo in itertools.product(*(values for _, values in grid)):
            chosen = tuple(params) + tuple(zip((k for k, _ in grid), combo))
            built.append(Variant(len(built), label, chosen))
    for v in built:
        _check(base, v, seeds[0], source, scenario_path)
    columns = list(dict.fromkeys([*(k for _, params in variants for k, _ in params), *(k for k, _ in grid)]))
    return Sweep(source, name, scenario_path, text, seeds, tuple(built), tuple(columns))


def describe(params: tuple[tuple[str, Any], ...] | list[tuple[str, Any]]) -> str:
    return ", ".join(f"{k} = {v!r}" for k, v in params) or "the scenario as it is"


def _check(base: dict[str, Any], v: Variant, seed: int, source: str, scenario_path: Path) -> None:
    where = f"{source}: variant {v.index}{f' {v.label!r}' if v.label else ''} ({describe(v.params)})"
    try:
        parse(apply(base, [*v.params, (SEED_PATH, seed)]), str(scenario_path), default_name=scenario_path.stem)
    except (OverrideError, ScenarioError) as exc:
        raise SweepError(f"{where}: {exc}") from None


def _seeds(top: Table) -> tuple[int, ...]:
    raw = top.raw("seeds")
    if isinstance(raw, dict):
        t = Table(raw, top.source, "seeds")
        first, count = t.integer("from"), t.integer("count", minimum=1)
        t.done()
        if first + count - 1 not in INT64:
            t.fail("count", f"the last seed, {first + count - 1}, is outside TOML's 64-bit integer range")
        return tuple(range(first, first + count))
    if not isinstance(raw, list) or not raw or not all(isinstance(s, int) and not isinstance(s, bool) for s in raw):
        top.fail("seeds", f"expected a non-empty list of integers or {{from = N, count = M}}, got {raw!r}")
    if any(s not in INT64 for s in raw):
        top.fail("seeds", f"{next(s for s in raw if s not in INT64)} is outside TOML's 64-bit integer range")
    if len(set(raw)) != len(raw):
        top.fail("seeds", f"{raw!r} repeats a seed (the runs would be identical)")
    return tuple(raw)


def _variant(t: Table) -> tuple[str | None, list[tuple[str, Any]]]:
    label = t.string("name", None)
    return label, _flat_table(t, lists=False)


def _flat_table(t: Table, *, lists: bool) -> list[tuple[str, Any]]:
    """The table's unread keys as (dotted path, value); nested tables (``simulation.task_timeout``
    written unquoted) are paths too, but for an empty one, which sets its path to an empty table. With ``lists``, every value is a non-empty list of choices."""
    out: list[tuple[str, Any]] = []

    def walk(prefix: str, table: dict[str, Any]) -> None:
        for key, value in table.items():
            path = f"{prefix}{key}"
            if isinstance(value, dict) and value:  # an empty table is a value: "manager.options" = {} clears them
                walk(path + ".", value)
            else:
                out.append((path, value))

    walk("", {k: v for k, v in t.data.items() if k not in t.used})
    t.used.update(t.data)
    seen: dict[str, str] = {}
    for path, value in out:
        if canonical(path) in seen:
            t.fail(path, f"names the same field as {seen[canonical(path)]!r}")
        seen[canonical(path)] = path
        if lists and (not isinstance(value, list) or not value):
            t.fail(path, f"expected a non-empty list of values to try, got {value!r}")
    return out
