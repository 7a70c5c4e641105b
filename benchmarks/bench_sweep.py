"""Sweeps (docs/contract.md §10): 40 runs of the 10-robot hour on 1 worker vs 2, and the Dask path against the local
process pool, in one run.

    python benchmarks/bench_sweep.py                 # 40 runs of vcran gen --robots 10 --hours 1
    python benchmarks/bench_sweep.py --runs 8 --tiny 100

The fleet is ``vcran gen --robots 10 --hours 1 --seed 1``; the sweep crosses four task timeouts with
``runs / 4`` seeds. Each pool runs the same sweep through :func:`vcran.sweep.runs.execute`:

* this process (``--workers 1``: no pool at all),
* the local process pool with 2 workers (``--workers 2``; its start-up included),
* a Dask ``LocalCluster`` of 2 worker processes with one thread each, already running (a user's cluster
  is up before the sweep; its start-up is printed apart), reached over tcp on loopback.

The Dask overhead per run shows best on many tiny runs, so ``--tiny N`` also runs N seeds of the demo
(a few milliseconds each) on the pool and on Dask. Every pool must give the same rows (wall time aside);
the script checks it. Each figure is the least of ``--repeat`` rounds in which the pools take turns.
Wall-clock figures on a shared machine: compare the ratios of one run, and mind the load it prints.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from vcran.io.gen import generate  # noqa: E402
from vcran.sweep.pool import DaskPool, InProcess, LocalPool, Pool  # noqa: E402
from vcran.sweep.runs import execute  # noqa: E402
from vcran.sweep.spec import Sweep, load  # noqa: E402

TIMEOUTS = (20.0, 30.0, 45.0, 60.0)


def sweep_file(folder: Path, runs: int) -> Path:
    (folder / "fleet.toml").write_text(generate(10, 1.0, 1), encoding="utf-8")
    path = folder / "fleet-sweep.toml"
    path.write_text(f'scenario = "fleet.toml"\nseeds = {{from = 1, count = {max(runs // len(TIMEOUTS), 1)}}}\n'
                    f'[grid]\n"simulation.task_timeout" = {list(TIMEOUTS)}\n', encoding="utf-8")
    return path


def tiny_file(folder: Path, runs: int) -> Path:
    path = folder / "tiny-sweep.toml"
    path.write_text(f'scenario = "{(ROOT / "scenarios" / "demo.toml").as_posix()}"\n'
                    f"seeds = {{from = 1, count = {runs}}}\n", encoding="utf-8")
    return path


def once(sweep: Sweep, pool: Callable[[], Pool]) -> tuple[float, list[dict]]:
    """One sweep on a fresh pool (its start-up counts): wall time and rows without the wall column."""
    start = time.perf_counter()
    opened = pool()
    try:
        result = execute(sweep, opened)
    finally:
        opened.close()
    wall = time.perf_counter() - start
    assert result.failed == 0, [r["error"] for r in result.rows if r["error"]]
    return wall, [{k: v for k, v in r.items() if k != "wall_seconds"} for r in result.rows]


def interleaved(cases: dict[str, tuple[Sweep, Callable[[], Pool]]], repeat: int) -> dict[str, float]:
    """The least wall time of ``repeat`` rounds per case, the cases taking turns within each round: on a
    shared machine whose load drifts, no case gets the quiet minutes alone, and the least of a case's
    times is the one the others' load disturbed least. Every case of one sweep must give the same rows."""
    walls: dict[str, list[float]] = {name: [] for name in cases}
    rows: dict[int, list[dict]] = {}
    for _ in range(repeat):
        for name, (sweep, pool) in cases.items():
            wall, got = once(sweep, pool)
            walls[name].append(wall)
            assert rows.setdefault(id(sweep), got) == got, f"{name} gave other rows"
    return {name: min(w) for name, w in walls.items()}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=40, help="runs of the 10-robot hour (default 40)")
    parser.add_argument("--tiny", type=int, default=200, help="demo runs for the per-run overhead (default 200)")
    parser.add_argument("--repeat", type=int, default=2, help="sweeps per pool, the least wall time counts (default 2)")
    args = parser.parse_args()

    from distributed import LocalCluster

    figures: dict[str, float] = {}
    load_before = os.getloadavg()[0]
    with tempfile.TemporaryDirectory(prefix="vcran-bench-sweep-") as tmp:
        folder = Path(tmp)
        fleet, tiny = load(sweep_file(folder, args.runs)), load(tiny_file(folder, args.tiny))
        runs = len(fleet.runs())
        start = time.perf_counter()
        with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, protocol="tcp", host="127.0.0.1",
                          scheduler_port=0, dashboard_address=None) as cluster:
            figures["dask_start"] = time.perf_counter() - start
            address = cluster.scheduler_address
            figures.update(interleaved({
                "one": (fleet, InProcess),
                "pool": (fleet, lambda: LocalPool(2)),
                "dask": (fleet, lambda: DaskPool(address)),
                "tiny_pool": (tiny, lambda: LocalPool(2)),
                "tiny_dask": (tiny, lambda: DaskPool(address)),
            }, args.repeat))
    load_average = os.getloadavg()[0]
    per_run = figures["one"] / runs
    print(f"## Sweep: {runs} runs of the 10-robot hour (vcran gen --robots 10 --hours 1), {os.cpu_count()} cores, "
          f"load average {load_before:.1f} before and {load_average:.1f} at the end (this benchmark's own processes "
          f"count), least of {args.repeat} interleaved rounds\n")
    print("| pool | wall s | s per run | speed-up vs 1 worker |")
    print("|---|---|---|---|")
    for key, name in (("one", "1 worker (this process)"), ("pool", "2 local processes"),
                      ("dask", "Dask LocalCluster, 2 processes x 1 thread")):
        print(f"| {name} | {figures[key]:.1f} | {figures[key] / runs:.2f} | {figures['one'] / figures[key]:.2f}x |")
    print(f"\nDask path against the process pool: {figures['dask'] / figures['pool']:.2f}x the wall time "
          f"({runs} runs of {per_run:.2f} s); on {args.tiny} tiny demo runs "
          f"{figures['tiny_dask'] / figures['tiny_pool']:.2f}x "
          f"(pool {1000 * figures['tiny_pool'] / args.tiny:.1f} ms per run, "
          f"Dask {1000 * figures['tiny_dask'] / args.tiny:.1f} ms per run). "
          f"LocalCluster start-up {figures['dask_start']:.1f} s, not counted.")
    results = ROOT / "benchmarks" / "results"
    results.mkdir(exist_ok=True)
    (results / f"sweep-{int(time.time())}.json").write_text(json.dumps({"runs": runs, **figures}, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
