"""The fleet's telemetry reconstructed from a recording: ``current_motion`` of every robot at every tick,
evaluated from the leg log with the very code that published it (bit for bit), or read from format 1's
``telemetry.bin``; and as a table of named columns for pandas or polars."""

from __future__ import annotations

import heapq
import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

from vcran.core.motion import Leg
from vcran.core.wire import Frame
from vcran.io.trace.files import TELEMETRY_FILE
from vcran.io.trace.readers import legs, read_header, robots_of, telemetry, trace_in

if TYPE_CHECKING:
    import numpy as np


def samples(trace: Path) -> np.ndarray:
    """``current_motion`` of the whole fleet at every telemetry tick: a (ticks, 1 + robots * 5) float64
    array ``[t, x0, y0, theta0, v0, w0, x1, ...]``, robots in header order; from ``telemetry.bin``
    (format 1) or evaluated from the leg log (format 2), bit for bit what was published."""
    trace = trace_in(trace)
    header = read_header(trace)
    robots = robots_of(header)
    from vcran.io.verify import recorded_end

    end, complete = recorded_end(trace, header)
    if header["version"] == 1:
        path = trace.parent / str(header.get("telemetry", {}).get("file", TELEMETRY_FILE))
        return telemetry(path, len(robots), cut_off=not complete)
    return from_legs(header["fleet"], legs(trace.parent / str(header["legs"]["file"]), cut_off=not complete), end)


def from_legs(fleet_spec: dict[str, Any], rows: np.ndarray, end: float) -> np.ndarray:
    """:func:`samples` of the leg log ``rows`` of a run of the fleet ``fleet_spec`` (a trace header's ``fleet``,
    :meth:`vcran.core.scenario.Scenario.fleet_dict`) that ended at ``end``: drive a :class:`FleetKinematics`
    through the logged legs and sample it at every tick, exactly as the telemetry process did
    (:meth:`vcran.sim.opil.ran.Ran.telemetry`: tick k at ``k * period``, up to and including the end)."""
    import numpy as np

    from vcran.core.motion import FleetKinematics, Limits

    poses = [tuple(float(c) for c in r["pose"]) for r in fleet_spec["robots"]]
    period = float(fleet_spec["simulation"].get("telemetry_period", 1.0))
    fleet = FleetKinematics(poses)  # type: ignore[arg-type]
    ending: list[tuple[float, int, int, Leg]] = []  # (t_end, row, robot, leg): legs to finish
    out = []
    j, k, n = 0, 0, len(rows)
    while (t := k * period) <= end:
        # leg ends and logged rows up to this tick, in the order they happened: a halt before a leg's end
        # stops it there, a leg's end before a halt leaves nothing to halt (ties: the end first, which
        # stops the robot at the same place, and lets a leg start where the last one ended)
        while (ending and ending[0][0] <= t) or (j < n and rows[j]["t"] <= t):
            if ending and ending[0][0] <= t and (j >= n or ending[0][0] <= rows[j]["t"]):
                _, _, i, done = heapq.heappop(ending)
                if fleet.current.get(i) is done:
                    fleet.finish(i)
                continue
            r = rows[j]
            i = int(r["robot"])
            if math.isnan(r["t0"]) and not math.isnan(r["x0"]):  # an abandon: it rests where the leg began
                fleet.place(i, float(r["t"]), (float(r["x0"]), float(r["y0"]), float(r["theta0"])))
            elif math.isnan(r["t0"]):  # a halt: the robot rests where its leg had brought it
                if i in fleet.current:
                    fleet.stop(i, float(r["t"]))
            else:
                if i in fleet.current:
                    fleet.finish(i)
                goal = float(r["theta"])
                leg = Leg(float(r["t0"]), float(r["x0"]), float(r["y0"]), float(r["theta0"]), float(r["x"]),
                          float(r["y"]), None if math.isnan(goal) else goal,
                          Limits(float(r["speed"]), float(r["accel"]), float(r["decel"]), float(r["turn_rate"])))
                fleet.start(i, leg)
                heapq.heappush(ending, (leg.t_end, j, i, leg))
            j += 1
        row = np.empty(1 + 5 * len(poses))
        row[0] = t
        row[1:] = fleet.sample(t).reshape(-1)
        out.append(row)
        k += 1
    return np.vstack(out) if out else np.empty((0, 1 + 5 * len(poses)))


def telemetry_table(run: Path | str) -> np.ndarray:
    """Every robot's ``current_motion`` at every telemetry tick of a run folder (either format), one row
    per robot and tick, ticks in order and robots in fleet order, as a structured array with named
    columns ``t``, ``robot``, ``x``, ``y``, ``theta``, ``v``, ``w``: ``pandas.DataFrame(telemetry_table(run))``
    or ``polars.from_numpy(telemetry_table(run))``. The values are bit for bit those published."""
    trace = trace_in(Path(run))
    return long_table(samples(trace), tuple(robots_of(read_header(trace))))


def long_table(rows: np.ndarray, robots: tuple[str, ...]) -> np.ndarray:
    """Telemetry rows ``[t, x0, y0, theta0, v0, w0, x1, ...]`` as one record per tick and robot."""
    import numpy as np

    n, ticks = len(robots), rows.shape[0]
    width = max((len(r) for r in robots), default=1)
    table = np.empty(ticks * n, dtype=[("t", "<f8"), ("robot", f"<U{width}"),
                                       *((name, "<f8") for name in Frame.FIELDS)])
    table["t"] = np.repeat(rows[:, 0], n)
    table["robot"] = np.tile(np.array(robots), ticks)
    columns = rows[:, 1:].reshape(ticks, n, len(Frame.FIELDS))
    for k, name in enumerate(Frame.FIELDS):
        table[name] = columns[:, :, k].ravel()
    return table
