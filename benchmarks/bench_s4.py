"""What SPEC §4 costs: a generated fleet with collision detection on vs off, and with batteries vs without.

    python benchmarks/bench_s4.py                          # 1000 robots, one simulated hour
    python benchmarks/bench_s4.py --robots 100 --hours 0.25

The fleet is ``vcran gen --robots N --hours H --seed 1``. Three variants of it run as ``vcran run`` child
processes: *base* (``collisions = "off"``, no battery), *collisions* (``collisions = "report"``, the
default) and *battery* (``collisions = "off"``, every robot with a battery that lasts the run: 100 Ah,
0.01 Ah/m, 0.001 Ah/s idle, 0.002 Ah/s per action second, so ``battery`` goes out on each percent step).
Each variant runs twice, in the order base, collisions, battery, battery, collisions, base, and its
faster wall time counts, which evens out a shared machine's drift; the ratios to *base* are from this one
invocation. Targets (issue 11): collisions at most 1.3x, battery at most 1.05x.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

BATTERY = """
[robots.battery]
capacity = 100.0
per_metre = 0.01
per_idle_second = 0.001
per_action_second = 0.002
"""


def variants(text: str) -> dict[str, str]:
    off = re.sub(r"^\[simulation\]\n", '[simulation]\ncollisions = "off"\n', text, count=1, flags=re.M)
    with_battery = re.sub(r"^(max_angular_velocity = .*\n)", lambda m: m.group(1) + BATTERY, off, flags=re.M)
    return {"base": off, "collisions": text, "battery": with_battery}


def run(scenario: Path, out: Path) -> float:
    start = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "vcran", "run", str(scenario), "--out", str(out), "--quiet"],
                          capture_output=True, text=True, cwd=ROOT, env={**os.environ, "PYTHONHASHSEED": "0"})
    wall = time.perf_counter() - start
    if done.returncode != 0:
        raise SystemExit(f"vcran run {scenario} failed:\n{done.stderr}")
    return wall


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--robots", type=int, default=1000)
    parser.add_argument("--hours", type=float, default=1.0)
    args = parser.parse_args()
    sys.path.insert(0, str(ROOT))
    from vcran.io.gen import generate

    texts = variants(generate(args.robots, args.hours, 1))
    walls: dict[str, list[float]] = {name: [] for name in texts}
    facts: dict[str, dict[str, int]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        for name in ("base", "collisions", "battery", "battery", "collisions", "base"):
            scenario = work / f"{name}.toml"
            scenario.write_text(texts[name])
            out = work / f"out-{name}"
            walls[name].append(run(scenario, out))
            summary = json.loads((out / "summary.json").read_text())
            with (out / "trace.jsonl").open("rb") as f:
                batteries = sum(b'"attr":"battery"' in line for line in f)
            facts[name] = {
                "tasks": sum(len(r["completed"]) for r in summary["robots"].values()),
                "collisions": sum(r.get("collisions", 0) for r in summary["robots"].values()),
                "battery_records": batteries,
            }
    best = {name: min(w) for name, w in walls.items()}
    print(f"{args.robots} robots x {args.hours:g} h (vcran gen seed 1); best of two runs each\n")
    print("| variant | wall s (best) | wall s (other) | ratio to base | tasks | collisions | battery records |")
    print("|---|---|---|---|---|---|---|")
    for name, w in walls.items():
        f = facts[name]
        print(f"| {name} | {min(w):.1f} | {max(w):.1f} | {best[name] / best['base']:.3f}x | {f['tasks']} | "
              f"{f['collisions']} | {f['battery_records']} |")
    results = ROOT / "benchmarks" / "results"
    results.mkdir(exist_ok=True)
    (results / f"s4-{int(time.time())}.json").write_text(json.dumps({"walls": walls, "facts": facts}, indent=2))


if __name__ == "__main__":
    main()
