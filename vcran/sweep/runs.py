"""Run every variant × seed of a sweep on a pool and gather one row per run (docs/contract.md §10).

A row is the run's number, its variant (number, and label if the sweep names its variants), the value of
every swept parameter, its seed, its error (empty when it ran), the KPIs of its summary and, last, its
wall time: every column but ``wall_seconds`` is a function of the sweep file alone, whichever pool ran
it and in whatever order runs finished. A run that fails is a row with its error; Ctrl-C keeps the rows
already done.

The folders :func:`run_sweep` (``keep_runs``) and :meth:`SweepResult.write` write are those of ``vcran
sweep --out``, staged and refused by the same code (:mod:`vcran.sweep.folder`).
"""

from __future__ import annotations

import shutil
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path

from vcran.io.runfolder import incomplete
from vcran.sweep.folder import carry_runs, check, check_format, finish, open_folder, run_folder
from vcran.sweep.pool import Pool, PoolError, open_pool
from vcran.sweep.spec import RunSpec, Sweep, load
from vcran.sweep.table import columns, csv_text
from vcran.sweep.worker import Row, run_one


@dataclass(frozen=True, slots=True)
class SweepResult:
    """The rows of a sweep: one per run that finished, in run order (a failed run's has its ``error``)."""

    rows: list[Row]
    #: Runs in the sweep; fewer rows than that only after Ctrl-C (``interrupted``).
    total: int
    interrupted: bool
    #: The columns before a run's results: run, variant, label (if variants are named), parameters, seed.
    head: list[str]
    #: The sweep that ran (its parameters and name label the figures).
    sweep: Sweep
    #: The folder ``run_sweep(keep_runs=DIR)`` wrote, absolute: ``DIR``, or ``DIR.incomplete`` after
    #: Ctrl-C; None without ``keep_runs``.
    folder: Path | None = None
    #: Why the pool broke off part way (the Dask scheduler went away), ``interrupted`` set too; None after
    #: Ctrl-C and for a sweep that ran to its end. :func:`run_sweep` raises it as a PoolError.
    lost: str | None = None
    #: What stopped an ``interrupted`` sweep here: the KeyboardInterrupt (Ctrl-C, or the CLI's SIGTERM,
    #: a subclass, which ``vcran sweep`` reports as exit 143 rather than 130); None otherwise.
    interrupt: KeyboardInterrupt | None = field(default=None, repr=False, compare=False)

    @property
    def failed(self) -> int:
        return sum(row["error"] is not None for row in self.rows)

    @property
    def columns(self) -> list[str]:
        """Every column of the runs table, in order; ``wall_seconds`` last."""
        return columns(self.rows, self.head)

    def write(self, out: str | Path, *, fmt: str = "png") -> list[Path]:
        """The folder ``vcran sweep --out out`` writes: ``runs.csv``, ``runs.parquet`` (with pyarrow) and
        the figures (with matplotlib, in format ``fmt``), staged in ``out.incomplete`` and renamed to
        ``out``; an earlier sweep's folder there is replaced whole, a folder vcran did not write refused
        (:class:`vcran.RunFolderError`, nothing written). Over the folder ``run_sweep(keep_runs=out)``
        wrote for this result, its kept runs stay (the folder of ``vcran sweep --keep-runs``). An
        interrupted sweep's folder is never renamed: its files go to ``out.incomplete``. The files
        written, where they are."""
        check_format(fmt)
        out = Path(out)
        mine = self._holds_its_rows(self.folder)
        if self.interrupted and mine and self.folder == incomplete(out).resolve():
            check(out)  # its own unfinished folder, runs and rows: written again where it is
            work = incomplete(out)
        else:
            work = open_folder(out)
            if not self.interrupted and mine and self.folder == out.resolve():
                carry_runs(out, work)
        return finish(work, out, self.sweep, self.rows, self.columns, interrupted=self.interrupted, fmt=fmt)

    def _holds_its_rows(self, folder: Path | None) -> bool:
        """``folder`` still holds this sweep (its ``runs.csv``, wall times and all, is this result's): not
        replaced since by another sweep into the same place, whose runs are not this one's."""
        if folder is None or not (folder / "runs.csv").is_file():
            return False
        return (folder / "runs.csv").read_bytes() == csv_text(self.rows, self.columns).encode("utf-8")


def run_sweep(sweep: Sweep | str | Path, *, workers: int | None = None, cluster: str | None = None,
              keep_runs: str | Path | None = None, on_row: Callable[[Row], None] | None = None,
              fmt: str = "png") -> SweepResult:
    """Every run of ``sweep`` (a :class:`Sweep` or a sweep file's path), in this process
    (``workers=1``), on ``workers`` local processes (default: one per CPU) or on the Dask scheduler at
    ``cluster`` (``"tcp://host:8786"``); ``workers`` below 1, or with ``cluster``, is a ValueError before
    anything runs. ``on_row`` sees each row as it arrives. Ctrl-C returns the rows done so far; a cluster
    lost part way raises :class:`~vcran.sweep.pool.PoolError`, whose ``result`` holds them.

    ``keep_runs=DIR`` writes the folder ``vcran sweep --out DIR --keep-runs`` does (each run's folder in
    ``runs/0007/``, the tables, the figures in format ``fmt``): staged in ``DIR.incomplete`` and renamed
    to ``DIR`` when the sweep has ended (after Ctrl-C, or an error, it stays ``DIR.incomplete``); an
    earlier sweep's ``DIR`` is replaced whole, and a folder vcran did not write refused before a run
    starts (:class:`vcran.RunFolderError`)."""
    check_format(fmt)
    if not isinstance(sweep, Sweep):
        sweep = load(sweep)
    out = Path(keep_runs) if keep_runs is not None else None
    work = open_folder(out) if out is not None else None
    try:
        pool = open_pool(workers, cluster, jobs=len(sweep.seeds) * len(sweep.variants))
    except BaseException:
        if work is not None:
            shutil.rmtree(work, ignore_errors=True)  # nothing ran: no folder left behind
        raise
    try:
        # the workers (local processes, or Dask's on a shared file system) write kept runs into the staging folder
        result = execute(sweep, pool, keep_runs=work.resolve() if work is not None else None, on_row=on_row)
    finally:
        pool.close()
    if work is not None and out is not None:
        finish(work, out, sweep, result.rows, result.columns, interrupted=result.interrupted, fmt=fmt)
        result = replace(result, folder=(work if result.interrupted else out).resolve())
    if result.lost is not None:  # not a sweep to analyse as if complete: raised, its rows with it
        where = f"; their rows are in {result.folder / 'runs.csv'}" if result.folder is not None else ""
        error = PoolError(f"{result.lost}: {len(result.rows)} of {result.total} runs done{where}")
        error.result = result
        raise error
    return result


def execute(sweep: Sweep, pool: Pool, *, keep_runs: Path | None = None,
            on_row: Callable[[Row], None] | None = None) -> SweepResult:
    """The runs of :func:`run_sweep` on a pool that the caller opened and closes; ``keep_runs`` is the
    folder the runs are kept under, as it is (the caller stages it: :mod:`vcran.sweep.folder`)."""
    specs = sweep.runs()
    source = str(sweep.scenario_path)
    jobs = [(sweep.scenario_text, source, spec.overrides,
             str(run_folder(keep_runs, spec.index)) if keep_runs is not None else None) for spec in specs]
    rows: dict[int, Row] = {}
    interrupted, lost, interrupt = False, None, None
    try:
        for i, result in pool.run(run_one, jobs):
            rows[i] = row(sweep, specs[i], result)
            if on_row is not None:
                on_row(rows[i])
    except KeyboardInterrupt as exc:
        interrupted, interrupt = True, exc
        pool.stop()
    except PoolError as exc:  # the cluster went away: the rows done are kept, the sweep is not complete
        interrupted, lost = True, str(exc)
        pool.stop()
    return SweepResult([rows[i] for i in sorted(rows)], len(specs), interrupted, head(sweep), sweep, lost=lost,
                       interrupt=interrupt)


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
