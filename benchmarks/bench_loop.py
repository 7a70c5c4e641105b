"""The closed loop in process (docs/contract.md §9): the warehouse with its dispatcher, and the cost of the loop.

    python benchmarks/bench_loop.py              # scenarios/warehouse.toml, best of 3
    python benchmarks/bench_loop.py --repeat 5 --scenario my.toml

Three runs of the same simulated hour, each timed in process (best of ``--repeat``):

* **in memory**: ``vcran.simulate(scenario)``, nothing written: simulated seconds per wall second;
* **loop, run folder**: the same with ``out=`` (trace, telemetry, events, summary written);
* **fixed script**: the manager's writes, as the loop run's trace recorded them (when each reached the
  RAN), decoded beforehand into a message script and played by the scripted transport, in memory: the
  RAN does the same work at the same instants, but no manager, job book or link runs. The ratio loop /
  fixed script is what the closed loop costs over a scripted run of the same fleet and workload;
* **replay of the trace** (``ReplayTransport``, with a run folder), which also checks that the trace
  reproduces the loop run (docs/contract.md §6), so the script did the same simulation.

Wall-clock figures on a shared machine swing with its load: compare the ratios within one run. The CPU
seconds of the same runs (``time.process_time``, the best of ``--repeat`` too) swing much less, and are
what docs/library.md quotes for the warehouse hour, with the machine and Python that measured them.
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import vcran  # noqa: E402
from transports.replay import ReplayTransport, inbound_records  # noqa: E402
from transports.scripted import ScriptedTransport  # noqa: E402
from vcran.core.scenario import ScriptEntry  # noqa: E402
from vcran.io.sinks import MemorySinks  # noqa: E402
from vcran.io.trace import trace_in  # noqa: E402
from vcran.io.verify import scenario_from_trace, verify  # noqa: E402
from vcran.runner import execute, run_to  # noqa: E402


def best(repeat: int, fn) -> tuple[float, float]:  # type: ignore[no-untyped-def]
    """The least wall time and the least CPU time of ``repeat`` calls of ``fn``."""
    walls, cpus = [], []
    for _ in range(repeat):
        start, cpu = time.perf_counter(), time.process_time()
        fn()
        walls.append(time.perf_counter() - start)
        cpus.append(time.process_time() - cpu)
    return min(walls), min(cpus)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", type=Path, default=ROOT / "scenarios" / "warehouse.toml")
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    scenario = vcran.load_scenario(args.scenario)

    with tempfile.TemporaryDirectory(prefix="vcran-bench-loop-") as work:
        folder = Path(work)
        result = vcran.simulate(scenario)
        sim = result.summary["sim_time"]
        memory = best(args.repeat, lambda: vcran.simulate(scenario))
        written = best(args.repeat, lambda: vcran.simulate(scenario, out=folder / "loop"))
        trace = trace_in(folder / "loop")
        replayed = scenario_from_trace(trace)
        entries = [ScriptEntry(t, i.entity, i.attribute, i.message, i.raw) for t, i in inbound_records(trace)]

        def scripted() -> None:
            ran = execute(replayed, ScriptedTransport(iter(entries)), MemorySinks())
            ends.append(ran.model.env.now)

        ends: list[float] = []
        script = best(args.repeat, scripted)
        replay = best(args.repeat, lambda: run_to(replayed, folder / "replay", ReplayTransport(trace)))
        difference = verify(trace, folder / "replay")
        if difference is not None:
            raise SystemExit(f"the replay differs from the loop run: {difference}")

    jobs = result.summary["jobs"]
    print(f"# {args.scenario.name}: {len(scenario.robots)} robots, {sim:.0f} s simulated, "
          f"{jobs['completed']} of {jobs['arrived']} jobs done; best of {args.repeat}; Python "
          f"{platform.python_version()} on {platform.machine()}, {os.cpu_count()} CPUs, load average "
          f"{os.getloadavg()[0]:.1f}\n")
    print(f"(the fixed script ends at {ends[0]:.0f} s simulated: its last write's task done)\n")
    print("| run | wall (s) | CPU (s) | simulated s per wall s | CPU vs fixed script |")
    print("|---|---:|---:|---:|---:|")
    runs = (("loop, in memory", memory), ("fixed script, in memory", script), ("loop, run folder", written),
            ("replay of its trace, run folder", replay))
    for name, (wall, cpu) in runs:
        print(f"| {name} | {wall:.3f} | {cpu:.3f} | {sim / wall:,.0f} | {cpu / script[1]:.2f}x |")


if __name__ == "__main__":
    main()
