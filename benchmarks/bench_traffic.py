"""What safety fields cost (docs/contract.md §12, issue 32's "Must show"): a generated fleet with fields on vs off.

    python benchmarks/bench_traffic.py                         # 1000 robots, one simulated hour
    python benchmarks/bench_traffic.py --robots 100 --hours 0.25

The fleet is ``vcran gen --robots N --hours H --seed 1`` (collisions reported, the default). Two variants
run as ``vcran run`` child processes: *off* (the file as generated: no field) and *on* (``[traffic] field =
{ margin = MARGIN }``: every robot a field of ``MARGIN`` m plus its braking distance, 1.5 m at the
generated 1.5 m/s and 0.75 m/s², so up to 3 m at the default 1.5 m margin). Each runs twice, in the order
off, on, on, off, and its faster run counts, which evens out a shared machine's drift; the ratio is from
this one invocation, in the child's CPU time (less disturbed by other processes than wall time, shown
too). Target (issue 32): on at most 1.5x off.

A generated fleet's robots keep to their own 60 m cells (stations 16 m or more from a neighbour's, and a
field ends where its motion does), so they never meet: the table's blocks column says so for each run.
What is measured is the price of watching: filing every field in the grid and testing it against its
neighbours on every leg, the case of a fleet that flows. Where robots do meet, each block costs its
refinement, as a collision does (``bench_s4.py --scenario``).
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

from bench_s4 import run_variant

ROOT = Path(__file__).resolve().parent.parent


def with_fields(text: str, margin: float) -> str:
    """The generated file with a fleet-wide field, in a ``[traffic]`` table before the first robot."""
    head, sep, rest = text.partition("\n[[robots]]\n")
    return f"{head}\n[traffic]\nfield = {{ margin = {margin!r} }}\n{sep}{rest}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--robots", type=int, default=1000)
    parser.add_argument("--hours", type=float, default=1.0)
    parser.add_argument("--margin", type=float, default=1.5, help="field length at rest, m (default 1.5)")
    args = parser.parse_args()
    sys.path.insert(0, str(ROOT))
    from vcran.io.gen import generate

    base = generate(args.robots, args.hours, 1)
    texts = {"off": base, "on": with_fields(base, args.margin)}
    walls: dict[str, list[float]] = {name: [] for name in texts}
    cpus: dict[str, list[float]] = {name: [] for name in texts}
    facts: dict[str, dict[str, float]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        for name in ("off", "on", "on", "off"):
            robots = run_variant(work, name, texts[name], walls, cpus)["robots"].values()
            facts[name] = {
                "tasks": sum(len(r["completed"]) for r in robots),
                "collisions": sum(r.get("collisions", 0) for r in robots),
                "blocks": sum(r.get("blocks", 0) for r in robots),
                "blocked_time": sum(r.get("blocked_time", 0.0) for r in robots),
            }
    cpu = {name: min(c) for name, c in cpus.items()}
    wall = {name: min(w) for name, w in walls.items()}
    print(f"{args.robots} robots x {args.hours:g} h (vcran gen seed 1), fields of {args.margin:g} m + braking "
          "distance; best of two runs each.\nCPU time (user + system of the child) is the figure to compare on "
          "a shared machine; wall time is shown too.\n")
    print("| fields | CPU s | CPU ratio to off | wall s | wall ratio | tasks | collisions | blocks | blocked s |")
    print("|---|---|---|---|---|---|---|---|---|")
    for name in texts:
        f = facts[name]
        print(f"| {name} | {cpu[name]:.1f} | {cpu[name] / cpu['off']:.3f}x | {wall[name]:.1f} | "
              f"{wall[name] / wall['off']:.3f}x | {f['tasks']:.0f} | {f['collisions']:.0f} | {f['blocks']:.0f} | "
              f"{f['blocked_time']:.1f} |")
    results = ROOT / "benchmarks" / "results"
    results.mkdir(exist_ok=True)
    (results / f"traffic-{int(time.time())}.json").write_text(
        json.dumps({"walls": walls, "cpus": cpus, "facts": facts}, indent=2))


if __name__ == "__main__":
    main()
