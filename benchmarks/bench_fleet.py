"""Fleet-size sweep: ``vcran run`` on generated fleets against a bare-SimPy floor, in one run.

    python benchmarks/bench_fleet.py                      # 1, 10, 100, 1000 robots, one simulated hour
    python benchmarks/bench_fleet.py --sizes 1 10 --hours 0.25
    python benchmarks/bench_fleet.py --flat 100           # peak memory for 0.5 h, 1 h and 2 h of 100 robots

For each size it times the whole ``vcran run`` process (interpreter start-up included, as a user sees
it) on ``vcran gen --robots N --hours H --seed 1``, and reads back the simulated time, the events logged
and the output size; peak memory is the child's own ``ru_maxrss``. The floor is a bare SimPy program in a
child process too: N processes that each wake once per simulated second (the per-robot periodic work a
naive model would schedule as N timers) for the same simulated time. Figures are wall-clock and this
machine is shared: compare the ratios within one run, not absolute numbers across runs.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

CHILD = r"""
import json, resource, sys, time
start = time.perf_counter()
kind = sys.argv[1]
if kind == "vcran":
    from vcran.cli import main
    code = main(["run", sys.argv[2], "--out", sys.argv[3], "--quiet"])
    extra = {"code": code}
else:
    import simpy
    robots, seconds = int(sys.argv[2]), float(sys.argv[3])
    env = simpy.Environment()
    published = [0]
    def robot(env):
        while True:
            yield env.timeout(1.0)
            published[0] += 1
    for _ in range(robots):
        env.process(robot(env))
    env.run(until=seconds)
    extra = {"events": published[0]}
extra["wall_inside"] = time.perf_counter() - start
extra["maxrss_kib"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print(json.dumps(extra))
"""


def child(*args: str) -> tuple[dict, float]:
    start = time.perf_counter()
    out = subprocess.run([sys.executable, "-c", CHILD, *args], capture_output=True, text=True, cwd=ROOT,
                         env={**os.environ, "PYTHONHASHSEED": "0"})
    wall = time.perf_counter() - start
    if out.returncode != 0:
        raise SystemExit(f"child failed: {' '.join(args)}\n{out.stderr}")
    return json.loads(out.stdout.strip().splitlines()[-1]), wall


def bench(robots: int, hours: float, work: Path) -> dict:
    from vcran.io.gen import generate

    scenario = work / f"fleet-{robots}.toml"
    scenario.write_text(generate(robots, hours, 1))
    out = work / f"out-{robots}-{hours}"
    info, wall = child("vcran", str(scenario), str(out))
    summary = json.loads((out / "summary.json").read_text())
    with (out / "events.jsonl").open("rb") as f:
        events = sum(1 for _ in f)
    with (out / "trace.jsonl").open("rb") as f:
        records = sum(1 for _ in f) - 2  # header and end line
    size = sum(p.stat().st_size for p in out.iterdir())
    tasks = sum(len(r["completed"]) for r in summary["robots"].values())
    floor, floor_wall = child("floor", str(robots), str(summary["sim_time"]))
    sim = summary["sim_time"]
    ticks = int(sim) + 1
    return {
        "robots": robots, "hours": hours, "sim_time": sim, "wall": wall, "speed": sim / wall,
        "tasks": tasks, "events": events, "events_per_s": events / wall,
        # every periodic record (current_motion per robot per tick) counts as published work
        "records_per_s": (records + ticks * robots) / wall,
        "maxrss_mib": info["maxrss_kib"] / 1024, "output_mib": size / 2**20,
        "floor_wall": floor_wall, "floor_speed": sim / floor_wall, "floor_events_per_s": floor["events"] / floor_wall,
        "floor_maxrss_mib": floor["maxrss_kib"] / 1024,
    }


def table(rows: list[dict]) -> str:
    head = ("| robots | sim h | wall s | speed (sim s / wall s) | tasks | events/s | records/s | peak MiB "
            "| output MiB | floor wall s | floor speed | vcran / floor wall |")
    lines = [head, "|" + "|".join(["---"] * 12) + "|"]
    for r in rows:
        lines.append(
            f"| {r['robots']} | {r['hours']:g} | {r['wall']:.2f} | {r['speed']:,.0f} | {r['tasks']} | "
            f"{r['events_per_s']:,.0f} | {r['records_per_s']:,.0f} | {r['maxrss_mib']:.0f} | {r['output_mib']:.1f} | "
            f"{r['floor_wall']:.2f} | {r['floor_speed']:,.0f} | {r['wall'] / r['floor_wall']:.1f}x |"
        )
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--sizes", type=int, nargs="+", default=[1, 10, 100, 1000])
    parser.add_argument("--hours", type=float, default=1.0)
    parser.add_argument("--flat", type=int, metavar="ROBOTS", help="memory vs run length for this fleet size")
    parser.add_argument("--keep", type=Path, help="keep outputs in this folder")
    args = parser.parse_args()
    sys.path.insert(0, str(ROOT))
    with tempfile.TemporaryDirectory() as tmp:
        work = args.keep or Path(tmp)
        work.mkdir(parents=True, exist_ok=True)
        if args.flat:
            rows = [bench(args.flat, h, work) for h in (0.5, 1.0, 2.0)]
        else:
            rows = [bench(n, args.hours, work) for n in args.sizes]
    print(table(rows))
    results = ROOT / "benchmarks" / "results"
    results.mkdir(exist_ok=True)
    (results / f"fleet-{int(time.time())}.json").write_text(json.dumps(rows, indent=2))


if __name__ == "__main__":
    main()
