"""Leg kinematics: where an AGV is at any instant, computed, never stepped (SPEC §4).

A leg goes from the AGV's pose to one motion assignment's point in three phases: turn in place to face
the point, drive a straight line with a trapezoidal speed profile (or a triangle when the leg is too short
to reach cruise speed), and, for a goal with ``use_orientation``, turn in place to ``theta``. Every phase is
closed-form, so the cost of a pose does not depend on the leg's length or on how often it is sampled.

:class:`Leg` answers for one robot (the AGV process uses its duration to schedule the arrival);
:class:`FleetKinematics` holds every robot's current leg in numpy arrays and samples the whole fleet in
one vectorised sweep, which is how the 1 Hz telemetry of a thousand robots stays cheap.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

TAU = 2.0 * math.pi


def wrap(angle: float) -> float:
    """Angle in (-pi, pi]."""
    a = math.fmod(angle + math.pi, TAU)
    if a <= 0.0:
        a += TAU
    return a - math.pi


@dataclass(frozen=True, slots=True)
class Limits:
    """Speed limits of one leg: linear speed, acceleration and deceleration, angular speed.

    A non-positive acceleration, deceleration or angular speed means "instantaneous" (the seed's
    interpolating AGV has none); the linear speed must be positive.
    """

    speed: float
    accel: float = 0.0
    decel: float = 0.0
    turn_rate: float = 0.0

    def __post_init__(self) -> None:
        if not (math.isfinite(self.speed) and self.speed > 0):
            raise ValueError(f"leg speed must be a positive finite number, got {self.speed}")


@dataclass(frozen=True, slots=True)
class Leg:
    """One straight leg from ``(x0, y0, theta0)`` to ``(x1, y1)``, starting at ``t0``."""

    t0: float
    x0: float
    y0: float
    theta0: float
    x1: float
    y1: float
    theta_goal: float | None
    limits: Limits

    # Derived once in __post_init__ (frozen: set through object.__setattr__).
    distance: float = 0.0
    heading: float = 0.0
    turn1: float = 0.0  # signed angle of the first turn
    t_turn1: float = 0.0
    peak: float = 0.0  # highest speed reached
    t_acc: float = 0.0
    t_dec: float = 0.0
    t_drive: float = 0.0
    turn2: float = 0.0
    t_turn2: float = 0.0

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        dx, dy = self.x1 - self.x0, self.y1 - self.y0
        distance = math.hypot(dx, dy)
        heading = math.atan2(dy, dx) if distance > 0 else self.theta0
        turn1 = wrap(heading - self.theta0) if distance > 0 else 0.0
        lim = self.limits
        peak, t_acc, t_dec, t_drive = _profile(distance, lim.speed, lim.accel, lim.decel)
        turn2 = wrap(self.theta_goal - heading) if self.theta_goal is not None else 0.0
        for name, value in (
            ("distance", distance),
            ("heading", heading),
            ("turn1", turn1),
            ("t_turn1", _turn_time(turn1, lim.turn_rate)),
            ("peak", peak),
            ("t_acc", t_acc),
            ("t_dec", t_dec),
            ("t_drive", t_drive),
            ("turn2", turn2),
            ("t_turn2", _turn_time(turn2, lim.turn_rate)),
        ):
            set_(self, name, value)

    @property
    def duration(self) -> float:
        return self.t_turn1 + self.t_drive + self.t_turn2

    @property
    def end_theta(self) -> float:
        """Exactly the goal's theta when it has one, so a goal pose is reached bit for bit."""
        return wrap(self.theta_goal) if self.theta_goal is not None else self.heading

    def pose_at(self, t: float) -> tuple[float, float, float, float, float]:
        """``(x, y, theta, linear speed, angular speed)`` at time ``t`` (clamped to the leg)."""
        if t >= self.t0 + self.duration:
            return self.x1, self.y1, self.end_theta, 0.0, 0.0
        tau = max(t - self.t0, 0.0)
        if tau < self.t_turn1:
            rate = math.copysign(self.limits.turn_rate, self.turn1)
            return self.x0, self.y0, wrap(self.theta0 + rate * tau), 0.0, rate
        tau -= self.t_turn1
        if tau < self.t_drive:
            s, v = _along(tau, self.distance, self.peak, self.t_acc, self.t_dec, self.t_drive)
            ux, uy = math.cos(self.heading), math.sin(self.heading)
            return self.x0 + ux * s, self.y0 + uy * s, self.heading, v, 0.0
        tau -= self.t_drive
        if tau < self.t_turn2:
            rate = math.copysign(self.limits.turn_rate, self.turn2)
            return self.x1, self.y1, wrap(self.heading + rate * tau), 0.0, rate
        return self.x1, self.y1, self.end_theta, 0.0, 0.0

    def distance_at(self, t: float) -> float:
        tau = t - self.t0 - self.t_turn1
        if tau <= 0.0:
            return 0.0
        if tau >= self.t_drive:
            return self.distance
        return _along(tau, self.distance, self.peak, self.t_acc, self.t_dec, self.t_drive)[0]


def _turn_time(angle: float, rate: float) -> float:
    return abs(angle) / rate if rate > 0 and angle != 0.0 else 0.0


def _profile(distance: float, speed: float, accel: float, decel: float) -> tuple[float, float, float, float]:
    """Peak speed, acceleration time, deceleration time and total time of a straight drive."""
    if distance <= 0.0:
        return 0.0, 0.0, 0.0, 0.0
    inv_a = 1.0 / accel if accel > 0 else 0.0
    inv_d = 1.0 / decel if decel > 0 else 0.0
    ramps = 0.5 * speed * speed * (inv_a + inv_d)  # distance spent accelerating and braking
    if ramps <= distance:
        peak = speed
        cruise = (distance - ramps) / speed
    else:  # triangle: never reaches cruise speed
        peak = math.sqrt(distance / (0.5 * (inv_a + inv_d)))
        cruise = 0.0
    t_acc, t_dec = peak * inv_a, peak * inv_d
    return peak, t_acc, t_dec, t_acc + cruise + t_dec


def _along(tau: float, distance: float, peak: float, t_acc: float, t_dec: float, t_drive: float) -> tuple[float, float]:
    if tau < t_acc:
        return 0.5 * peak * tau * tau / t_acc, peak * tau / t_acc
    if tau <= t_drive - t_dec:
        return 0.5 * peak * t_acc + peak * (tau - t_acc), peak
    rest = t_drive - tau
    return distance - 0.5 * peak * rest * rest / t_dec, peak * rest / t_dec


# Column layout of FleetKinematics.legs: one row per robot, the parameters of its current leg.
_COLUMNS = (
    "t0 x0 y0 theta0 x1 y1 end_theta distance heading turn1 t_turn1 rate1 peak t_acc t_dec t_drive turn2 "
    "t_turn2 rate2 t_end"
).split()
C = {name: i for i, name in enumerate(_COLUMNS)}


class FleetKinematics:
    """Every robot's current leg as one row of a float64 array, sampled for all robots at once.

    A robot at rest has a degenerate leg that ended at -inf at its pose. Rows are written by
    :meth:`start` (the AGV process, once per leg) and read by :meth:`sample` (the telemetry sweep, once
    per tick): O(robots) numpy work per tick, no Python loop over robots.
    """

    def __init__(self, poses: list[tuple[float, float, float]]) -> None:
        n = len(poses)
        self.legs = np.zeros((n, len(_COLUMNS)), dtype=np.float64)
        self.legs[:, C["t_end"]] = -np.inf
        self.odometer = np.zeros(n, dtype=np.float64)  # distance of finished legs
        for i, (x, y, theta) in enumerate(poses):
            self.rest(i, x, y, theta)

    def __len__(self) -> int:
        return len(self.legs)

    def rest(self, i: int, x: float, y: float, theta: float) -> None:
        row = self.legs[i]
        row[:] = 0.0
        row[[C["x0"], C["x1"]]] = x
        row[[C["y0"], C["y1"]]] = y
        row[[C["theta0"], C["end_theta"], C["heading"]]] = theta
        row[C["t_end"]] = -np.inf

    def start(self, i: int, leg: Leg) -> None:
        row = self.legs[i]
        rate = leg.limits.turn_rate
        values = {
            "t0": leg.t0, "x0": leg.x0, "y0": leg.y0, "theta0": leg.theta0, "x1": leg.x1, "y1": leg.y1,
            "end_theta": leg.end_theta, "distance": leg.distance, "heading": leg.heading,
            "turn1": leg.turn1, "t_turn1": leg.t_turn1, "rate1": math.copysign(rate, leg.turn1),
            "peak": leg.peak, "t_acc": leg.t_acc, "t_dec": leg.t_dec, "t_drive": leg.t_drive,
            "turn2": leg.turn2, "t_turn2": leg.t_turn2, "rate2": math.copysign(rate, leg.turn2),
            "t_end": leg.t0 + leg.duration,
        }
        for name, value in values.items():
            row[C[name]] = value

    def finish(self, i: int) -> None:
        """The leg of robot ``i`` is over: bank its distance and rest at its end pose."""
        row = self.legs[i]
        self.odometer[i] += row[C["distance"]]
        self.rest(i, row[C["x1"]], row[C["y1"]], row[C["end_theta"]])

    def distance(self, i: int, t: float) -> float:
        """Odometer of robot ``i`` at ``t``, including the driven part of its current leg."""
        x, y, *_ = self.sample(t, np.array([i]))
        row = self.legs[i]
        partial = math.hypot(x[0] - row[C["x0"]], y[0] - row[C["y0"]]) if t < row[C["t_end"]] else 0.0
        return float(self.odometer[i] + partial)

    def sample(self, t: float, rows: np.ndarray | None = None) -> tuple[np.ndarray, ...]:
        """``(x, y, theta, v, w)`` arrays at time ``t`` for ``rows`` (default: every robot)."""
        legs = self.legs if rows is None else self.legs[rows]
        x = legs[:, C["x1"]].copy()
        y = legs[:, C["y1"]].copy()
        theta = legs[:, C["end_theta"]].copy()
        v = np.zeros(len(legs))
        w = np.zeros(len(legs))
        moving = np.flatnonzero(t < legs[:, C["t_end"]])
        if moving.size:
            _sample_moving(legs[moving], t, moving, x, y, theta, v, w)
        return x, y, theta, v, w


def _sample_moving(
    L: np.ndarray, t: float, idx: np.ndarray, x: np.ndarray, y: np.ndarray, theta: np.ndarray,
    v: np.ndarray, w: np.ndarray,
) -> None:
    """Fill the outputs at ``idx`` for legs that have not ended; mirrors :meth:`Leg.pose_at`."""
    tau = np.maximum(t - L[:, C["t0"]], 0.0)
    t1, td = L[:, C["t_turn1"]], L[:, C["t_drive"]]
    ta, tdec, peak, dist = L[:, C["t_acc"]], L[:, C["t_dec"]], L[:, C["peak"]], L[:, C["distance"]]
    heading = L[:, C["heading"]]

    turning1 = tau < t1
    d = tau - t1
    driving = ~turning1 & (d < td)
    turning2 = ~turning1 & ~driving

    safe_ta = np.where(ta > 0, ta, 1.0)
    safe_td = np.where(tdec > 0, tdec, 1.0)
    rest = td - d
    s = np.where(
        d < ta,
        0.5 * peak * d * d / safe_ta,
        np.where(d <= td - tdec, 0.5 * peak * ta + peak * (d - ta), dist - 0.5 * peak * rest * rest / safe_td),
    )
    speed = np.where(d < ta, peak * d / safe_ta, np.where(d <= td - tdec, peak, peak * rest / safe_td))
    s = np.clip(s, 0.0, dist)

    cos_h, sin_h = np.cos(heading), np.sin(heading)
    px = np.where(turning1, L[:, C["x0"]], np.where(driving, L[:, C["x0"]] + cos_h * s, L[:, C["x1"]]))
    py = np.where(turning1, L[:, C["y0"]], np.where(driving, L[:, C["y0"]] + sin_h * s, L[:, C["y1"]]))
    d2 = d - td
    ang = np.where(
        turning1,
        L[:, C["theta0"]] + L[:, C["rate1"]] * tau,
        np.where(driving, heading, heading + L[:, C["rate2"]] * d2),
    )
    ang = np.mod(ang + np.pi, 2 * np.pi) - np.pi
    ang = np.where(ang == -np.pi, np.pi, ang)
    x[idx] = px
    y[idx] = py
    theta[idx] = ang
    v[idx] = np.where(driving, speed, 0.0)
    w[idx] = np.where(turning1, L[:, C["rate1"]], np.where(turning2, L[:, C["rate2"]], 0.0))
