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

from vcran.sweep.pool import Pool, open_pool
from vcran.sweep.spec import RunSpec, Sweep, load
from vcran.sweep.table import columns, write_tables
from vcran.sweep.worker import Row, run_one

#: Folder of a run's outputs under the sweep's folder, with ``--keep-runs``.
RUNS_DIR = "runs"


@dataclass(frozen=True, slots=True)
class SweepResult:
    """The rows of a sweep: one per run that finished, in run order (a failed run's has its ``error``)."""

    rows: list[Row]
    #: Runs in the sweep; fewer rows than that only after Ctrl-C (``interrupted``).
    total: int
    interrupted: bool
    #: The columns before a run's results: run, variant, label (if variants are named), parameters, seed.
    head: list[str]

    @property
    def failed(self) -> int:
        return sum(row["error"] is not None for row in self.rows)

    @property
    def columns(self) -> list[str]:
        """Every column of the runs table, in order; ``wall_seconds`` last."""
        return columns(self.rows, self.head)

    def write(self, out: str | Path) -> list[Path]:
        """``runs.csv`` (and ``runs.parquet`` when pyarrow is installed) into the folder ``out``."""
        return write_tables(Path(out), self.rows, self.columns)


def run_folder(out: Path, index: int) -> Path:
    return out / RUNS_DIR / f"{index:04d}"


def run_sweep(sweep: Sweep | str | Path, *, workers: int | None = None, cluster: str | None = None,
              keep_runs: str | Path | None = None, on_row: Callable[[Row], None] | None = None) -> SweepResult:
    """Every run of ``sweep`` (a :class:`Sweep` or a sweep file's path), in this process
    (``workers=1``), on ``workers`` local processes (default: one per CPU) or on the Dask scheduler at
    ``cluster`` (``"tcp://host:8786"``). ``keep_runs`` keeps each run's folder under that folder
    (``runs/0007/``); ``on_row`` sees each row as it arrives. Ctrl-C returns the rows done so far."""
    if not isinstance(sweep, Sweep):
        sweep = load(sweep)
    pool = open_pool(workers, cluster, jobs=len(sweep.seeds) * len(sweep.variants))
    try:
        return execute(sweep, pool, keep_runs=Path(keep_runs) if keep_runs is not None else None, on_row=on_row)
    finally:
        pool.close()


def execute(sweep: Sweep, pool: Pool, *, keep_runs: Path | None = None,
            on_row: Callable[[Row], None] | None = None) -> SweepResult:
    """:func:`run_sweep` on a pool that the caller opened and closes."""
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
    return SweepResult([rows[i] for i in sorted(rows)], len(specs), interrupted, head(sweep))


def head(sweep: Sweep) -> list[str]:
    """The columns before a run's results: its identity, parameters and seed."""
    return ["run", "variant", *(["label"] if sweep.labelled else []), *sweep.parameters, "seed"]


def row(sweep: Sweep, spec: RunSpec, result: Row | BaseException) -> Row:
    """The table row of run ``spec``: its identity and parameters, then what ``run_one`` returned (or,
    when the pool lost the run, a worker that died, the error that says so)."""
    chosen = dict(spec.variant.params)
    identity = {"run": spec.index, "variant": spec.variant.index, "label": spec.variant.label, "seed": spec.seed}
    first = {name: identity[name] if name in identity else chosen.get(name) for name in head(sweep)}
    if isinstance(result, BaseException):
        return {**first, "error": f"{type(result).__name__}: {result}".strip(), "wall_seconds": None}
    return {**first, **result}
