"""Fleet-size sweep: ``vcran run`` on generated fleets against two bare-SimPy floors, in one run.

    python benchmarks/bench_fleet.py                          # 1, 10, 100, 1000 robots, one simulated hour
    python benchmarks/bench_fleet.py --sizes 10 100 --hours 0.25
    python benchmarks/bench_fleet.py --sizes 1000 --baseline ../vcran-before   # CPU against another checkout
    python benchmarks/bench_fleet.py --flat 1000              # peak memory at 1, 2 and 4 simulated hours

For each size it runs ``vcran run`` on ``vcran gen --robots N --hours H --seed 1`` in a child process and
reports: the whole process's wall time (the installed ``vcran`` command, interpreter start-up and exit
included, as a user sees it; the median of ``--repeat`` runs, with its CPU time), the in-process time of
the run itself (``run_to``, imports excluded), CPU seconds (user + system) and CPU microseconds per
completed task, peak memory (the child's ``ru_maxrss``), and the output bytes per robot-hour of every file.

Children run as an installed ``vcran`` does on a user's machine: with bytecode cached. The environment
this is developed in sets ``PYTHONDONTWRITEBYTECODE=1``, which would make every child compile each of
vcran's ~50 modules anew (about 80 ms, a sixth of a 10-robot run); so children run without it, with their
bytecode in a cache folder of the benchmark's own (``PYTHONPYCACHEPREFIX``: neither checkout is written
to), after one unmeasured warm-up run per checkout.

Each checkout runs as its venv installed it (a baseline from before issue 30 may have installed the compiled
core of those days; ``VCRAN_PURE=1`` in this command's environment made such a checkout run its pure modules).

Two floors run in the same sweep, also as child processes over the same simulated time:

* ``1 Hz floor``: N processes that each wake once per simulated second (what a naive per-robot periodic
  model schedules);
* ``event floor``: bare SimPy doing only what vcran's design needs: per robot, one timeout per leg and per
  action, with the durations the vcran run actually had (read from its ``motion_finished`` and
  ``action_finished`` events), plus one fleet-wide 1 Hz tick. This is the honest floor for vcran.

``--baseline DIR`` runs the same vcran child with another checkout (its own ``.venv``, e.g. a
``git worktree`` of the commit before a change), so that ratios come from one run on one machine: the
two checkouts' in-process runs alternate (``--pairs``, order swapped every pair), and the CPU ratio shown
is the median of the pairs' ratios. The
machine is usually shared and noisy: compare ratios within one run, never absolute figures across runs.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import statistics
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
    import vcran.runner
    from transports.scripted import ScriptedTransport
    from vcran.io.scenario_file import load
    from pathlib import Path
    begin = time.perf_counter()
    scenario = load(sys.argv[2])
    try:  # what `vcran run` does: nothing reads the frames (a baseline checkout may predate the option)
        transport = ScriptedTransport(scenario.messages(), frames=False)
    except TypeError:
        transport = ScriptedTransport(scenario.messages())
    vcran.runner.run_to(scenario, Path(sys.argv[3]), transport)
    extra = {"in_process": time.perf_counter() - begin}
elif kind == "floor":
    import simpy
    robots, seconds = int(sys.argv[2]), float(sys.argv[3])
    env = simpy.Environment()
    def robot(env):
        while True:
            yield env.timeout(1.0)
    for _ in range(robots):
        env.process(robot(env))
    env.run(until=seconds)
    extra = {}
else:  # event floor: per robot, the run's leg and action durations in sequence; one fleet tick
    import simpy
    plan = json.load(open(sys.argv[2]))
    env = simpy.Environment()
    def robot(env, durations):
        for d in durations:
            yield env.timeout(d)
    def tick(env):
        while True:
            yield env.timeout(1.0)
    for durations in plan["robots"]:
        env.process(robot(env, durations))
    env.process(tick(env))
    env.run(until=plan["seconds"])
    extra = {}
usage = resource.getrusage(resource.RUSAGE_SELF)
extra["cpu"] = usage.ru_utime + usage.ru_stime
extra["maxrss_kib"] = usage.ru_maxrss
print(json.dumps(extra))
"""


#: Where children keep their bytecode (set by main): a folder of the benchmark's, so that no checkout is written.
PYCACHE: Path | None = None


def child_env() -> dict[str, str]:
    """The children's environment: bytecode cached as in a user's install (see the module docstring)."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    env["PYTHONHASHSEED"] = "0"
    if PYCACHE is not None:
        env["PYTHONPYCACHEPREFIX"] = str(PYCACHE)
    return env


def child(python: str, cwd: Path, *args: str) -> tuple[dict, float]:
    start = time.perf_counter()
    out = subprocess.run([python, "-c", CHILD, *args], capture_output=True, text=True, cwd=cwd, env=child_env())
    wall = time.perf_counter() - start
    if out.returncode != 0:
        raise SystemExit(f"child failed: {' '.join(args)}\n{out.stderr}")
    return json.loads(out.stdout.strip().splitlines()[-1]), wall


def whole_process(checkout: Path, scenario: Path, out: Path, repeat: int) -> dict:
    """``vcran run SCENARIO --out DIR --quiet`` with the checkout's installed command, ``repeat`` times after
    one warm-up (which also caches the bytecode): the median wall and CPU seconds of the whole process."""
    command = [str(checkout / ".venv" / "bin" / "vcran"), "run", str(scenario), "--out", str(out), "--quiet"]
    walls, cpus = [], []
    for i in range(repeat + 1):
        shutil.rmtree(out, ignore_errors=True)
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        start = time.perf_counter()
        done = subprocess.run(command, capture_output=True, text=True, cwd=checkout, env=child_env())
        wall = time.perf_counter() - start
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        if done.returncode != 0:
            raise SystemExit(f"vcran run failed: {' '.join(command)}\n{done.stderr}")
        if i:  # the first run is the warm-up
            walls.append(wall)
            cpus.append(after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime)
    return {"wall": statistics.median(walls), "cpu": statistics.median(cpus), "runs": repeat}


def _events(folder: Path) -> list[dict]:
    from vcran.io.trace import event_records, events_beside, trace_in

    try:
        return list(event_records(events_beside(trace_in(folder))))
    except ValueError:  # a checkout older than the reader
        return [json.loads(line) for line in (folder / "events.jsonl").read_text().splitlines()]


def _plan(events: list[dict], robots: int, seconds: float) -> dict:
    """Per robot, the intervals between its leg/action starts and ends, as the event floor replays them."""
    last: dict[str, float] = {}
    durations: dict[str, list[float]] = {}
    for e in events:
        if e["event"] in ("motion_finished", "action_finished"):
            rid = e["robot"]
            durations.setdefault(rid, []).append(max(e["t"] - last.get(rid, 0.0), 0.0))
            last[rid] = e["t"]
    rows = list(durations.values()) + [[] for _ in range(robots - len(durations))]
    return {"robots": rows, "seconds": seconds}


def vcran_run(python: str, cwd: Path, scenario: Path, out: Path, robots: int, hours: float) -> dict:
    info, wall = child(python, cwd, "vcran", str(scenario), str(out))
    summary = json.loads((out / "summary.json").read_text())
    tasks = sum(len(r["completed"]) for r in summary["robots"].values())
    robot_hours = robots * summary["sim_time"] / 3600
    files = {p.name: p.stat().st_size / robot_hours for p in sorted(out.iterdir()) if p.is_file()}
    return {"wall": wall, "in_process": info["in_process"], "cpu": info["cpu"], "tasks": tasks,
            "cpu_per_task_us": 1e6 * info["cpu"] / max(tasks, 1), "maxrss_mib": info["maxrss_kib"] / 1024,
            "bytes_per_robot_hour": files, "total_per_robot_hour": sum(files.values()),
            "sim_time": summary["sim_time"]}


def bench(robots: int, hours: float, work: Path, baseline: Path | None, repeat: int, pairs: int) -> dict:
    from vcran.io.gen import generate

    scenario = work / f"fleet-{robots}-{hours}.toml"
    scenario.write_text(generate(robots, hours, 1))
    row: dict = {"robots": robots, "hours": hours}
    # the whole process first: its warm-up run caches the bytecode the in-process child then reads
    whole = whole_process(ROOT, scenario, work / f"cli-{robots}-{hours}", repeat)
    if baseline is not None:
        base_whole = whole_process(baseline, scenario, work / f"base-cli-{robots}-{hours}", repeat)
        row.update(paired(robots, hours, scenario, work, baseline, pairs))
        row["baseline"]["whole"] = base_whole
    else:
        row["vcran"] = vcran_run(sys.executable, ROOT, scenario, work / f"out-{robots}-{hours}", robots, hours)
    row["vcran"]["whole"] = whole
    sim = row["vcran"]["sim_time"]
    floor, floor_wall = child(sys.executable, ROOT, "floor", str(robots), str(sim))
    plan = work / f"plan-{robots}-{hours}.json"
    plan.write_text(json.dumps(_plan(_events(work / f"out-{robots}-{hours}"), robots, sim)))
    event_floor, _ = child(sys.executable, ROOT, "event", str(plan))
    row["floor_cpu"], row["event_floor_cpu"] = floor["cpu"], event_floor["cpu"]
    return row


def paired(robots: int, hours: float, scenario: Path, work: Path, baseline: Path, pairs: int) -> dict:
    """The in-process run of this checkout and of the baseline, ``pairs`` times, back to back, the order
    swapped every pair: on a shared machine the load drifts over minutes, and a ratio of two runs made
    far apart measures the drift too (a baseline run first under load once came out 40% slower than in
    quiet). Each checkout's row is its run of median CPU; ``cpu_ratios`` holds every pair's ratio."""
    checkouts = {"vcran": (sys.executable, ROOT, work / f"out-{robots}-{hours}"),
                 "baseline": (str(baseline / ".venv" / "bin" / "python"), baseline, work / f"base-{robots}-{hours}")}
    runs: dict[str, list[dict]] = {"vcran": [], "baseline": []}
    for k in range(pairs):
        for name in (("baseline", "vcran") if k % 2 == 0 else ("vcran", "baseline")):
            python, cwd, out = checkouts[name]
            shutil.rmtree(out, ignore_errors=True)
            runs[name].append(vcran_run(python, cwd, scenario, out, robots, hours))
    ratios = [v["cpu"] / b["cpu"] for v, b in zip(runs["vcran"], runs["baseline"])]
    median = {name: sorted(r, key=lambda v: v["cpu"])[(len(r) - 1) // 2] for name, r in runs.items()}
    return {**median, "cpu_ratios": ratios}


def table(rows: list[dict]) -> str:
    out = ["| robots | sim h | tasks | CPU s | CPU µs/task | in-process s | whole process s (CPU s) | peak MiB "
           "| output kB/robot-h | 1 Hz floor CPU s | event floor CPU s | vcran / event floor |",
           "|" + "|".join(["---"] * 12) + "|"]
    for r in rows:
        for name in ("baseline", "vcran"):
            v = r.get(name)
            if v is None:
                continue
            label = f"{r['robots']}" + (" (baseline)" if name == "baseline" else "")
            whole = f"{v['whole']['wall']:.3f} ({v['whole']['cpu']:.3f})"
            out.append(
                f"| {label} | {r['hours']:g} | {v['tasks']} | {v['cpu']:.2f} | {v['cpu_per_task_us']:.0f} | "
                f"{v['in_process']:.3f} | {whole} | {v['maxrss_mib']:.0f} | {v['total_per_robot_hour'] / 1000:.1f} | "
                f"{r['floor_cpu']:.2f} | {r['event_floor_cpu']:.2f} | {v['cpu'] / max(r['event_floor_cpu'], 1e-9):.1f}x |")
    for r in rows:
        if "baseline" in r:
            b, v = r["baseline"], r["vcran"]
            pairs = ", ".join(f"{x:.2f}" for x in r["cpu_ratios"])
            out.append(f"\n{r['robots']} robots: CPU {statistics.median(r['cpu_ratios']):.2f}x of the baseline "
                       f"(median of {len(r['cpu_ratios'])} interleaved pairs: {pairs}), "
                       f"in-process {v['in_process'] / b['in_process']:.2f}x, "
                       f"whole process {v['whole']['wall'] / b['whole']['wall']:.2f}x, "
                       f"output {v['total_per_robot_hour'] / b['total_per_robot_hour']:.3f}x")
    files = "\n".join(
        f"- {r['robots']} robots, {name}: " + ", ".join(f"{f} {n / 1000:.1f} kB" for f, n in r[name]["bytes_per_robot_hour"].items())
        for r in rows for name in ("baseline", "vcran") if name in r)
    return "\n".join(out) + "\n\nbytes per robot-hour per file:\n" + files


def flat(robots: int, work: Path) -> str:
    from vcran.io.gen import generate

    lines = ["| robots | sim h | peak MiB | CPU s |", "|---|---|---|---|"]
    base = None
    for hours in (1.0, 2.0, 4.0):
        scenario = work / f"flat-{robots}-{hours}.toml"
        scenario.write_text(generate(robots, hours, 1))
        v = vcran_run(sys.executable, ROOT, scenario, work / f"flat-out-{robots}-{hours}", robots, hours)
        base = base or v["maxrss_mib"]
        lines.append(f"| {robots} | {hours:g} | {v['maxrss_mib']:.0f} ({v['maxrss_mib'] / base:.2f}x of 1 h) | {v['cpu']:.1f} |")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--sizes", type=int, nargs="+", default=[1, 10, 100, 1000])
    parser.add_argument("--hours", type=float, default=1.0)
    parser.add_argument("--baseline", type=Path, help="another checkout (with its .venv) to run the same fleets")
    parser.add_argument("--flat", type=int, metavar="ROBOTS", help="peak memory at 1, 2 and 4 h for this fleet size")
    parser.add_argument("--keep", type=Path, help="keep outputs in this folder")
    parser.add_argument("--repeat", type=int, default=5, help="whole-process runs per size (the median is shown)")
    parser.add_argument("--pairs", type=int, default=3,
                        help="with --baseline: in-process runs of both checkouts, interleaved (median shown)")
    args = parser.parse_args()
    sys.path.insert(0, str(ROOT))
    global PYCACHE
    with tempfile.TemporaryDirectory() as tmp:
        work = args.keep or Path(tmp)
        work.mkdir(parents=True, exist_ok=True)
        PYCACHE = Path(tmp) / "pycache"
        if args.flat:
            print(flat(args.flat, work))
            return
        rows = [bench(n, args.hours, work, args.baseline, args.repeat, args.pairs) for n in args.sizes]
    print(table(rows))
    results = ROOT / "benchmarks" / "results"
    results.mkdir(exist_ok=True)
    (results / f"fleet-{int(time.time())}.json").write_text(json.dumps(rows, indent=2))


if __name__ == "__main__":
    main()
