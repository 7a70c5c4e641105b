"""The fleet's poses in one vectorised sweep (numpy): the telemetry of a thousand robots at 1 Hz.

:class:`~vcran.core.motion.FleetKinematics` keeps its bookkeeping in plain Python and comes here only when
someone samples the fleet (a consumer of ``current_motion`` frames, the battery's sweep, replay's
telemetry, collision checks), so a run that samples nothing never imports numpy. Every function mirrors
:meth:`Leg.pose_at <vcran.core.motion.Leg.pose_at>` operation by operation, so the scalar and the
vectorised paths agree to the last bit (tests/core/test_motion.py).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from vcran.core.motion import _COLUMNS, SCALAR_BELOW, TAU, C, Leg, _row

if TYPE_CHECKING:
    from vcran.core.motion import FleetKinematics


def moving_rows(
    table: np.ndarray | None, robots: int, current: dict[int, Leg], started: set[int]
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every robot's leg as a row (:data:`C` columns) brought up to date, the moving robots' indices, and
    their rows. ``table`` is the last sweep's (None: the first sweep fills it from ``current``); only
    the robots in ``started`` (a leg began since) are written again: a few rows a tick, not the fleet."""
    if table is None:
        table = np.zeros((robots, len(_COLUMNS)), dtype=np.float64)
        started = set(current)
    for i in started:
        leg = current.get(i)
        if leg is not None:
            table[i] = _row(leg)
    idx = np.fromiter(current, dtype=np.intp, count=len(current))
    return table, idx, table[idx]


def fleet_sample(fleet: FleetKinematics, t: float) -> np.ndarray:
    """A (robots, 5) array of ``x, y, theta, v, w`` at ``t`` (legs not started count as at rest)."""
    out = np.zeros((len(fleet), 5), dtype=np.float64)
    if len(fleet):
        out[:, :3] = fleet.rest
    if len(fleet.current) < SCALAR_BELOW:  # numpy's per-call overhead would dominate
        for i, leg in fleet.current.items():
            out[i] = leg.pose_at(t)
        return out
    idx, rows = fleet.moving()
    out[idx] = sample_moving(rows, t)
    return out


def fleet_distances(fleet: FleetKinematics, t: float) -> np.ndarray:
    """Every robot's odometer at ``t`` (the battery's sweep), legs in progress included."""
    out = np.array(fleet.odometer, dtype=np.float64)
    for i, d in fleet.held.items():
        out[i] += d
    if len(fleet.current) < SCALAR_BELOW:
        for i, leg in fleet.current.items():
            out[i] += leg.distance_at(t)
        return out
    idx, rows = fleet.moving()
    out[idx] += _driven(rows, np.maximum(t - rows[:, C["t0"]], 0.0) - rows[:, C["t_turn1"]])
    return out


def sample_leg(leg: Leg, times: np.ndarray) -> np.ndarray:
    """A ``(len(times), 5)`` array of one leg's ``x, y, theta, v, w`` at each of ``times``: the fleet sweep's
    arithmetic on one leg, which :func:`leg_poses` reproduces and falls back to."""
    row = np.array(_row(leg), dtype=np.float64)
    return sample_moving(np.broadcast_to(row, (len(times), len(_COLUMNS))), times)  # type: ignore[arg-type]


def leg_poses(leg: Leg, times: np.ndarray) -> np.ndarray:
    """A ``(len(times), 3)`` array of one leg's ``x, y, theta`` at each of ``times`` (collision checks).

    :func:`sample_moving`'s arithmetic, element for element, evaluated phase by phase: with ``times``
    ascending, each phase of the leg (turning, accelerating, cruising, braking, turning, ended) is one
    stretch of them, found by bisection, so each formula runs once, on its own stretch, with the leg's
    parameters as scalars. A collision check samples a few dozen instants at a time, where numpy's cost
    is per call, not per element: this takes about a third of the calls of :func:`sample_leg`, and a
    refinement round, whose instants all lie in one phase, a tenth. Times are taken as float64 (the
    reference's arithmetic); unordered ones, or NaN, go through :func:`sample_leg` (same results).
    """
    times = np.asarray(times, dtype=np.float64)
    n = len(times)
    if n and not (times[0] == times[0] and (times[1:] >= times[:-1]).all()):  # NaN or out of order
        return sample_leg(leg, times)[:, :3]
    out = np.empty((n, 3))
    ke = int(times.searchsorted(leg.t_end, "left"))  # from here on the leg has ended
    if ke < n:
        out[ke:] = (leg.x1, leg.y1, leg.end_theta)
    if ke == 0:
        return out
    tau = np.maximum(times[:ke] - leg.t0, 0.0)
    t1 = leg.t_turn1
    k1 = int(tau.searchsorted(t1, "left"))  # before k1: turning towards the heading
    if k1:
        out[:k1, 0] = leg.x0
        out[:k1, 1] = leg.y0
        out[:k1, 2] = _wrap_array(leg.theta0 + leg.rate1 * tau[:k1])
    if k1 == ke:
        return out
    d = tau[k1:] - t1
    td = leg.t_drive
    k2 = int(d.searchsorted(td, "left"))  # from k1 + k2 on: turning to the goal's theta
    if k2 < len(d):
        out[k1 + k2:ke, 0] = leg.x1
        out[k1 + k2:ke, 1] = leg.y1
        out[k1 + k2:ke, 2] = _wrap_array(leg.heading + leg.rate2 * (d[k2:] - td))
    if k2:
        d = d[:k2]
        peak, ta, tdec, dist = leg.peak, leg.t_acc, leg.t_dec, leg.distance
        na = int(d.searchsorted(ta, "left"))  # accelerating before na
        nc = max(na, int(d.searchsorted(td - tdec, "right")))  # cruising before nc, then braking
        s = np.empty(k2)
        if na:
            s[:na] = 0.5 * peak * d[:na] * d[:na] / ta
        if nc > na:
            s[na:nc] = 0.5 * peak * ta + peak * (d[na:nc] - ta)
        if nc < k2:
            rest = td - d[nc:]
            s[nc:] = dist - 0.5 * peak * rest * rest / tdec
        s = np.minimum(np.maximum(s, 0.0), dist)
        out[k1:k1 + k2, 0] = leg.x0 + leg.ux * s
        out[k1:k1 + k2, 1] = leg.y0 + leg.uy * s
        out[k1:k1 + k2, 2] = leg.heading
    return out


def _wrap_array(a: np.ndarray) -> np.ndarray:
    """:func:`~vcran.core.motion.wrap` elementwise, with the same fmod steps (fmod is exact, so results agree)."""
    r = np.fmod(a + math.pi, TAU)
    r = np.where(r <= 0.0, r + TAU, r)
    return np.where((-math.pi < a) & (a <= math.pi), a, r - math.pi)


def _driven(L: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Distance covered ``d`` seconds into each leg's drive (``d`` clamped to the drive), vectorised."""
    col = lambda name: L[:, C[name]]  # noqa: E731
    td, ta, tdec, peak, dist = col("t_drive"), col("t_acc"), col("t_dec"), col("peak"), col("distance")
    d = np.minimum(np.maximum(d, 0.0), td)
    with np.errstate(divide="ignore", invalid="ignore"):
        rest = td - d
        s = np.where(
            d < ta, 0.5 * peak * d * d / ta,
            np.where(d <= td - tdec, 0.5 * peak * ta + peak * (d - ta), dist - 0.5 * peak * rest * rest / tdec),
        )
    return np.minimum(np.maximum(s, 0.0), dist)  # a NaN of a 0/0 ramp lies in a branch np.where did not pick


def sample_moving(L: np.ndarray, t: float) -> np.ndarray:
    """Poses of legs that are under way at ``t`` (rows of :data:`C` columns); mirrors ``Leg.pose_at``."""
    col = lambda name: L[:, C[name]]  # noqa: E731
    tau = np.maximum(t - col("t0"), 0.0)
    t1, td, ta, tdec = col("t_turn1"), col("t_drive"), col("t_acc"), col("t_dec")
    peak, dist = col("peak"), col("distance")
    turning1 = tau < t1
    d = tau - t1
    driving = ~turning1 & (d < td)
    with np.errstate(divide="ignore", invalid="ignore"):
        accelerating = d < ta
        cruising = ~accelerating & (d <= td - tdec)
        rest = td - d
        s = np.where(
            accelerating, 0.5 * peak * d * d / ta,
            np.where(cruising, 0.5 * peak * ta + peak * (d - ta), dist - 0.5 * peak * rest * rest / tdec),
        )
        v = np.where(accelerating, peak * d / ta, np.where(cruising, peak, peak * rest / tdec))
    s = np.minimum(np.maximum(s, 0.0), dist)
    out = np.empty((len(L), 5))
    out[:, 0] = np.where(turning1, col("x0"), np.where(driving, col("x0") + col("ux") * s, col("x1")))
    out[:, 1] = np.where(turning1, col("y0"), np.where(driving, col("y0") + col("uy") * s, col("y1")))
    theta_turn1 = _wrap_array(col("theta0") + col("rate1") * tau)
    theta_turn2 = _wrap_array(col("heading") + col("rate2") * (d - td))
    out[:, 2] = np.where(turning1, theta_turn1, np.where(driving, col("heading"), theta_turn2))
    out[:, 3] = np.where(driving, v, 0.0)
    out[:, 4] = np.where(turning1, col("rate1"), np.where(driving, 0.0, col("rate2")))
    ended = t >= col("t_end")
    if ended.any():  # a leg whose completion has not been processed yet: at its end pose
        out[ended] = np.column_stack((col("x1"), col("y1"), col("end_theta"), np.zeros(len(L)), np.zeros(len(L))))[ended]
    return out
