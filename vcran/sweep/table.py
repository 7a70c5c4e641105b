"""The runs table of a sweep: ``runs.csv`` always, ``runs.parquet`` with pyarrow (the ``sweep`` extra).

Columns are the rows' keys in a fixed order: run identity and parameters, seed, error, the KPIs every
run has (:data:`vcran.sweep.worker.KPIS`), any others (a closed loop's ``jobs_*``) in order of first
appearance, and ``wall_seconds`` last. A row without a column (a failed run has no KPIs) leaves it empty.
Numbers are written as Python's shortest round-trip repr, so the CSV is byte-identical for the same
sweep whatever ran it, ``wall_seconds`` aside. A parameter whose values are lists or tables is written
as its label in both files (:mod:`vcran.sweep.labels`: ``3 robots: robot_1, robot_2, robot_3``,
``[1.0, 0.0, 0.0]``), the text the figures' axes show; a column that mixes integers and floats is float
in Parquet.
"""

from __future__ import annotations

import csv
import io
import json
import os
from pathlib import Path
from typing import Any

from vcran.sweep.labels import Labels
from vcran.sweep.worker import KPIS, Row

WALL = "wall_seconds"


def columns(rows: list[Row], head: list[str]) -> list[str]:
    """``head`` (identity, parameters, seed, error), the KPI columns, ``wall_seconds``."""
    seen = dict.fromkeys([*head, "error", *KPIS])
    for r in rows:
        seen.update(dict.fromkeys(r))
    seen.pop(WALL, None)
    return [*seen, WALL]


def readable(rows: list[Row], names: list[str]) -> list[Row]:
    """``rows`` with each list or table value replaced by its label, one :class:`Labels` per column."""
    out = [dict(r) for r in rows]
    for name in names:
        values = [r[name] for r in rows if isinstance(r.get(name), (list, dict))]
        if values:
            labels = Labels(name, values)
            for r in out:
                if isinstance(r.get(name), (list, dict)):
                    r[name] = labels(r[name])
    return out


def csv_text(rows: list[Row], names: list[str]) -> str:
    rows = readable(rows, names)
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(names)
    for r in rows:
        writer.writerow([_cell(r.get(name)) for name in names])
    return buffer.getvalue()


def _cell(v: Any) -> str:
    if v is None:
        return ""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, float, str)):
        return repr(v) if isinstance(v, float) else str(v)
    return json.dumps(v, ensure_ascii=False, separators=(",", ":"))


def write_csv(path: Path, rows: list[Row], names: list[str]) -> None:
    _atomic(path, csv_text(rows, names).encode("utf-8"))


def have_parquet() -> bool:
    try:
        import pyarrow  # noqa: F401
    except ImportError:
        return False
    return True


def write_parquet(path: Path, rows: list[Row], names: list[str]) -> None:
    import pyarrow as pa
    import pyarrow.parquet as pq

    arrays = {}
    rows = readable(rows, names)
    for name in names:
        values = [r.get(name) for r in rows]
        kind, values = _typed(values)
        arrays[name] = pa.array(values, type=kind(pa))
    tmp = path.with_name(path.name + ".tmp")
    pq.write_table(pa.table(arrays), tmp)
    os.replace(tmp, path)


def write_tables(out: Path, rows: list[Row], names: list[str]) -> list[Path]:
    """``runs.csv``, and ``runs.parquet`` if pyarrow is installed; the files written."""
    out.mkdir(parents=True, exist_ok=True)
    files = [out / "runs.csv"]
    write_csv(files[0], rows, names)
    if have_parquet():
        files.append(out / "runs.parquet")
        write_parquet(files[1], rows, names)
    return files


def _typed(values: list[Any]) -> tuple[Any, list[Any]]:
    present = [v for v in values if v is not None]
    if present and all(isinstance(v, bool) for v in present):
        return (lambda pa: pa.bool_()), values
    if present and all(isinstance(v, int) and not isinstance(v, bool) for v in present):
        return (lambda pa: pa.int64()), values
    if present and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in present):
        return (lambda pa: pa.float64()), [None if v is None else float(v) for v in values]
    return (lambda pa: pa.string()), [None if v is None else _cell(v) for v in values]


def _atomic(path: Path, data: bytes) -> None:
    """Write ``path`` whole or not at all: a second Ctrl-C never leaves half a table."""
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_bytes(data)
    os.replace(tmp, path)
