"""The battery model (docs/contract.md §4 Battery): charge as a closed-form function of time, like a pose.

A robot's charge falls linearly with three odometers: simulated time (the base draw, ``per_idle_second``,
drawn always: it is the whole draw of an idle robot), metres driven (``per_metre``) and seconds of action
(``per_action_second``, on top of the base draw); a ``charge`` action adds ``charge_rate``. Between two
changes of what the robot does (a *segment*: a leg, an action, a charge, rest) the charge is therefore

    level(t) = level0 - rate * (t - t0) - per_metre * (distance(t) - distance0)

with ``distance`` the robot's odometer (closed-form along a leg, :mod:`vcran.core.motion`), clamped to
``0 .. capacity``. :class:`FleetBattery` keeps these segment parameters for the whole fleet in numpy arrays,
so the telemetry tick computes every level in one sweep; :func:`leg_empty_after` and
:func:`linear_empty_after` give the exact instant a segment drains the battery, which is when the SimPy
model stops the robot (there is no stepping anywhere).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

from vcran.core.motion import Leg

if TYPE_CHECKING:
    import numpy as np


@dataclass(frozen=True, slots=True)
class BatteryConfig:
    """One robot's battery (scenario ``[robots.battery]``, docs/scenarios.md). Charges in Ah, times in s."""

    capacity: float
    initial: float | None = None  # None: full
    per_metre: float = 0.0
    per_action_second: float = 0.0
    per_idle_second: float = 0.0
    charge_rate: float = 0.0
    #: Below this fraction of capacity a ``battery_low`` warning is reported once per discharge.
    low: float = 0.2
    #: Seconds after running empty until the battery is swapped for a full one (None: never).
    swap_after: float | None = None
    voltage: float = 24.0
    #: Published percentage steps: ``battery_state`` is published when the level crosses one (default 1 %).
    resolution: float = 0.01

    @property
    def start_level(self) -> float:
        return self.capacity if self.initial is None else self.initial


# Segment kinds: what the robot does, which decides the draw.
REST, DRIVE, ACT, CHARGE, EMPTY = range(5)


class FleetBattery:
    """The battery level of every robot that has one, segment by segment (see the module docstring).

    The segment parameters are plain Python lists: the SimPy processes read and write one robot at a time,
    at every leg and action, where a Python float is several times cheaper than a numpy scalar. The
    telemetry tick turns them into arrays once, for the whole fleet (:meth:`levels`). Robots without a
    battery have ``capacity`` NaN and are never reported.
    """

    def __init__(self, configs: list[BatteryConfig | None]) -> None:
        import numpy as np  # a fleet with batteries only: a run without any does not import numpy

        n = len(configs)
        self.configs = configs
        self.indices = np.flatnonzero(np.array([c is not None for c in configs], dtype=bool))
        get = lambda name, default=0.0: [float(getattr(c, name)) if c else default for c in configs]  # noqa: E731
        self.capacity = get("capacity", math.nan)
        self.idle = get("per_idle_second")
        self.level0 = [c.start_level if c else 0.0 for c in configs]
        self.t0 = [0.0] * n
        self.rate = list(self.idle)
        self.k = [0.0] * n  # per_metre while driving, else 0
        self.d0 = [0.0] * n
        self.kind = [REST] * n
        #: ``battery_low`` reported since the last charge or swap.
        self.low_warned = np.zeros(n, dtype=bool)
        #: Charge drawn and charge added, summed over segments (the summary's energy figures).
        self.used = [0.0] * n
        self.added = [0.0] * n
        i = self.indices
        self.capacities = np.array(self.capacity)[i]  # constant: the tick's copy, in ``indices`` order
        self.idles = np.array(self.idle)[i]
        #: The tick's numpy mirror of the segment parameters, brought up to date from the robots whose
        #: segment changed since (``_dirty``): a tick copies a few rows, not five whole lists.
        self._mirror = np.array([self.level0, self.t0, self.rate, self.k, self.d0, self.kind], dtype=np.float64)
        self._dirty: list[int] = []
        self._everyone = len(i) == n

    def level(self, i: int, t: float, distance: float) -> float:
        """Charge of robot ``i`` at ``t`` (within its current segment); ``distance`` = its odometer at ``t``."""
        raw = self.level0[i] - self.rate[i] * (t - self.t0[i]) - self.k[i] * (distance - self.d0[i])
        return min(max(raw, 0.0), self.capacity[i])

    def levels(self, t: float, distances: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Charge of every robot with a battery at ``t``, and its segment kind (as floats), both in
        ``indices`` order."""
        import numpy as np

        m = self._sync()
        if not self._everyone:
            m, distances = m[:, self.indices], distances[self.indices]
        raw = m[0] - m[2] * (t - m[1]) - m[3] * (distances - m[4])
        return np.minimum(np.maximum(raw, 0.0), self.capacities), m[5]

    def _sync(self) -> np.ndarray:
        m = self._mirror
        for i in self._dirty:
            m[:, i] = (self.level0[i], self.t0[i], self.rate[i], self.k[i], self.d0[i], self.kind[i])
        self._dirty.clear()
        return m

    def begin(self, i: int, t: float, distance: float, kind: int) -> float:
        """Start a new segment of ``kind`` for robot ``i`` at ``t``; returns the level it starts with."""
        level = self.level(i, t, distance)
        c = self.configs[i]
        assert c is not None
        delta = self.level0[i] - level
        if delta >= 0.0:
            self.used[i] += delta
        else:
            self.added[i] -= delta
        self.level0[i], self.t0[i], self.d0[i] = level, t, distance
        self.kind[i] = kind
        self._dirty.append(i)
        self.k[i] = c.per_metre if kind == DRIVE else 0.0
        if kind == ACT:
            self.rate[i] = c.per_idle_second + c.per_action_second
        elif kind == CHARGE:
            self.rate[i] = c.per_idle_second - c.charge_rate
        elif kind == EMPTY:
            self.rate[i] = 0.0
        else:
            self.rate[i] = c.per_idle_second
        return level

    def refill(self, i: int, t: float, distance: float) -> None:
        """A swap: a full battery at ``t`` (the robot rests)."""
        self.level0[i], self.t0[i], self.d0[i] = self.capacity[i], t, distance
        self.low_warned[i] = False
        self.begin(i, t, distance, REST)


# --- rules (docs/contract.md §4 Battery): what a robot's body does about its battery -------------------------------------
# Shared by every protocol: the body (vcran.sim.body) asks these and does what they say; what a protocol tells
# its fleet manager about it (OPIL: a cancelled task, a ran_error; VDA 5050: errors in its state) is the protocol's.

#: The code of an empty battery's stop (and the reason a protocol gives for the work it ends).
EMPTY_CODE = "battery_empty"


def leg_cut(c: BatteryConfig, leg: Leg, level: float, now: float) -> float:
    """Seconds from ``now`` until a battery holding ``level`` now runs out driving ``leg`` (inf: not before
    the leg ends). The common case, a leg that costs less than what is left, needs no root."""
    if c.per_idle_second * leg.duration + c.per_metre * leg.distance < level:
        return math.inf
    tau = max(now - leg.t0, 0.0)
    done = c.per_idle_second * tau + c.per_metre * leg.distance_at(now)
    return leg_empty_after(leg, level + done, c.per_idle_second, c.per_metre) - tau


def charge_time(c: BatteryConfig, level: float) -> float:
    """Seconds a charge takes from ``level`` to full: it ends when the battery is full (inf: never, the
    charge rate does not exceed the base draw)."""
    return linear_full_after(level, c.capacity, c.charge_rate - c.per_idle_second)


def charge_refusal(has_battery: bool, charger_in_reach: bool, seconds: float, x: float, y: float) -> tuple[str, str] | None:
    """Why a charge at ``(x, y)`` cannot start (code, message), or None: it fails at once, not after a duration
    (R14), without a battery, without a charger in reach, or when it would never end (``seconds`` inf)."""
    if not has_battery:
        return "action_not_capable", "charge: this robot has no battery"
    if not charger_in_reach:
        return "no_charger_in_reach", f"charge: no charger in reach at {x:.3f}, {y:.3f}"
    if seconds == math.inf:
        return "charge_too_slow", "charge: charge_rate does not exceed the idle draw"
    return None


def empty_stop(c: BatteryConfig, x: float, y: float) -> tuple[str, float | None]:
    """An empty battery stops the robot where it is, out of service until a swap: the stop's message, and
    the seconds until the swap gives it a full battery and service again (None: never)."""
    return f"battery empty at {x:.3f}, {y:.3f}: the robot stopped [§4]", c.swap_after


def linear_empty_after(level: float, rate: float) -> float:
    """Seconds until ``level`` drains at ``rate`` per second (inf when it never does)."""
    if level <= 0.0:
        return 0.0
    return level / rate if rate > 0.0 else math.inf


def linear_full_after(level: float, capacity: float, gain: float) -> float:
    """Seconds until ``level`` reaches ``capacity`` gaining ``gain`` per second (inf when it never does)."""
    if level >= capacity:
        return 0.0
    return (capacity - level) / gain if gain > 0.0 else math.inf


def leg_empty_after(leg: Leg, level: float, idle: float, per_metre: float) -> float:
    """Seconds after the leg's start at which ``idle * tau + per_metre * s(tau)`` reaches ``level``
    (``s`` the leg's distance profile), or inf if the leg ends first. Exact, phase by phase: the profile is
    piecewise quadratic (turn, accelerate, cruise, brake, turn), so each phase is one quadratic root."""
    if level <= 0.0:
        return 0.0
    if idle <= 0.0 and per_metre <= 0.0:
        return math.inf
    t1, ta, td, tdr, peak, dist = leg.t_turn1, leg.t_acc, leg.t_dec, leg.t_drive, leg.peak, leg.distance
    # Phase 1: turning in place, s = 0.
    if idle * t1 >= level:
        return level / idle
    # Phase 2a: accelerating, d in [0, ta]: idle*(t1+d) + k*0.5*peak/ta*d^2 = level.
    if ta > 0.0:
        a = per_metre * 0.5 * peak / ta
        d = _root(a, idle, idle * t1 - level, 0.0, ta)
        if d is not None:
            return t1 + d
    # Phase 2b: cruising, d in [ta, tdr - td]: s = 0.5*peak*ta + peak*(d - ta).
    lo, hi = ta, tdr - td
    if hi > lo:
        s0 = 0.5 * peak * ta
        d = _root(0.0, idle + per_metre * peak, idle * t1 + per_metre * (s0 - peak * ta) - level, lo, hi)
        if d is not None:
            return t1 + d
    # Phase 2c: braking, rest = tdr - d in [0, td]: s = dist - 0.5*peak/td*rest^2.
    if td > 0.0:
        a = per_metre * 0.5 * peak / td
        # idle*(t1 + tdr - rest) + k*dist - a*rest^2 = level  ->  a*rest^2 + idle*rest + (level - idle*(t1+tdr) - k*dist) = 0
        rest = _root(a, idle, level - idle * (t1 + tdr) - per_metre * dist, 0.0, td, largest=True)
        if rest is not None:
            return t1 + tdr - rest
    # Phase 3: the final turn, s = dist.
    left = level - per_metre * dist - idle * (t1 + tdr)
    if idle > 0.0 and left < idle * leg.t_turn2:
        return t1 + tdr + max(left, 0.0) / idle
    return math.inf


def _root(a: float, b: float, c: float, lo: float, hi: float, largest: bool = False) -> float | None:
    """The root of ``a x^2 + b x + c`` in ``[lo, hi]`` (the one the caller's monotone phase crosses)."""
    if a == 0.0:
        if b == 0.0:
            return None
        x = -c / b
    else:
        disc = b * b - 4.0 * a * c
        if disc < 0.0:
            return None
        sq = math.sqrt(disc)
        roots = sorted(((-b - sq) / (2.0 * a), (-b + sq) / (2.0 * a)))
        inside = [r for r in roots if lo - 1e-12 <= r <= hi + 1e-12]
        if not inside:
            return None
        x = inside[-1] if largest else inside[0]
    if not lo - 1e-12 <= x <= hi + 1e-12:
        return None
    return min(max(x, lo), hi)
