"""Leg kinematics: where an AGV is at any instant, computed, never stepped (docs/contract.md §4).

A leg goes from the AGV's pose to one motion assignment's point in three phases: turn in place to face
the point, drive a straight line with a trapezoidal speed profile (or a triangle when the leg is too short
to reach cruise speed), and, for a goal with ``use_orientation``, turn in place to ``theta``. Every phase is
closed-form, so the cost of a pose does not depend on the leg's length or on how often it is sampled.

:class:`Leg` answers for one robot (the AGV process uses its duration to schedule the arrival);
:class:`FleetKinematics` holds every robot's current leg and samples the whole fleet in one vectorised
sweep (:mod:`vcran.core.sampling`), which is how the 1 Hz telemetry of a thousand robots stays cheap.
numpy is imported only by that sweep: a run whose fleet nobody samples (``vcran run``: every record is
reproduced from the leg log) does not load it, which was a tenth of a small run's process (issue 14).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from operator import attrgetter
from typing import TYPE_CHECKING, Protocol

if TYPE_CHECKING:
    import numpy as np

TAU = 2.0 * math.pi
_PI = math.pi


def wrap(angle: float) -> float:
    """Angle in (-pi, pi]; an angle already in range is returned unchanged (bit for bit)."""
    if -math.pi < angle <= math.pi:
        return angle
    a = math.fmod(angle + math.pi, TAU)
    if a <= 0.0:
        a += TAU
    return a - math.pi


@dataclass(frozen=True, slots=True)
class Limits:
    """Speed limits of one leg: linear speed, acceleration and deceleration, angular speed.

    A non-positive acceleration, deceleration or angular speed means "instantaneous" (the original VC-RAN's
    interpolating AGV has none); the linear speed must be positive.
    """

    speed: float
    accel: float = 0.0
    decel: float = 0.0
    turn_rate: float = 0.0

    def __post_init__(self) -> None:
        if not (math.isfinite(self.speed) and self.speed > 0):
            raise ValueError(f"leg speed must be a positive finite number, got {self.speed}")


@dataclass(slots=True)
class Leg:
    """One straight leg from ``(x0, y0, theta0)`` to ``(x1, y1)``, starting at ``t0``.

    A value: built once per motion driven and never changed afterwards (the fleet's table, the leg log
    and the AGV process share it; a held leg is resumed as a new one through ``dataclasses.replace``).
    It is not ``frozen`` only because a frozen class pays an ``object.__setattr__`` per field in its
    constructor: 24 fields, 48k machine instructions a leg against 15k with plain stores (callgrind),
    3.8% of a 1000-robot run (py-spy; issue 14).
    """

    t0: float
    x0: float
    y0: float
    theta0: float
    x1: float
    y1: float
    theta_goal: float | None
    limits: Limits

    # Derived once, in __init__ (not constructor arguments: replace() passes the eight above only).
    distance: float = field(init=False)
    heading: float = field(init=False)
    ux: float = field(init=False)  # cos(heading), sin(heading): computed once, in scalar libm (see module notes)
    uy: float = field(init=False)
    turn1: float = field(init=False)  # signed angle of the first turn
    rate1: float = field(init=False)  # signed angular speed of the first turn
    t_turn1: float = field(init=False)
    peak: float = field(init=False)  # highest speed reached
    t_acc: float = field(init=False)
    t_dec: float = field(init=False)
    t_drive: float = field(init=False)
    turn2: float = field(init=False)
    rate2: float = field(init=False)
    t_turn2: float = field(init=False)
    end_theta: float = field(init=False)
    t_end: float = field(init=False)

    def __init__(self, t0: float, x0: float, y0: float, theta0: float, x1: float, y1: float,
                 theta_goal: float | None, limits: Limits) -> None:
        # Written out (``dataclass`` keeps a class's own __init__): the derived fields need computing anyway.
        # Angles already in (-pi, pi] skip wrap() and turns of zero _turn_time(), as those functions would
        # return them: two legs a task, and each call cost more than its arithmetic (issue 30).
        self.t0, self.x0, self.y0, self.theta0, self.x1, self.y1 = t0, x0, y0, theta0, x1, y1
        self.theta_goal, self.limits = theta_goal, limits
        dx, dy = x1 - x0, y1 - y0
        self.distance = distance = math.hypot(dx, dy)
        heading = math.atan2(dy, dx) if distance > 0 else theta0
        if not -_PI < heading <= _PI:  # atan2 may return -pi
            heading = wrap(heading)
        self.heading = heading
        self.ux, self.uy = math.cos(heading), math.sin(heading)
        rate = limits.turn_rate
        turn1 = heading - theta0 if distance > 0 else 0.0
        if not -_PI < turn1 <= _PI:
            turn1 = wrap(turn1)
        self.turn1 = turn1
        self.rate1 = math.copysign(rate, turn1)
        self.t_turn1 = t_turn1 = _turn_time(turn1, rate) if turn1 != 0.0 else 0.0
        self.peak, self.t_acc, self.t_dec, self.t_drive = _profile(distance, limits.speed, limits.accel, limits.decel)
        if theta_goal is None:
            self.turn2, self.rate2, self.t_turn2 = 0.0, math.copysign(rate, 0.0), 0.0
            self.end_theta = heading
        else:
            self.turn2 = turn2 = wrap(theta_goal - heading)
            self.rate2 = math.copysign(rate, turn2)
            self.t_turn2 = _turn_time(turn2, rate)
            # Exactly the goal's theta, so a goal pose is reached bit for bit.
            self.end_theta = wrap(theta_goal)
        self.t_end = t0 + (t_turn1 + self.t_drive + self.t_turn2)

    @property
    def duration(self) -> float:
        return self.t_turn1 + self.t_drive + self.t_turn2

    def pose_at(self, t: float) -> tuple[float, float, float, float, float]:
        """``(x, y, theta, linear speed, angular speed)`` at ``t``, clamped to the leg.

        The same operations, in the same order, as :func:`vcran.core.sampling.sample_moving`, so that the
        scalar and the vectorised paths agree to the last bit.
        """
        if t >= self.t_end:
            return self.x1, self.y1, self.end_theta, 0.0, 0.0
        tau = t - self.t0
        if tau < 0.0:
            tau = 0.0
        if tau < self.t_turn1:
            return self.x0, self.y0, wrap(self.theta0 + self.rate1 * tau), 0.0, self.rate1
        d = tau - self.t_turn1
        if d < self.t_drive:
            s, v = _along(d, self.distance, self.peak, self.t_acc, self.t_dec, self.t_drive)
            return self.x0 + self.ux * s, self.y0 + self.uy * s, self.heading, v, 0.0
        return self.x1, self.y1, wrap(self.heading + self.rate2 * (d - self.t_drive)), 0.0, self.rate2

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


def _along(d: float, distance: float, peak: float, t_acc: float, t_dec: float, t_drive: float) -> tuple[float, float]:
    """Distance covered and speed ``d`` seconds into a drive (trapezoid or triangle profile)."""
    if d < t_acc:
        s, v = 0.5 * peak * d * d / t_acc, peak * d / t_acc
    elif d <= t_drive - t_dec:
        s, v = 0.5 * peak * t_acc + peak * (d - t_acc), peak
    else:
        rest = t_drive - d
        s, v = distance - 0.5 * peak * rest * rest / t_dec, peak * rest / t_dec
    return min(max(s, 0.0), distance), v


#: Below this many moving robots a tick is sampled leg by leg in Python: numpy's per-call overhead
#: would dominate. Both paths give bit-identical results (tests/core/test_motion.py).
SCALAR_BELOW = 24

# Columns of the fleet's leg table (vcran.core.sampling), one row per robot: the parameters of its current leg.
_COLUMNS = "t0 x0 y0 theta0 x1 y1 end_theta distance heading ux uy rate1 t_turn1 peak t_acc t_dec t_drive rate2 t_end".split()
C = {name: i for i, name in enumerate(_COLUMNS)}
#: A leg's row of that table, read in one C call (a Python loop of 19 getattrs was most of what writing a
#: row cost).
_row = attrgetter(*_COLUMNS)


class LegObserver(Protocol):
    """What a leg log is told (vcran.io.trace.TraceWriter): enough to reproduce every sample."""

    def leg(self, robot: int, leg: Leg, t: float) -> None: ...

    def halt(self, robot: int, t: float) -> None: ...

    def abandon(self, robot: int, t: float, pose: tuple[float, float, float]) -> None: ...


class FleetKinematics:
    """Every robot's current leg, sampled for the whole fleet at once.

    A robot at rest has no leg; ``rest`` holds its pose. :meth:`start` (the AGV process, once per leg)
    and :meth:`finish` keep the bookkeeping current in plain Python (a leg's start cost a third more
    when it also wrote its row into numpy arrays); :meth:`sample` (the telemetry sweep, once per tick)
    builds the moving robots' rows once per change of legs and costs a few numpy calls for the whole
    fleet, or a short Python loop when few robots move.
    """

    def __init__(self, poses: list[tuple[float, float, float]]) -> None:
        #: x, y, theta of every robot where it rests (a moving robot's is where it last rested).
        self.rest = [(float(x), float(y), float(wrap(theta))) for x, y, theta in poses]
        self.odometer = [0.0] * len(poses)  # distance of finished legs
        self.current: dict[int, Leg] = {}  # robot index -> running leg, in start order
        #: robot index -> distance driven on a leg that is held (paused, broken down; docs/contract.md §4)
        self.held: dict[int, float] = {}
        self._changes = 0  # bumped whenever a leg starts or ends, so the sweeps' cache knows
        self._moving_cache: tuple[int, np.ndarray, np.ndarray] | None = None
        #: Every robot's current leg as a row (:data:`C` columns), made on the first sweep and then kept up
        #: to date from ``_started``: the robots that started a leg since the last sweep.
        self._table: np.ndarray | None = None
        self._started: set[int] = set()
        #: Told of every leg as it starts and of every halt mid-leg (the run's leg log, from which its
        #: telemetry is reproduced).
        self.observer: LegObserver | None = None

    def __len__(self) -> int:
        return len(self.rest)

    def start(self, i: int, leg: Leg, t: float | None = None) -> None:
        """Robot ``i`` starts ``leg`` (at ``t``: a resumed leg starts later than its shifted ``t0``)."""
        if self.observer is not None:
            self.observer.leg(i, leg, leg.t0 if t is None else t)
        self._changes += 1
        self.current[i] = leg
        self._started.add(i)

    def finish(self, i: int) -> None:
        """The leg of robot ``i`` is over: bank its distance and rest at its end pose."""
        leg = self.current.pop(i)
        self._changes += 1
        self.odometer[i] += leg.distance
        self.rest[i] = (leg.x1, leg.y1, leg.end_theta)

    def stop(self, i: int, t: float) -> tuple[float, float, float]:
        """Robot ``i`` stops where it is at ``t`` (docs/contract.md §4): its leg ends there, the distance is banked."""
        leg = self.current.pop(i)
        pose = self._rest_at(i, leg, t)
        self.odometer[i] += leg.distance_at(t)
        if self.observer is not None:
            self.observer.halt(i, t)
        return pose

    def hold(self, i: int, t: float) -> tuple[float, float, float]:
        """Robot ``i`` halts at ``t`` mid-leg, to :meth:`resume` the same leg later (pause, breakdown)."""
        leg = self.current.pop(i)
        self.held[i] = leg.distance_at(t)
        if self.observer is not None:
            self.observer.halt(i, t)
        return self._rest_at(i, leg, t)

    def resume(self, i: int, leg: Leg, t: float) -> None:
        """Continue a held leg at ``t``: ``leg`` is the held one shifted in time by the halt's length."""
        del self.held[i]
        self.start(i, leg, t)

    def drop_held(self, i: int) -> None:
        """A held leg is abandoned where it was held (the robot stopped for good): bank its distance."""
        self.odometer[i] += self.held.pop(i)

    def _rest_at(self, i: int, leg: Leg, t: float) -> tuple[float, float, float]:
        self._changes += 1
        x, y, theta, _, _ = leg.pose_at(t)
        self.rest[i] = (x, y, theta)
        return x, y, theta

    def abandon(self, i: int, t: float) -> None:
        """The leg of robot ``i`` did not happen (R14, at ``t``): it rests where the leg began, nothing driven."""
        leg = self.current[i]
        self.place(i, t, (leg.x0, leg.y0, wrap(leg.theta0)))

    def place(self, i: int, t: float, pose: tuple[float, float, float]) -> None:
        """Robot ``i`` rests at ``pose`` from ``t``, its current leg (if any) not driven: :meth:`abandon`,
        and the leg log's abandon rows replayed (which come after a zero-length leg's end at a tie)."""
        self.current.pop(i, None)
        self._changes += 1
        self.rest[i] = (float(pose[0]), float(pose[1]), float(pose[2]))
        if self.observer is not None:
            self.observer.abandon(i, t, pose)

    def distance(self, i: int, t: float) -> float:
        """Odometer of robot ``i`` at ``t``, including the driven part of its current leg."""
        leg = self.current.get(i)
        if leg is None:
            return self.odometer[i] + self.held.get(i, 0.0)
        return self.odometer[i] + leg.distance_at(t)

    def pose(self, i: int, t: float) -> tuple[float, float, float]:
        """Robot ``i``'s x, y, theta at ``t``: a row of :meth:`sample`, bit for bit, without numpy."""
        leg = self.current.get(i)
        return self.rest[i] if leg is None else leg.pose_at(t)[:3]

    def distances(self, t: float) -> np.ndarray:
        """Every robot's odometer at ``t`` (the battery's sweep), legs in progress included."""
        from vcran.core.sampling import fleet_distances

        return fleet_distances(self, t)

    def sample(self, t: float) -> np.ndarray:
        """A (robots, 5) array of ``x, y, theta, v, w`` at ``t`` (legs not started count as at rest)."""
        from vcran.core.sampling import fleet_sample

        return fleet_sample(self, t)

    def moving(self) -> tuple[np.ndarray, np.ndarray]:
        """The moving robots' indices and leg rows (:data:`C` columns), shared by the sweeps of one tick
        (the legs did not change in between: nothing runs between a tick's telemetry and its battery sweep)."""
        if self._moving_cache is None or self._moving_cache[0] != self._changes:
            from vcran.core.sampling import moving_rows

            self._table, idx, rows = moving_rows(self._table, len(self), self.current, self._started)
            self._started.clear()
            self._moving_cache = (self._changes, idx, rows)
        return self._moving_cache[1], self._moving_cache[2]
