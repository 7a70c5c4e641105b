"""Generated fleets (``vcran gen``): N robots kept busy for H hours, as a scenario file.

Each robot works its own cell of a grid: a pickup station that produces one part per cycle and a drop
station. Its script is one ``cycle`` entry: a pickup task (two motions, load) and a drop task (two motions,
unload), repeated every ``period`` seconds. The period is the cycle's exact duration, computed with the
same kinematics the AGV uses, plus one second, so the robot is busy but its queue never grows. Station
positions are jittered with ``random.Random(seed)`` (stable across Python versions), so seeds differ and
one seed always prints the same file.
"""

from __future__ import annotations

import math
import random

from vcran.core.motion import Leg, Limits

CELL = 60.0
SPEED, ACCEL, TURN = 1.5, 0.75, 1.5
DURATIONS = {"dummy": 1.0, "load": 5.0, "unload": 5.0}
SLACK = 1.0


def generate(robots: int, hours: float, seed: int) -> str:
    if robots < 1:
        raise ValueError(f"--robots must be at least 1, got {robots}")
    if not (hours > 0 and math.isfinite(hours)):
        raise ValueError(f"--hours must be a finite number above 0, got {hours}")
    duration = hours * 3600.0
    latest = _start(min(robots, 50) - 1)
    if duration < latest:  # the loader refuses a cycle that starts after the run's end
        raise ValueError(f"--hours {hours:g} is {duration:g} s of simulated time; the fleet's first cycles start "
                         f"until {latest:g} s: give at least that")
    rng = random.Random(seed)
    columns = math.ceil(math.sqrt(robots))
    out = [
        f"# vcran gen --robots {robots} --hours {hours:g} --seed {seed}",
        "[simulation]",
        f'name = "fleet-{robots}x{hours:g}h-s{seed}"',
        f"seed = {seed}",
        f"duration = {duration!r}",
        "task_timeout = 30.0",
        "",
        "[simulation.action_durations]",
        *(f"{k} = {v!r}" for k, v in DURATIONS.items()),
    ]
    stations: list[str] = []
    script: list[str] = []
    for i in range(robots):
        cx, cy = (i % columns) * CELL, (i // columns) * CELL
        home = (cx, cy, 0.0)
        pick = (cx + 22 + rng.uniform(-3, 3), cy + 20 + rng.uniform(-3, 3))
        drop = (cx - 22 + rng.uniform(-3, 3), cy + 20 + rng.uniform(-3, 3))
        via = (cx + rng.uniform(-2, 2), cy + 8.0)
        at_pick = (pick[0], pick[1] - 1.0, math.pi / 2)
        at_drop = (drop[0], drop[1] - 1.0, math.pi / 2)
        period = _period(home, via, at_pick, at_drop)
        rid = f"robot_{i + 1}"
        out += ["", "[[robots]]", f'id = "{rid}"', f"pose = {_list(home)}", f"max_velocity = {SPEED!r}",
                f"max_acceleration = {ACCEL!r}", f"max_angular_velocity = {TURN!r}"]
        stations += ["", "[[stations]]", f'id = "pick_{i + 1}"', f"position = {_list(pick)}", "reach = 1.2",
                     "parts = 1", "capacity = 2", f"produce_every = {period!r}"]
        stations += ["", "[[stations]]", f'id = "drop_{i + 1}"', f"position = {_list(drop)}", "reach = 1.2"]
        start = _start(i % 50)
        script += [
            "", "[[script]]", f"t = {start!r}", f'robot = "{rid}"', 'kind = "cycle"', f'prefix = "r{i + 1}"',
            f"every = {period!r}", f"until = {duration!r}",
            f'tasks = [{{path = [{_list(via)}, {_list(at_pick)}], actions = ["load"]}}, '
            f'{{path = [{_list(via)}, {_list(at_drop)}], actions = ["unload"]}}]',
        ]
    return "\n".join(out + stations + script) + "\n"


def _start(k: int) -> float:
    """When robot ``k`` (of 50, repeating) starts its cycle: staggered so that a fleet's messages spread."""
    return 1.0 + k * 0.02


def _period(home: tuple[float, float, float], via: tuple[float, float], at_pick: tuple[float, float, float],
            at_drop: tuple[float, float, float]) -> float:
    """Duration of one cycle from home and from the end of the previous one; the longer, plus slack."""
    limits = Limits(SPEED, ACCEL, ACCEL, TURN)

    def drive(pose: tuple[float, float, float], points: list[tuple[float, ...]]) -> tuple[float, tuple[float, float, float]]:
        total = 0.0
        for n, p in enumerate(points):
            goal = p[2] if n == len(points) - 1 and len(p) == 3 else None
            leg = Leg(0.0, *pose, p[0], p[1], goal, limits)
            total += leg.duration
            pose = (leg.x1, leg.y1, leg.end_theta)
        return total, pose

    def cycle(pose: tuple[float, float, float]) -> float:
        t1, pose = drive(pose, [via, at_pick])
        t2, _ = drive(pose, [via, at_drop])
        return t1 + t2 + DURATIONS["load"] + DURATIONS["unload"]

    longest = max(cycle(home), cycle(at_drop))
    return math.ceil((longest + SLACK) * 1000) / 1000


def _list(values: tuple[float, ...]) -> str:
    return "[" + ", ".join(repr(float(v)) for v in values) + "]"
