"""One run of a sweep as a pure function of plain data: scenario text, overrides, seed -> row (docs/contract.md §10).

This is all a worker executes, in a process of the local pool or on a Dask worker on another machine, so
it takes and returns only strings, numbers, lists and dicts: nothing about pools, clusters or files
leaks into the simulation, and a worker needs vcran installed but not the sweep's files. The run is the
one ``vcran run`` does on the overridden scenario (same loader, then :func:`vcran.simulate`, its script or
its fleet manager), which is why a run in a sweep is byte-identical to the same variant and seed run
alone. Without a folder to keep, nothing touches the disk.
"""

from __future__ import annotations

import time
import tomllib
from pathlib import Path
from typing import Any

from vcran.api import manager_options, simulate
from vcran.core.opil.effects import Reason
from vcran.core.scenario import ManagerSpec
from vcran.core.vda5050.outcomes import OrderLog, order_logs
from vcran.io.scenario_file import parse
from vcran.io.scenario_toml import dumps
from vcran.sim.loop import manager_note
from vcran.sweep.overrides import apply, canonical

Row = dict[str, Any]


def run_one(scenario_text: str, source: str, overrides: list[tuple[str, Any]], out: str | None = None) -> Row:
    """Run the scenario ``scenario_text`` (read from ``source``, which names it in errors and gives its
    default name) with ``overrides`` applied, and return its KPIs (:func:`kpis`), ``error`` (None, or
    what went wrong: a failing run is a row, never a lost sweep) and ``wall_seconds``.

    With ``out`` the run folder is kept there, with the overridden scenario as ``scenario.toml`` (its
    name set, so that ``vcran run out/scenario.toml`` reproduces the run byte for byte).
    """
    start = time.perf_counter()
    kept: str | None = None
    try:
        data = apply(options_for_class(tomllib.loads(scenario_text), overrides), overrides)
        scenario = parse(data, source, default_name=Path(source).stem)
        data.setdefault("simulation", {})["name"] = scenario.settings.name
        kept = dumps(data)
        result = simulate(scenario, out=out)
        vda = scenario.settings.protocol == "vda5050"
        row: Row = {"error": None, **kpis(result.summary, order_logs(result.events) if vda else None)}
    except (Exception, SystemExit) as exc:  # noqa: BLE001 - any failure of one run is that run's row
        row = {"error": error_text(exc)}
    if out is not None and kept is not None:  # after the run: the run folder is written whole, then renamed
        folder = Path(out)
        folder.mkdir(parents=True, exist_ok=True)  # a failed run's folder holds the scenario that fails
        (folder / "scenario.toml").write_text(kept, encoding="utf-8")
    row["wall_seconds"] = time.perf_counter() - start
    return row


def options_for_class(base: dict[str, Any], overrides: list[tuple[str, Any]]) -> dict[str, Any]:
    """The scenario table ``base`` without its ``[manager] options`` when the overrides name another
    class, as ``--manager`` does (:func:`vcran.api.manager_options`, the one rule); options the sweep
    sets (``manager.options`` or ``manager.options.KEY``) are applied after, to whichever class runs. In
    the worker, which imports the class to run it anyway: the sweep's own process need not import it."""
    named = [value for path, value in overrides if canonical(path) == "manager.class"]
    own = base.get("manager")
    if not named or not isinstance(named[-1], str) or not isinstance(own, dict) or not own.get("options"):
        return base  # a class that is no string is the loader's to refuse
    if manager_options(ManagerSpec(own["class"], tuple(own["options"].items())), named[-1]):
        return base
    return {**base, "manager": {k: v for k, v in own.items() if k != "options"}}


def error_text(exc: BaseException) -> str:
    """A failed run's ``error`` cell: the exception, and for one its fleet manager raised the hook and the
    simulated time it raised at, as ``vcran run`` says them. A ``sys.exit()`` in a manager is its run's
    error too, the same in this process, a local pool and on Dask (where it would end the worker)."""
    note = manager_note(exc)
    return f"{type(exc).__name__}: {exc}".strip() + (f" ({note})" if note is not None else "")


#: The KPI columns every row has, in order; a closed-loop run adds ``jobs_*`` and ``utilisation``, a
#: fleet with batteries ``battery_used``, one with safety fields (docs/contract.md §12) :data:`TRAFFIC`.
KPIS = ("sim_time", "tasks_completed", "tasks_cancelled",
        *(f"cancelled_{r.value}" for r in Reason if r is not Reason.DEADLOCK), "distance", "parts_moved", "errors",
        "collisions")
#: docs/contract.md §12's columns, for runs whose robots had safety fields (summary.json's ``traffic``).
TRAFFIC = ("cancelled_deadlock", "blocks", "blocked_time", "deadlocks")


def kpis(summary: dict[str, Any], orders: dict[str, OrderLog] | None = None) -> dict[str, Any]:
    """The fleet's key figures from a run's summary (docs/outputs.md): task counts, cancels by reason,
    distance, parts moved, errors and collisions (docs/contract.md §4: each involves two robots, and each robot's
    summary counts it); with batteries the charge drawn (Ah); with a closed loop (docs/contract.md §9) every figure
    of its ``jobs`` section (``jobs_lead_time_p95``, ...) and the fleet's ``utilisation``; with safety fields
    (docs/contract.md §12) tasks cancelled for a deadlock and the summary's ``traffic``: blocks, blocked time (s),
    deadlocks. A VDA 5050 run's counts are of orders, as `vcran report` counts them from ``orders``
    (:mod:`vcran.core.vda5050.outcomes`, docs/report.md): completed, not completed by how (``action_failed``:
    completed with one of its actions FAILED), ``rejected``; ``cancelled_timeout`` is empty (no such thing)."""
    robots = summary["robots"].values()
    reasons = [c["reason"] for r in robots for c in r["cancelled"]]
    row: dict[str, Any] = {
        "sim_time": summary["sim_time"],
        "tasks_completed": sum(len(r["completed"]) for r in robots),
        "tasks_cancelled": len(reasons),
        **{f"cancelled_{r.value}": reasons.count(r.value) for r in Reason if r is not Reason.DEADLOCK},
        "distance": sum(r["distance"] for r in robots),
        "parts_moved": sum(r["parts_moved"] for r in robots),
        "errors": summary["errors"],
        "collisions": sum(r.get("collisions", 0) for r in robots) // 2,
    }
    if orders is not None:
        reasons = [e.outcome for log in orders.values() for e in log.ended if e.outcome != "completed"]
        row.update({"tasks_completed": sum(e.outcome == "completed" for log in orders.values() for e in log.ended),
                    "tasks_cancelled": len(reasons),
                    **{f"cancelled_{r.value}": reasons.count(r.value) for r in Reason if r is not Reason.DEADLOCK},
                    "cancelled_timeout": None, "rejected": sum(log.rejected for log in orders.values())})
    traffic = summary.get("traffic")
    if isinstance(traffic, dict):
        row["cancelled_deadlock"] = reasons.count(Reason.DEADLOCK.value)
        row.update({k: traffic[k] for k in TRAFFIC[1:]})
    batteries = [r["battery"] for r in robots if "battery" in r]
    if batteries:
        row["battery_used"] = sum(b["used"] for b in batteries)
    jobs = summary.get("jobs")
    if isinstance(jobs, dict):
        _flatten(row, "jobs_", jobs)
    utilisation = summary.get("utilisation")
    if isinstance(utilisation, dict) and "fleet" in utilisation:
        row["utilisation"] = utilisation["fleet"]
    return row


def _flatten(row: dict[str, Any], prefix: str, table: dict[str, Any]) -> None:
    for key, value in table.items():
        if isinstance(value, dict):
            _flatten(row, f"{prefix}{key}_", value)
        elif isinstance(value, (int, float)):  # None (no lead time without a completed job): an empty cell
            row[prefix + key] = value
