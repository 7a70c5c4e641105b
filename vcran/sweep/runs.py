"""Run every variant × seed of a sweep on a pool and gather one row per run (SPEC §10).

A row is the run's number, its variant (number, and label if the sweep names its variants), the value of
every swept parameter, its seed, its error (empty when it ran), the KPIs of its summary and, last, its
wall time: every column but ``wall_seconds`` is a function of the sweep file alone, whichever pool ran
it and in whatever order runs finished. A run that fails is a row with its error; Ctrl-C keeps the rows
already done.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from vcran.sweep.pool import Pool
from vcran.sweep.spec import RunSpec, Sweep
from vcran.sweep.worker import Row, run_one

#: Folder of a run's outputs under the sweep's folder, with ``--keep-runs``.
RUNS_DIR = "runs"


@dataclass(frozen=True, slots=True)
class SweepResult:
    #: One row per run that finished, in run order.
    rows: list[Row]
    total: int
    interrupted: bool

    @property
    def failed(self) -> int:
        return sum(row["error"] is not None for row in self.rows)


def run_folder(out: Path, index: int) -> Path:
    return out / RUNS_DIR / f"{index:04d}"


def run_sweep(sweep: Sweep, pool: Pool, *, keep_runs: Path | None = None,
              on_row: Callable[[Row], None] | None = None) -> SweepResult:
    """Every run of ``sweep`` on ``pool``. ``keep_runs`` keeps each run's folder under it
    (``runs/0007/``); ``on_row`` sees each row as it arrives (the progress line)."""
    specs = sweep.runs()
    source = str(sweep.scenario_path)
    jobs = [(sweep.scenario_text, source, spec.overrides,
             str(run_folder(keep_runs, spec.index)) if keep_runs is not None else None) for spec in specs]
    rows: dict[int, Row] = {}
    interrupted = False
    try:
        for i, result in pool.run(run_one, jobs):
            rows[i] = row(sweep, specs[i], result)
            if on_row is not None:
                on_row(rows[i])
    except KeyboardInterrupt:
        interrupted = True
        pool.stop()
    return SweepResult([rows[i] for i in sorted(rows)], len(specs), interrupted)


def head(sweep: Sweep) -> list[str]:
    """The columns before a run's results: its identity, parameters and seed."""
    return ["run", "variant", *(["label"] if sweep.labelled else []), *sweep.parameters, "seed"]


def row(sweep: Sweep, spec: RunSpec, result: Row | BaseException) -> Row:
    """The table row of run ``spec``: its identity and parameters, then what ``run_one`` returned (or,
    when the pool lost the run, a worker that died, the error that says so)."""
    head: dict[str, Any] = {"run": spec.index, "variant": spec.variant.index}
    if sweep.labelled:
        head["label"] = spec.variant.label
    chosen = dict(spec.variant.params)
    head.update({name: chosen.get(name) for name in sweep.parameters})
    head["seed"] = spec.seed
    if isinstance(result, BaseException):
        return {**head, "error": f"{type(result).__name__}: {result}".strip(), "wall_seconds": None}
    return {**head, **result}
