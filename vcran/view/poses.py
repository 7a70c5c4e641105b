"""Where a robot is at any instant, from the leg log: the rule the page's ``fleet.js`` follows too.

:func:`vcran.io.trace.samples` drives a whole :class:`~vcran.core.motion.FleetKinematics` through the log
to sample every tick. A page asks about one instant the user scrubbed to, so it needs the same answer
per robot and per instant without replaying the log from the start. Robots are independent (each row
concerns one robot), and a robot's pose at ``t`` follows from its last row at or before ``t``:

* a leg: the leg's pose at ``t`` (:meth:`Leg.pose_at`, clamped to the leg: past its end it rests there);
* an abandon (R14): the pose the row gives, where the leg began;
* a halt: where the robot was at the halt's instant, i.e. the same rule one row earlier, evaluated at
  the halt (a halt of a robot at rest, or of a leg already over at a tie, leaves it where it was);
* none: the robot's starting pose (theta wrapped, as :class:`FleetKinematics` keeps it).

This is exactly what ``vcran.io.trace.reconstruct.from_legs`` computes at a tick (tests/view/test_view_model.py
compares it with ``vcran.telemetry_table`` at every tick of the docs/contract.md §4 scenarios, the warehouse and a generated fleet).
"""

from __future__ import annotations

import math

import numpy as np

from vcran.core.motion import Leg, Limits, wrap

Pose = tuple[float, float, float]

#: Kinds of leg log row (the page ships them as one byte per row).
LEG, HALT, ABANDON = 0, 1, 2


def row_kinds(rows: np.ndarray) -> np.ndarray:
    """LEG, HALT or ABANDON per row of a leg log (docs/outputs.md: NaN ``t0``, and ``x0`` set or not)."""
    halt = np.isnan(rows["t0"])
    return np.where(halt, np.where(np.isnan(rows["x0"]), HALT, ABANDON), LEG).astype(np.uint8)


class Poses:
    """Every robot's pose at any instant (module docstring). A row's leg or rest pose is worked out the
    first time a pose needs it: a page asks about few instants of a long run."""

    def __init__(self, starts: list[Pose], rows: np.ndarray | None) -> None:
        self._starts = [(float(x), float(y), wrap(float(th))) for x, y, th in starts]
        n = len(starts)
        empty = np.zeros(0, dtype=np.int64)
        self._rows = rows
        #: per robot: its rows' indices into ``rows`` and their times, in log order
        self._index: list[np.ndarray] = [empty] * n
        self._times: list[np.ndarray] = [np.zeros(0)] * n
        self._states: dict[int, Leg | Pose] = {}
        if rows is None or len(rows) == 0:
            return
        self._kinds = row_kinds(rows)
        robot = rows["robot"].astype(np.int64)
        order = np.argsort(robot, kind="stable")
        bounds = np.searchsorted(robot[order], np.arange(n + 1))
        for i in range(n):
            self._index[i] = order[bounds[i]:bounds[i + 1]]
            self._times[i] = rows["t"][self._index[i]]

    def pose(self, i: int, t: float) -> Pose:
        """Robot ``i``'s x, y, theta at ``t``."""
        return self._at(i, int(np.searchsorted(self._times[i], t, side="right")), t)

    def _at(self, i: int, k: int, t: float) -> Pose:
        """The pose at ``t`` given that robot ``i``'s rows before its ``k``-th are the ones that happened."""
        if k == 0:
            return self._starts[i]
        state = self._state(i, k - 1)
        return state.pose_at(t)[:3] if isinstance(state, Leg) else state

    def _state(self, i: int, k: int) -> Leg | Pose:
        """Robot ``i``'s ``k``-th row as a Leg, or the pose it rests at from then on."""
        j = int(self._index[i][k])
        state = self._states.get(j)
        if state is not None:
            return state
        assert self._rows is not None
        r, kind = self._rows[j], self._kinds[j]
        if kind == LEG:
            goal = float(r["theta"])
            state = Leg(float(r["t0"]), float(r["x0"]), float(r["y0"]), float(r["theta0"]), float(r["x"]),
                        float(r["y"]), None if math.isnan(goal) else goal,
                        Limits(float(r["speed"]), float(r["accel"]), float(r["decel"]), float(r["turn_rate"])))
        elif kind == ABANDON:
            state = (float(r["x0"]), float(r["y0"]), float(r["theta0"]))
        else:  # a halt: where the robot was then (a halt after a halt: recursion as deep as the run of halts)
            state = self._at(i, k, float(r["t"]))
        self._states[j] = state
        return state
