"""A sweep's folder, complete or visibly incomplete (docs/contract.md §6, §10, docs/sweeps.md).

``vcran sweep --out DIR``, ``run_sweep(keep_runs=DIR)`` and ``SweepResult.write(DIR)`` all write it with
this code, the way a run folder is written (:mod:`vcran.io.runfolder`): :func:`open_folder` checks ``DIR``
(an earlier sweep's or run's folder may be replaced, anything else is refused, as is the folder you are
in) and makes a fresh ``DIR.incomplete``; the runs kept, the tables and the figures go there; and
:func:`finish` renames it to ``DIR`` only when the sweep ran to its end. An interrupted sweep keeps its rows
in ``DIR.incomplete``, and so does one that fails, with any earlier ``DIR`` untouched: never new rows beside
an older sweep's figures and runs, never a folder that looks finished and is not.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

from vcran.io.runfolder import SWEEP_FORMATS, check_out, publish, staging
from vcran.sweep.spec import Sweep
from vcran.sweep.table import write_tables
from vcran.sweep.worker import Row

#: Folder of a run's outputs under the sweep's folder, with ``--keep-runs`` (``runs/0007``).
RUNS_DIR = "runs"


def check_format(fmt: str) -> None:
    """A ValueError for a figure format other than those a sweep's folder may hold (``SWEEP_FORMATS``): a
    folder with another would no longer be recognised as a sweep's, and the next sweep into it refused."""
    if fmt not in SWEEP_FORMATS:
        raise ValueError(f"figure format must be one of {', '.join(SWEEP_FORMATS)}, got {fmt!r}")


def open_folder(out: Path) -> Path:
    """A fresh, empty ``out.incomplete`` to write the sweep in; :class:`vcran.RunFolderError` (nothing
    written) when ``out`` is a folder vcran did not write, the folder you are in or one that holds it."""
    return staging(out, "sweep")


def check(out: Path) -> None:
    """:func:`open_folder`'s refusals alone, for a folder that exists already (its own unfinished sweep)."""
    check_out(out, "sweep")


def run_folder(out: Path, index: int) -> Path:
    return out / RUNS_DIR / f"{index:04d}"


def finish(work: Path, out: Path, sweep: Sweep, rows: list[Row], columns: list[str], *, interrupted: bool,
           fmt: str = "png") -> list[Path]:
    """Write the tables into the staging folder ``work`` and, unless the sweep was ``interrupted``, the
    figures, then rename it to ``out``. The files written, where they are now: in ``out``, or in
    ``work`` for an interrupted sweep, which is never renamed (its runs stay beside its rows)."""
    files = write_tables(work, rows, columns)
    if interrupted:
        return files
    files += figures(sweep, rows, work, fmt)
    publish(work, out)
    return [out / f.relative_to(work) for f in files]


def have_matplotlib() -> bool:
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        return False
    return True


def compared(sweep: Sweep) -> bool:
    """Whether ``sweep`` has figures: a swept parameter, or named variants, to compare runs by."""
    return bool(sweep.parameters or sweep.labelled)


def figures(sweep: Sweep, rows: list[Row], out: Path, fmt: str) -> list[Path]:
    """The comparison figures, when there is something to compare and matplotlib to draw it."""
    if not compared(sweep) or not have_matplotlib():
        return []
    from vcran.sweep.figures import draw

    return draw(sweep, rows, out, fmt)


def carry_runs(old: Path, work: Path) -> None:
    """The kept runs of the sweep folder ``old`` into the staging folder ``work`` that will replace it:
    hard links where the file system allows (instant, no second copy of the traces), copies elsewhere.
    ``old`` stays whole until :func:`finish` renames ``work`` over it. None there (Dask workers without a
    file system shared with this machine kept them on theirs): nothing to carry."""
    if not (old / RUNS_DIR).is_dir():
        return
    shutil.copytree(old / RUNS_DIR, work / RUNS_DIR, copy_function=_link_or_copy, symlinks=True)


def _link_or_copy(src: str, dst: str) -> None:
    try:
        os.link(src, dst)
    except OSError:
        shutil.copy2(src, dst)
