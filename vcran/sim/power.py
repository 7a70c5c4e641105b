"""The battery at the telemetry cadence (docs/contract.md §4): which levels to publish, the low warning, idle drain.

Levels come from :class:`vcran.core.battery.FleetBattery` in one numpy sweep per tick. A robot's level is
published when its percentage, rounded to the battery's ``resolution``, changed, or a charge started or ended,
since its last publication: a thousand robots do not put a thousand messages per second on the wire. How it is
published is the protocol's (OPIL: ``battery_state``, a ``sensor_msgs.BatteryState``): the tick hands it the
rows that changed. A robot at rest whose battery would run out before the tick after next is handed to
:meth:`~vcran.sim.energy.Energy.watch_idle`, which schedules the exact instant. A robot whose protocol clears
the low warning (its ``battery_restored`` hook is set: VDA 5050's batteryLow) is told at the first tick that
finds its battery, once warned of, at or above the low level again; it can then be warned of again.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from vcran.core.battery import CHARGE, REST, FleetBattery
from vcran.core.incidents import BatteryLow
from vcran.sim.body import Body

#: One robot's level to publish: the body, the percentage (rounded to its resolution), the charge in Ah (the
#: percentage's), the capacity, the level itself (FULL at capacity), whether it is charging, the voltage.
Level = tuple[Body, float, float, float, float, bool, float]


class Power:
    def __init__(
        self, robots: list[Body], battery: FleetBattery, period: float,
        publish: Callable[[float, list[Level]], None],
    ) -> None:
        self.robots, self.battery, self.period, self._publish = robots, battery, period, publish
        configs = [c for c in (battery.configs[i] for i in battery.indices) if c is not None]
        self.resolution = [c.resolution for c in configs]
        #: Steps per Ah (1 / (capacity * resolution)); the low level and the "empty within two ticks"
        #: level of each robot, all in ``indices`` order.
        self.per_step = np.array([1.0 / (c.capacity * c.resolution) for c in configs])
        self.low = np.array([c.low * c.capacity for c in configs])
        self.soon = np.array([c.per_idle_second * 2.0 * period for c in configs])
        self.voltage = [c.voltage for c in configs]
        self.last = np.full(len(configs), -1.0)
        self.fleet = robots[0].fleet
        #: Robots (``indices`` order) whose protocol hears the battery restored, and those warned of since; None
        #: when none does (OPIL), and the tick is what it was.
        watched = [robots[int(i)].battery_restored is not None for i in battery.indices]
        self.watched = np.array(watched) if any(watched) else None
        self.restoring = np.zeros(len(configs), dtype=bool)

    def tick(self, t: float) -> None:
        """Publish what changed, warn of low batteries, watch resting ones about to run out.

        A robot's level is published when its percentage step changes or a charge starts or ends. A tick is a
        handful of numpy operations for the whole fleet; Python work is only for the robots in question.
        """
        b = self.battery
        idx = b.indices
        levels, kinds = b.levels(t, self.fleet.distances(t))
        steps = np.rint(levels * self.per_step)
        key = steps * 2.0 + (kinds == CHARGE)
        changed = np.flatnonzero(key != self.last)
        self.last = key
        if len(changed):
            self._publish(t, [self._level(int(idx[j]), int(j), int(steps[j]), float(levels[j]), int(kinds[j]))
                              for j in changed])
        for j in np.flatnonzero(levels < self.low):
            i = int(idx[j])
            if not b.low_warned[i] and kinds[j] != CHARGE:
                b.low_warned[i] = True
                robot = self.robots[i]
                level, pct = float(levels[j]), float(levels[j]) / b.capacity[i]
                robot.log_incident(BatteryLow(level, pct))
                robot.report("battery_low", f"battery at {pct:.1%} ({level:.3f} Ah), below its low level [§4]")
                if self.watched is not None and self.watched[j]:
                    self.restoring[j] = True
        if self.watched is not None:
            for j in np.flatnonzero(self.restoring & (levels >= self.low)):
                self.restoring[j] = False
                i = int(idx[j])
                b.low_warned[i] = False  # the next discharge below the low level is warned of again
                hook = self.robots[i].battery_restored
                assert hook is not None
                hook()
        for j in np.flatnonzero(levels <= self.soon):
            if kinds[j] == REST:
                self.robots[int(idx[j])].watch_idle()

    def _level(self, i: int, j: int, steps: int, level: float, kind: int) -> Level:
        capacity = self.battery.capacity[i]
        pct = round(steps * self.resolution[j], 9)  # 0.47, not 0.47000000000000003
        return self.robots[i], pct, round(pct * capacity, 9), capacity, level, kind == CHARGE, self.voltage[j]
