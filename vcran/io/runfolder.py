"""Run folders that are complete or visibly incomplete (docs/contract.md §6, §8).

A run writes into a sibling of its ``--out`` folder named ``<name>.incomplete`` and renames it to
``<name>`` only when every file is closed. A run that is interrupted, crashes or is killed leaves
``<name>.incomplete`` behind (the next run into ``<name>`` clears it), never a folder that looks finished,
and never a fresh partial trace beside an older run's ``summary.json``. An existing ``--out`` is
replaced only when it is a vcran run folder; anything else is refused rather than mixed into.
``vcran manage --out`` writes its folder (the job events and a summary, no trace) the same way, and so do
``vcran sweep --out``, ``vcran.run_sweep(keep_runs=)`` and ``SweepResult.write`` (vcran.sweep.folder: the
tables, figures and kept runs; an earlier sweep's folder is replaced whole, never new rows beside old
figures and runs).
"""

from __future__ import annotations

import os
import re
import shutil
from pathlib import Path

#: Everything a run folder may hold (both trace formats, `--report`'s subfolder, `vcran view`'s page, and the
#: scenario a sweep keeps beside a run, docs/sweeps.md).
RUN_FILES = frozenset({
    "trace.jsonl.zst", "legs.npy", "events.jsonl.zst", "summary.json",
    "trace.jsonl", "telemetry.bin", "events.jsonl", "report", "view.html", "scenario.toml",
})
#: What ``vcran manage --out`` writes: a fleet manager's job events and summary (docs/live.md), and the page
#: `vcran view` may write into it.
MANAGE_FILES = frozenset({"events.jsonl.zst", "summary.json", "view.html"})
#: What ``vcran sweep --out`` writes (docs/sweeps.md): its tables, a figure per swept parameter in either
#: format, and with ``--keep-runs`` a folder ``runs/NNNN`` per run (``NNNN.incomplete`` for one that failed
#: part way). Spelled here, not imported from vcran.sweep: a run imports no sweep machinery.
SWEEP_TABLES = frozenset({"runs.csv", "runs.parquet"})
SWEEP_FORMATS = ("png", "svg")
SWEEP_FIGURE = re.compile(rf"kpi-by-.+\.({'|'.join(SWEEP_FORMATS)})")
SWEEP_RUN = re.compile(r"[0-9]{4,}(\.incomplete)?")
INCOMPLETE = ".incomplete"


class RunFolderError(ValueError):
    """``--out`` cannot receive a run (it holds something else)."""


def is_run_folder(path: Path) -> bool:
    """A folder with a trace and nothing but what a run writes, or what ``vcran manage`` writes."""
    names = {p.name for p in path.iterdir()}
    if names <= MANAGE_FILES and "events.jsonl.zst" in names:
        return True
    return names <= RUN_FILES and bool(names & {"trace.jsonl.zst", "trace.jsonl"})


def is_sweep_folder(path: Path) -> bool:
    """A folder with ``runs.csv`` (every sweep writes it) and nothing but what a sweep writes; its ``runs``
    holding nothing but run folders by number. What is inside those is not read: a sweep is replaced whole."""
    names = {p.name for p in path.iterdir()}
    if "runs.csv" not in names:
        return False
    rest = names - SWEEP_TABLES - {"runs"}
    if any(not SWEEP_FIGURE.fullmatch(name) for name in rest):
        return False
    runs = path / "runs"
    if "runs" not in names:
        return True
    return runs.is_dir() and all(p.is_dir() and SWEEP_RUN.fullmatch(p.name) for p in runs.iterdir())


def is_output_folder(path: Path) -> bool:
    """What ``vcran sweep --out`` replaces: a sweep's folder, or a run's (or ``vcran manage``'s)."""
    return is_sweep_folder(path) or is_run_folder(path)


def check_out(out: Path, what: str = "run") -> None:
    """Raise :class:`RunFolderError` unless ``out`` may receive a run (``what="run"``: missing, empty, or
    a run folder) or a sweep (``what="sweep"``: missing, empty, or a sweep's or a run's folder)."""
    full, here = Path(os.path.abspath(out)), Path.cwd()
    if full == here or full in here.parents:  # "--out .": it would be renamed away under the shell
        raise RunFolderError(f"{out}: is the folder you are in, or holds it; a {what} replaces its output folder "
                             f"as a whole: name a folder inside it (e.g. {what}s/first)")
    if out.name.endswith(INCOMPLETE):
        raise RunFolderError(f"{out}: names an unfinished {what}'s folder; choose another output folder")
    if not out.exists():
        return
    if not out.is_dir():
        raise RunFolderError(f"{out}: exists and is not a folder")
    if what == "sweep":
        kind, replaceable = "output folder (a sweep's or a run's)", is_output_folder
    else:
        kind, replaceable = "run folder", is_run_folder
    if any(out.iterdir()) and not replaceable(out):
        raise RunFolderError(f"{out}: exists and is not a vcran {kind}; refusing to write a {what} into it "
                             "(choose a new output folder, or remove it)")


def incomplete(out: Path) -> Path:
    """``<out>.incomplete``: where a run or a sweep into ``out`` is written until it is complete."""
    return out.with_name(out.name + INCOMPLETE)


def staging(out: Path, what: str = "run") -> Path:
    """A fresh, empty ``<out>.incomplete`` beside ``out`` (checked with :func:`check_out` first); ``what``
    (``"run"`` or ``"sweep"``) is what will be written there."""
    check_out(out, what)
    work = incomplete(out)
    try:
        if work.exists():
            shutil.rmtree(work)  # an earlier interrupted run into the same --out
        work.mkdir(parents=True)
    except OSError as exc:  # a read-only or missing parent, a file on the way: named as the --out it is for
        raise RunFolderError(f"{out}: cannot create {work.name} beside it to write the {what} in: "
                             f"{exc.strerror or exc}") from None
    return work


def publish(work: Path, out: Path) -> None:
    """Put the finished run ``work`` in place of ``out``: renames, so a reader never sees a mix."""
    old = None
    if out.exists():
        old = out.with_name(f"{out.name}.replaced-{os.getpid()}")
        out.rename(old)
    work.rename(out)
    if old is not None and old.is_symlink():  # an --out that led elsewhere: the link goes, not what it led to
        old.unlink()
    elif old is not None:
        shutil.rmtree(old, ignore_errors=True)
