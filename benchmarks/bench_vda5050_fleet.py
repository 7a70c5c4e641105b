"""A 100-vehicle VDA 5050 hour against the OPIL equivalent (issue 31's "Must show", docs/contract.md §11).

    python benchmarks/bench_vda5050_fleet.py                  # 100 robots, one simulated hour, 3 rounds
    python benchmarks/bench_vda5050_fleet.py --robots 20 --hours 0.25 --rounds 2
    python benchmarks/bench_vda5050_fleet.py --only scripted  # or: loop
    python benchmarks/bench_vda5050_fleet.py --instructions --robots 20 --hours 0.25 --only scripted --sinks folder

**Scripted.** The OPIL side is ``vcran gen --robots N --hours H --seed 1`` (what ``bench_fleet.py`` runs):
each robot a cycle of two tasks, a pickup (two motions, ``load``) and a drop (two motions, ``unload``),
every ``period`` seconds. The VDA 5050 side is the same file with ``protocol = "vda5050"``, each robot a
manufacturer and serial number, and its cycle written out as the orders a master would send: per
repetition an order to the pickup (the vehicle's node, the ``via`` point, the pickup pose with a HARD
``pick`` at the station) at the cycle's time, and one to the drop (from the pickup pose, ``via``, the drop
pose with a ``drop``) half a second after the first has ended (a vehicle refuses a new orderId while it
works on one, §6.6.2; the end is computed with the same kinematics as the cycle's period). The orders take
the tasks' names (``r1_0_1``, ``r1_0_2`` ...), so the two summaries compare name by name. On both sides each
cycle's ``until`` is cut to the run's end minus one period, so that every cycle begun is finished within
the run (the OPIL drop starts half a second sooner: the last cycle would otherwise end differently). The
same legs, the same actions, the same stations: the benchmark checks that both complete the same tasks /
orders, move the same parts and drive the same distance, and stops if not.

**Closed loop.** The warehouse (``scenarios/warehouse.toml``) grown to N robots: ``N / 10`` copies of its
floor stacked 30 m apart, each with its lines, docks and ten robots, one job stream over all of them at ten
times the rate per copy, collision detection off on both sides (:data:`COLLISIONS`). OPIL's side runs it
with its dispatcher (``vcran.managers:Dispatcher``), VDA 5050's with ``protocol = "vda5050"`` and the
reference master (``vcran.managers.vda5050:MasterControl``). The two managers are different programs, so
the work is compared and shown (jobs done, tasks / orders, parts, distance, simulated time) rather than
required equal, and the CPU per job done is given beside the ratio. Skipped, saying so, where the
simulation cannot run a VDA 5050 master in the loop (before issue 31's closed loop).

Each run is a child process (its scenario built there and both protocols' modules imported, outside the
timed part) that times :func:`vcran.api.run` alone (what ``vcran.simulate`` and ``vcran run`` call:
:func:`vcran.runner.execute` with the scripted transport or the closed loop), with the same sinks on both
sides: in memory (``vcran.simulate`` without ``out``) or a run folder (``vcran run``'s), ``--sinks``. The two
sides alternate, the order swapped every round, and each side's least CPU time of ``--rounds`` counts (user +
system of the child's run: on a shared machine less disturbed than wall time, also shown). The figure is the
ratio VDA 5050 / OPIL within this one invocation; issue 31 asks at most 1.5x. Events are the lines of the
run's event log, per CPU second of its run. The figures and what was done about them: benchmarks/README.md.

``--instructions`` counts instead of timing: each side's run once under valgrind's callgrind, counting only
inside the run (the child calls it through ``functools.reduce``, the C function callgrind is told to count
in), ``PYTHONHASHSEED=0``. The count does not move with the machine's load (the same code twice agrees to about
0.1%), so it shows what a change did where CPU seconds on a shared machine cannot; it runs some 50 times
slower, hence a smaller fleet, whose ratio is above the hour's (fixed costs weigh more).
"""

from __future__ import annotations

import argparse
import copy
import functools
import importlib
import json
import math
import os
import platform
import re
import shutil
import subprocess
import sys
import tempfile
import time
import tomllib
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
#: Seconds between a pickup order's computed end and the drop order sent after it.
GAP = 0.5
#: Seconds between two stacked copies of the warehouse's floor (lines and docks span y = -10 .. 10).
FLOOR = 30.0
#: The closed loop's collision detection (docs/contract.md §4): off, since 100 robots crossing at shared stations
#: make its refinement most of both runs (``bench_s4.py --scenario`` measures that), hiding the protocols' cost.
COLLISIONS = "off"
#: Set in a child run under callgrind (``--instructions``): the run is called through ``functools.reduce``, the C
#: function callgrind is told to count inside (``--toggle-collect``), so that imports and the scenario's building
#: are left out.
COUNTED = "VCRAN_BENCH_COUNTED"


# --- the scripted pair ------------------------------------------------------------------------------------------

def scripted_pair(robots: int, hours: float) -> tuple[dict[str, Any], dict[str, Any]]:
    """The generated fleet as OPIL and as VDA 5050 scenario documents (as tomllib reads a file)."""
    from vcran.io.gen import generate

    opil = tomllib.loads(generate(robots, hours, 1))
    duration = opil["simulation"]["duration"]
    for cycle in opil["script"]:
        cycle["until"] = duration - cycle["every"]
    vda = copy.deepcopy(opil)
    vda["simulation"]["protocol"] = "vda5050"
    for n, robot in enumerate(vda["robots"], start=1):
        robot["manufacturer"], robot["serial_number"] = "vcran", f"{n:04d}"
    poses = {r["id"]: tuple(r["pose"]) for r in vda["robots"]}
    script = [entry for cycle in vda["script"] for entry in _orders(cycle, poses[cycle["robot"]])]
    vda["script"] = sorted(script, key=lambda entry: entry["t"])  # stable: at equal times, robot order
    return opil, vda


def _orders(cycle: dict[str, Any], pose: tuple[float, float, float]) -> list[dict[str, Any]]:
    """One OPIL cycle's repetitions as VDA 5050 orders, each sent when the vehicle is free for it."""
    from vcran.io.gen import DURATIONS

    (via, at_pick), (_, at_drop) = cycle["tasks"][0]["path"], cycle["tasks"][1]["path"]
    robot, number = cycle["robot"], cycle["robot"].rsplit("_", 1)[1]
    out = []
    k = 0
    while (t := cycle["t"] + k * cycle["every"]) < cycle["until"]:
        prefix = f"{cycle['prefix']}_{k}"
        pick = _order(f"{prefix}_1", [("start" if k == 0 else "drop", pose[:2]), ("via", via), ("pick", at_pick)],
                      "pick", f"pick_{number}")
        driven, pose = _drive(pose, [via, at_pick])
        drop = _order(f"{prefix}_2", [("pick", at_pick[:2]), ("via", via), ("drop", at_drop)], "drop", f"drop_{number}")
        out += [{"t": t, "robot": robot, "kind": "order", "message": pick},
                {"t": t + driven + DURATIONS["load"] + GAP, "robot": robot, "kind": "order", "message": drop}]
        _, pose = _drive(pose, [via, at_drop])
        k += 1
    return out


def _drive(pose: tuple[float, float, float], points: list[list[float]]) -> tuple[float, tuple[float, float, float]]:
    """How long the body takes along ``points`` from ``pose`` (the generator's kinematics), and where it ends."""
    from vcran.core.motion import Leg, Limits
    from vcran.io.gen import ACCEL, SPEED, TURN

    total = 0.0
    for n, p in enumerate(points):
        goal = p[2] if n == len(points) - 1 and len(p) == 3 else None
        leg = Leg(0.0, *pose, p[0], p[1], goal, Limits(SPEED, ACCEL, ACCEL, TURN))
        total += leg.duration
        pose = (leg.x1, leg.y1, leg.end_theta)
    return total, pose


def _order(order_id: str, points: list[tuple[str, Any]], action: str, station: str) -> dict[str, Any]:
    """An order through ``points`` (node id, [x, y(, theta)]) with ``action`` at ``station`` on the last node."""
    nodes, edges = [], []
    for i, (name, p) in enumerate(points):
        position = {"x": p[0], "y": p[1], "mapId": "map", **({"theta": p[2]} if len(p) == 3 else {})}
        actions = [{"actionType": action, "actionId": f"{order_id}_{action}", "blockingType": "HARD",
                    "actionParameters": [{"key": "stationName", "value": station}]}] if i == len(points) - 1 else []
        nodes.append({"nodeId": name, "sequenceId": 2 * i, "released": True, "nodePosition": position,
                      "actions": actions})
        if i:
            before = points[i - 1][0]
            edges.append({"edgeId": f"{before}-{name}", "sequenceId": 2 * i - 1, "released": True,
                          "startNodeId": before, "endNodeId": name, "actions": []})
    return {"orderId": order_id, "orderUpdateId": 0, "nodes": nodes, "edges": edges}


# --- the closed-loop pair ---------------------------------------------------------------------------------------

def loop_pair(robots: int, hours: float) -> tuple[dict[str, Any], dict[str, Any]]:
    """The warehouse grown to ``robots`` (a multiple of ten), as OPIL with its dispatcher and as VDA 5050
    with MasterControl."""
    if robots % 10:
        raise SystemExit(f"--robots {robots}: the closed loop grows the 10-robot warehouse, give a multiple of 10")
    base = tomllib.loads((ROOT / "scenarios" / "warehouse.toml").read_text())
    copies = robots // 10
    opil = copy.deepcopy(base)
    opil["simulation"]["duration"] = hours * 3600.0
    opil["simulation"]["collisions"] = COLLISIONS
    stream = opil["job_stream"]
    stream["rate"] *= copies
    stream["until"] = min(stream["until"], hours * 3600.0 - 300.0)
    opil["robots"], opil["stations"] = [], []
    pickup, dropoff = [], {}
    for c in range(copies):
        def moved(name: str) -> str:
            return name if c == 0 else f"{name}_{c}"  # noqa: B023 (used at once)
        for robot in base["robots"]:
            n = int(robot["id"].rsplit("_", 1)[1]) + 10 * c
            x, y, theta = robot["pose"]
            opil["robots"].append({**robot, "id": f"robot_{n}", "pose": [x, y + c * FLOOR, theta]})
        for station in base["stations"]:
            x, y = station["position"]
            shifted = {**station, "id": moved(station["id"]), "position": [x, y + c * FLOOR]}
            if "dock" in station:
                dx, dy, dtheta = station["dock"]
                shifted["dock"] = [dx, dy + c * FLOOR, dtheta]
            opil["stations"].append(shifted)
        pickup += [moved(s) for s in base["job_stream"]["pickup"]]
        dropoff.update({moved(s): w for s, w in base["job_stream"]["dropoff"].items()})
    stream["pickup"], stream["dropoff"] = pickup, dropoff
    vda = copy.deepcopy(opil)
    vda["simulation"]["protocol"] = "vda5050"
    vda["simulation"]["name"] = f"vda5050-{opil['simulation']['name']}"
    vda["manager"]["class"] = "vcran.managers.vda5050:MasterControl"
    vda["link"].pop("inbound", None)  # Orion's notification mode: OPIL's link only
    for n, robot in enumerate(vda["robots"], start=1):
        robot["manufacturer"], robot["serial_number"] = "vcran", f"{n:04d}"
    return opil, vda


def loop_runs() -> str | None:
    """None if the simulation runs a VDA 5050 master in the closed loop (the bundled warehouse), else why not."""
    import vcran

    try:
        vcran.simulate("vda5050-warehouse")
    except Exception as exc:  # noqa: BLE001 (any refusal means: not yet)
        return f"{type(exc).__name__}: {str(exc).splitlines()[0]}"
    return None


# --- one run, in a child ----------------------------------------------------------------------------------------

def child(case: str, side: str, sinks: str, robots: int, hours: float, out: str) -> dict[str, Any]:
    """Build the scenario, then time its run alone (:func:`vcran.api.run`, what ``vcran.simulate`` and
    ``vcran run`` call: the scripted transport or the closed loop); the run's figures and the work it did."""
    import numpy  # noqa: F401 (an in-memory run's frames import it: once per process, not the run's work)

    import vcran.api
    from vcran.io.scenario_file import parse
    from vcran.sim import protocols

    opil, vda = (scripted_pair if case == "scripted" else loop_pair)(robots, hours)
    scenario = parse(opil if side == "opil" else vda, f"<{case} {side}>")
    for name in protocols.PROTOCOLS:  # each protocol's modules, imported by its first run: not the run's work
        protocols.glue(name)
    if case == "loop":
        for module in ("vcran.managers", "vcran.managers.vda5050", "vcran.sim.opil.loop", "vcran.sim.vda5050.loop"):
            importlib.import_module(module)
    wall, cpu = time.perf_counter(), time.process_time()
    if os.environ.get(COUNTED):  # under callgrind, which counts inside functools.reduce alone (--instructions)
        result = functools.reduce(lambda _, __: vcran.api.run(scenario, out=out if sinks == "folder" else None),
                                  (None, None))
    else:
        result = vcran.api.run(scenario, out=out if sinks == "folder" else None)
    cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
    summary = result.summary
    done = summary["robots"]
    return {
        "cpu": cpu, "wall": wall, "events": result.event_count, "sim_time": summary["sim_time"],
        "completed": {r: s["completed"] for r, s in done.items()},
        "distance": {r: s["distance"] for r, s in done.items()},
        "parts": sum(s["parts_moved"] for s in done.values()),
        "cancelled": sum(len(s["cancelled"]) for s in done.values()),
        "errors": summary["errors"],
        "jobs": summary.get("jobs"),
    }


# --- the parent ---------------------------------------------------------------------------------------------------

def run_child(case: str, side: str, sinks: str, robots: int, hours: float, work: Path, n: int) -> dict[str, Any]:
    out = work / f"{case}-{side}-{n}"
    env = {**os.environ, "PYTHONHASHSEED": "0"}
    done = subprocess.run([sys.executable, __file__, "--child", case, side, sinks, str(robots), str(hours), str(out)],
                          capture_output=True, text=True, cwd=ROOT, env=env)
    if done.returncode != 0:
        raise SystemExit(f"{case} {side} failed:\n{done.stderr}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def run_counted(case: str, side: str, sinks: str, robots: int, hours: float, work: Path) -> tuple[int, dict[str, Any]]:
    """The instructions the child's run executes (callgrind's count inside ``functools.reduce``), and its figures."""
    out = work / f"{case}-{side}-counted"
    env = {**os.environ, "PYTHONHASHSEED": "0", COUNTED: "1"}
    command = ["valgrind", "--tool=callgrind", "--collect-atstart=no", "--toggle-collect=functools_reduce",
               "--callgrind-out-file=/dev/null", sys.executable, __file__, "--child", case, side, sinks, str(robots),
               str(hours), str(out)]
    done = subprocess.run(command, capture_output=True, text=True, cwd=ROOT, env=env)
    if done.returncode != 0:
        raise SystemExit(f"{case} {side} under callgrind failed:\n{done.stderr[-2000:]}")
    found = re.search(r"Collected\s*:\s*(\d+)", done.stderr)
    if found is None or int(found.group(1)) == 0:
        raise SystemExit("callgrind counted nothing inside functools_reduce: this Python's binary has no symbol of "
                         "that name (stripped?); --instructions needs one that has")
    return int(found.group(1)), json.loads(done.stdout.strip().splitlines()[-1])


def count(case: str, sinks: str, robots: int, hours: float, work: Path) -> None:
    """``--instructions``: each side once under callgrind; the counts do not depend on the machine's load."""
    counted = {side: run_counted(case, side, sinks, robots, hours, work) for side in ("opil", "vda5050")}
    print(f"\n## {case}, {robots} robots x {hours:g} h, {sinks} sinks; instructions inside vcran.api.run (callgrind)\n")
    if case == "scripted" and (problems := same_work(counted["opil"][1], counted["vda5050"][1])):
        raise SystemExit("the two runs did not do the same work: " + "; ".join(problems))
    print("| side | instructions | ratio to OPIL |\n|---|---|---|")
    base = counted["opil"][0]
    for side, (n, _) in counted.items():
        print(f"| {side} | {n:,} | {n / base:.2f}x |")


def same_work(opil: dict[str, Any], vda: dict[str, Any]) -> list[str]:
    """What differs between the two runs' work (empty: the same tasks/orders, parts and distance)."""
    problems = []
    if opil["completed"] != vda["completed"]:
        robot = next(r for r in opil["completed"] if opil["completed"][r] != vda["completed"].get(r))
        problems.append(f"{robot} completed {opil['completed'][robot][:4]}... (OPIL) and "
                        f"{vda['completed'].get(robot, [])[:4]}... (VDA 5050)")
    for key in ("parts", "cancelled", "errors"):
        if opil[key] != vda[key]:
            problems.append(f"{key}: {opil[key]} (OPIL), {vda[key]} (VDA 5050)")
    for robot, d in opil["distance"].items():
        if not math.isclose(d, vda["distance"][robot], rel_tol=1e-9, abs_tol=1e-6):
            problems.append(f"{robot} drove {d} m (OPIL), {vda['distance'][robot]} m (VDA 5050)")
            break
    return problems


def compare(case: str, sinks: str, robots: int, hours: float, rounds: int, work: Path) -> None:
    runs: dict[str, list[dict[str, Any]]] = {"opil": [], "vda5050": []}
    for n in range(rounds):
        for side in (("opil", "vda5050") if n % 2 == 0 else ("vda5050", "opil")):
            runs[side].append(run_child(case, side, sinks, robots, hours, work, n))
    best = {side: min(rs, key=lambda r: r["cpu"]) for side, rs in runs.items()}
    o, v = best["opil"], best["vda5050"]
    tasks = {side: sum(len(c) for c in b["completed"].values()) for side, b in best.items()}
    distance = {side: sum(b["distance"].values()) for side, b in best.items()}
    print(f"\n## {case}, {robots} robots x {hours:g} h, {sinks} sinks; least CPU of {rounds} interleaved rounds\n")
    if case == "scripted":
        problems = same_work(o, v)
        if problems:
            raise SystemExit("the two runs did not do the same work: " + "; ".join(problems))
        print(f"Same work on both sides: {tasks['opil']:,} tasks / orders completed (name by name), "
              f"{o['parts']:,} parts moved, {distance['opil']:,.1f} m driven, {o['cancelled']} cancelled, "
              f"{o['errors']} errors.\n")
        unit = "task"
    else:
        work = {side: (f"{(b['jobs'] or {}).get('completed')} of {(b['jobs'] or {}).get('arrived')} jobs done, "
                       f"{tasks[side]:,} tasks / orders completed, {b['parts']:,} parts moved, "
                       f"{distance[side]:,.1f} m driven") for side, b in best.items()}
        ended = f"the run ended at {o['sim_time']:,.1f} s simulated (OPIL) and {v['sim_time']:,.1f} s (VDA 5050)"
        if work["opil"] == work["vda5050"]:
            print(f"Same work on both sides: {work['opil']}; {ended}.\n")
        else:
            print("The two managers' work:\n\n" + "".join(f"- {side}: {w}\n" for side, w in work.items())
                  + f"\n({ended})\n")
        unit = "job"
    print(f"| side | CPU s | CPU ratio to OPIL | wall s | events | events per CPU s | CPU ms per {unit} | rounds' CPU s |")
    print("|---|---|---|---|---|---|---|---|")
    for side, b in best.items():
        done = tasks[side] if case == "scripted" else max((b["jobs"] or {}).get("completed", 0), 1)
        print(f"| {side} | {b['cpu']:.2f} | {b['cpu'] / o['cpu']:.2f}x | {b['wall']:.2f} | {b['events']:,} | "
              f"{b['events'] / b['cpu']:,.0f} | {1000 * b['cpu'] / done:.3f} | "
              f"{', '.join(format(r['cpu'], '.2f') for r in runs[side])} |")
    print(f"\nVDA 5050 / OPIL: **{v['cpu'] / o['cpu']:.2f}x** CPU (issue 31: at most 1.5x)")


def main() -> None:
    if len(sys.argv) > 1 and sys.argv[1] == "--child":
        sys.path.insert(0, str(ROOT))
        case, side, sinks, robots, hours, out = sys.argv[2:8]
        print(json.dumps(child(case, side, sinks, int(robots), float(hours), out)))
        return
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--robots", type=int, default=100)
    parser.add_argument("--hours", type=float, default=1.0)
    parser.add_argument("--rounds", type=int, default=3, help="interleaved rounds; each side's least CPU counts")
    parser.add_argument("--sinks", choices=("memory", "folder"), nargs="+", default=["memory", "folder"],
                        help="in memory (vcran.simulate) and/or a run folder (vcran run); default both")
    parser.add_argument("--only", choices=("scripted", "loop"), help="one case (default both)")
    parser.add_argument("--instructions", action="store_true",
                        help="count each side's instructions once under valgrind's callgrind instead of timing "
                             "rounds: the same on a loaded machine, about 50 times slower (use a smaller fleet)")
    args = parser.parse_args()
    if args.instructions and shutil.which("valgrind") is None:
        parser.error("--instructions needs valgrind on PATH (Debian: apt-get install valgrind)")
    sys.path.insert(0, str(ROOT))
    print(f"# VDA 5050 against OPIL: Python {platform.python_version()} on {platform.machine()}, "
          f"{os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.1f}")
    cases = [args.only] if args.only else ["scripted", "loop"]
    with tempfile.TemporaryDirectory(prefix="vcran-bench-vda-") as tmp:
        for case in cases:
            if case == "loop" and (why := loop_runs()) is not None:
                print(f"\n## loop: skipped, the simulation does not run a VDA 5050 master yet ({why})")
                continue
            for sinks in args.sinks:
                if args.instructions:
                    count(case, sinks, args.robots, args.hours, Path(tmp))
                else:
                    compare(case, sinks, args.robots, args.hours, args.rounds, Path(tmp))
    print(f"\n(load average at the end {os.getloadavg()[0]:.1f})")


if __name__ == "__main__":
    main()
