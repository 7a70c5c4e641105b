"""What safety fields cost (docs/contract.md §12, issue 32's "Must show"): two fleets with fields on vs off.

    python benchmarks/bench_traffic.py                         # 1000 robots, one simulated hour
    python benchmarks/bench_traffic.py --robots 100 --hours 0.25 --case queues

Each fleet (below) has collisions reported, the default. Two variants run as ``vcran run`` child
processes: *off* (the file as written: no field) and *on* (``[traffic] field =
{ margin = MARGIN }``: every robot a field of ``MARGIN`` m plus its braking distance, 1.5 m at the
generated 1.5 m/s and 0.75 m/s², so up to 3 m at the default 1.5 m margin). Each runs twice, in the order
off, on, on, off, and its faster run counts, which evens out a shared machine's drift; the ratio is from
this one invocation, in the child's CPU time (less disturbed by other processes than wall time, shown
too). Target (issue 32): on at most 1.5x off.

Two fleets (``--case``, both by default):

- *flowing*: the generated fleet. Its robots keep to their own 60 m cells (stations 16 m or more from a
  neighbour's, and a field reaches at most its margin past where its motion ends), so they never meet: the
  table's blocks column says so for each run. What is measured is the price of watching: filing every
  field in the grid and testing it against its neighbours on every leg, the case of a fleet that flows.
- *queues*: robots that meet all the time. Loops of 4 robots, each loop a one-way 20 m square lane of its
  own (40 m apart), its robots starting 3 m apart on its first side, all sent round it (corners, then the
  start corner) every 80 s (a lap alone is about 66 s). Every leg ends at rest at a corner, where the robot
  behind catches up: blocked until the one ahead turns and drives out of its field, and at the start
  corner until the one resting there leaves on its next lap. With fields off they drive through each other
  (collisions reported), so that run pays collision refinements instead.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from bench_s4 import run_variant

ROOT = Path(__file__).resolve().parent.parent
#: robots per loop in the *queues* fleet
PER_LOOP = 4


def with_fields(text: str, margin: float) -> str:
    """The generated file with a fleet-wide field, in a ``[traffic]`` table before the first robot."""
    head, sep, rest = text.partition("\n[[robots]]\n")
    return f"{head}\n[traffic]\nfield = {{ margin = {margin!r} }}\n{sep}{rest}"


def queues(robots: int, hours: float) -> str:
    """The *queues* fleet (module docstring): ``robots`` in loops of :data:`PER_LOOP`, for ``hours``."""
    side, pitch, spacing, every = 20.0, 40.0, 3.0, 80.0
    loops = math.ceil(robots / PER_LOOP)
    across = math.ceil(math.sqrt(loops))
    duration = hours * 3600.0
    head = ["[simulation]", f'name = "queues-{robots}x{hours:g}h"', "seed = 1", f"duration = {duration!r}", ""]
    fleet: list[str] = []
    script: list[str] = []
    for i in range(robots):
        loop, j = divmod(i, PER_LOOP)
        ox, oy = pitch * (loop % across), pitch * (loop // across)
        rid = f"robot_{i + 1}"
        fleet += ["[[robots]]", f'id = "{rid}"', f"pose = [{ox + spacing * j!r}, {oy!r}, 0.0]",
                  "max_velocity = 1.5", "max_acceleration = 0.75", "max_angular_velocity = 1.5", ""]
        corners = ((ox + side, oy), (ox + side, oy + side), (ox, oy + side), (ox, oy))
        path = ", ".join(f"[{x!r}, {y!r}]" for x, y in corners)
        script += ["[[script]]", f"t = {1.0 + 0.01 * j!r}", f'robot = "{rid}"', 'kind = "cycle"', f'prefix = "r{i + 1}"',
                   f"every = {every!r}", f"until = {duration!r}", f"tasks = [{{path = [{path}]}}]", ""]
    return "\n".join(head + fleet + script)


def measure(base: str, margin: float) -> tuple[dict[str, float], dict[str, float], dict[str, dict[str, float]]]:
    """Run ``base`` without fields and with them (module docstring): best CPU and wall seconds per variant,
    and each variant's figures from its summary."""
    texts = {"off": base, "on": with_fields(base, margin)}
    walls: dict[str, list[float]] = {name: [] for name in texts}
    cpus: dict[str, list[float]] = {name: [] for name in texts}
    facts: dict[str, dict[str, float]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        for name in ("off", "on", "on", "off"):
            summary = run_variant(work, name, texts[name], walls, cpus)
            robots = summary["robots"].values()
            facts[name] = {
                "legs": len(np.load(work / f"out-{name}" / "legs.npy")),
                "tasks": sum(len(r["completed"]) for r in robots),
                "collisions": sum(r.get("collisions", 0) for r in robots),
                "blocks": sum(r.get("blocks", 0) for r in robots),
                "blocked_time": sum(r.get("blocked_time", 0.0) for r in robots),
                "deadlocks": summary.get("traffic", {}).get("deadlocks", 0),
            }
    return ({name: min(c) for name, c in cpus.items()}, {name: min(w) for name, w in walls.items()}, facts)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--robots", type=int, default=1000)
    parser.add_argument("--hours", type=float, default=1.0)
    parser.add_argument("--margin", type=float, default=1.5, help="field length at rest, m (default 1.5)")
    parser.add_argument("--case", choices=("flowing", "queues", "both"), default="both")
    args = parser.parse_args()
    sys.path.insert(0, str(ROOT))
    from vcran.io.gen import generate

    cases = {"flowing": lambda: generate(args.robots, args.hours, 1), "queues": lambda: queues(args.robots, args.hours)}
    print(f"{args.robots} robots x {args.hours:g} h, fields of {args.margin:g} m + braking distance; best of two "
          "runs each.\nCPU time (user + system of the child) is the figure to compare on a shared machine; wall "
          "time is shown too.")
    record: dict[str, object] = {}
    for case, make in cases.items():
        if args.case not in (case, "both"):
            continue
        cpu, wall, facts = measure(make(), args.margin)
        record[case] = {"cpus": cpu, "walls": wall, "facts": facts}
        print(f"\n{case} ({'vcran gen seed 1' if case == 'flowing' else f'loops of {PER_LOOP}'}):\n")
        print("| fields | CPU s | CPU ratio to off | wall s | wall ratio | tasks | legs | CPU ms per leg | collisions "
              "| blocks | blocked s | deadlocks |")
        print("|---|---|---|---|---|---|---|---|---|---|---|---|")
        for name in ("off", "on"):
            f = facts[name]
            print(f"| {name} | {cpu[name]:.1f} | {cpu[name] / cpu['off']:.3f}x | {wall[name]:.1f} | "
                  f"{wall[name] / wall['off']:.3f}x | {f['tasks']:.0f} | {f['legs']:.0f} | "
                  f"{1000 * cpu[name] / max(f['legs'], 1):.2f} | {f['collisions']:.0f} | {f['blocks']:.0f} | "
                  f"{f['blocked_time']:.1f} | {f['deadlocks']:.0f} |")
    results = ROOT / "benchmarks" / "results"
    results.mkdir(exist_ok=True)
    (results / f"traffic-{int(time.time())}.json").write_text(json.dumps(record, indent=2))


if __name__ == "__main__":
    main()
