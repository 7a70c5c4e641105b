"""The body's battery in simulated time (docs/contract.md §4 Battery): segments, the instant it runs out, the swap.

Every change of what the body does (a leg, an action, a charge, rest) begins a battery segment of the fleet's
:class:`~vcran.core.battery.FleetBattery`, which the telemetry tick reads for the whole fleet at once
(:mod:`vcran.sim.power`). What happens is decided by the rules of :mod:`vcran.core.battery` (when a leg or a
rest drains the battery, how long a charge takes, what an empty battery does); this module carries them out:
a work's wait is cut at the exact instant the battery runs out, the robot halts out of service
(:class:`~vcran.sim.holds.Halted` ``battery_empty``), and a swap, if the scenario has one, puts it back in
service (:class:`~vcran.sim.holds.InService`).

A mixin of :class:`vcran.sim.body.Body`, like :mod:`vcran.sim.holds`.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import simpy

from vcran.core.battery import EMPTY, REST, FleetBattery, charge_time, empty_stop, linear_empty_after
from vcran.core.incidents import BatteryEmpty, BatterySwapped
from vcran.core.motion import FleetKinematics
from vcran.core.scenario import RobotConfig
from vcran.sim.holds import BATTERY_EMPTY, Halted, InService
from vcran.sim.timing import COMPLETION, FAULT, after, at


class Energy:
    """The body's battery (module docstring). ``battery`` is None for a robot without one."""

    env: simpy.Environment
    index: int
    config: RobotConfig
    fleet: FleetKinematics
    pose: tuple[float, float, float]
    battery: FleetBattery | None
    tell: Callable[[object], None]
    log: Callable[[Any, Any], None]
    _worker: Any
    beside: dict[Any, Any]
    _beside_all: Callable[[object], None]

    def _init_energy(self, battery: FleetBattery | None) -> None:
        self.battery = battery if battery is not None and self.config.battery is not None else None
        self.empty = False
        self._idle_check: simpy.events.Event | None = None
        #: How far ahead the power tick looks for a resting battery running out (2 telemetry periods).
        self.idle_horizon = 2.0
        #: Called by the power tick when a battery it warned of is back at or above its low level (a charge,
        #: a swap), for a protocol whose logic clears the warning (VDA 5050's batteryLow); None: not watched.
        self.battery_restored: Callable[[], None] | None = None

    def _segment(self, kind: int) -> float | None:
        """Begin a battery segment of ``kind`` now; returns the level it starts with (None: no battery)."""
        if self.battery is None or self.empty:
            return None
        t = self.env.now
        level = self.battery.begin(self.index, t, self.fleet.distance(self.index, t), kind)
        if kind == REST and level <= self.battery.idle[self.index] * self.idle_horizon:
            self.watch_idle()  # may run out before the power tick would notice
        return level

    def charge(self) -> float | None:
        """The battery's charge now, in Ah (None: this robot has no battery)."""
        return None if self.battery is None else self._level()

    def _level(self) -> float:
        b = self.battery
        assert b is not None
        t = self.env.now
        return b.level(self.index, t, self.fleet.distance(self.index, t))

    def _rate(self) -> float:
        assert self.battery is not None
        return self.battery.rate[self.index]

    def _charge_time(self) -> float:
        c = self.config.battery
        assert c is not None
        return charge_time(c, self._level())

    def _charged(self) -> None:
        assert self.battery is not None
        self.battery.low_warned[self.index] = False

    def _battery_empty_halt(self) -> Halted:
        """The battery just ran out (a work's cut fired): stop, out of service; swap if the scenario says."""
        self.empty = True
        assert self.battery is not None
        self.battery.begin(self.index, self.env.now, self.fleet.distance(self.index, self.env.now), EMPTY)
        x, y = self.position()
        self.log(self, BatteryEmpty(x, y))
        c = self.config.battery
        assert c is not None
        message, swap_after = empty_stop(c, x, y)
        if swap_after is not None:
            at(self.env, self.env.now + swap_after, FAULT).callbacks.append(lambda _: self._swap())
        halted = Halted(BATTERY_EMPTY, message, True)
        if self.beside:
            self._beside_all(halted)
        return halted

    def position(self) -> tuple[float, float]:
        """Where the robot is now (on its running leg, or at rest)."""
        if self.index in self.fleet.current:
            x, y, _, _, _ = self.fleet.current[self.index].pose_at(self.env.now)
            return x, y
        return self.pose[0], self.pose[1]

    def idle_empty(self) -> None:
        """The battery of this robot, at rest, is due to run out now (scheduled by :meth:`watch_idle`)."""
        self._idle_check = None
        if self.empty or self._worker is not None or self.battery is None or self._level() > 0.0:
            return
        self.tell(self._battery_empty_halt())

    def watch_idle(self) -> None:
        """Schedule :meth:`idle_empty` at the instant the resting battery runs out, once."""
        if self._idle_check is not None or self.empty or self._worker is not None or self.battery is None:
            return
        cut = linear_empty_after(self._level(), self._rate())
        if cut != float("inf"):
            self._idle_check = after(self.env, cut, COMPLETION)
            self._idle_check.callbacks.append(lambda _: self.idle_empty())

    def _swap(self) -> None:
        assert self.battery is not None
        t = self.env.now
        self.empty = False
        self.battery.refill(self.index, t, self.fleet.distance(self.index, t))
        self.log(self, BatterySwapped())
        self.tell(InService())
