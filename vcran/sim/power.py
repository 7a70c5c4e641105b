"""The battery at the telemetry cadence (SPEC §4): ``battery`` publications, the low warning, idle drain.

Levels come from :class:`vcran.core.battery.FleetBattery` in one numpy sweep per tick. ``battery``
(``sensor_msgs.BatteryState``) is published for a robot when its percentage, rounded to the battery's
``resolution``, or its charging status changed since its last publication: a thousand robots do not put a
thousand messages per second on the wire. A robot at rest whose battery would run out before the tick
after next is handed to :meth:`RobotNode.watch_idle`, which schedules the exact instant.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from vcran.core.battery import CHARGE, REST, FleetBattery
from vcran.core.incidents import BatteryLow
from vcran.core.messages import BatteryState, Header, Message, Time
from vcran.sim.robot import RobotNode

_STATUS = np.array([BatteryState.STATUS_DISCHARGING] * 5, dtype=np.int64)
_STATUS[CHARGE] = BatteryState.STATUS_CHARGING


class Power:
    def __init__(
        self, robots: list[RobotNode], battery: FleetBattery, period: float,
        publish: Callable[[float, RobotNode, str, Message], None],
    ) -> None:
        self.robots, self.battery, self.period, self._publish = robots, battery, period, publish
        idx = battery.indices
        configs = [battery.configs[i] for i in idx]
        self.resolution = np.array([c.resolution for c in configs if c is not None])
        self.low = np.array([c.low * c.capacity for c in configs if c is not None])
        self.voltage = [c.voltage for c in configs if c is not None]
        self.last = np.full(len(idx), -1, dtype=np.int64)
        self.fleet = robots[0].fleet

    def tick(self, t: float) -> None:
        b = self.battery
        idx = b.indices
        levels = b.levels(t, self.fleet.distances(t))
        cap = b.capacity[idx]
        steps = np.round(levels / cap / self.resolution).astype(np.int64)
        kinds = b.kind[idx]
        status = np.where(levels >= cap, BatteryState.STATUS_FULL, _STATUS[kinds])
        key = steps * 8 + status
        for j in np.flatnonzero(key != self.last):
            i = int(idx[j])
            robot = self.robots[i]
            pct = round(float(steps[j] * self.resolution[j]), 9)  # 0.47, not 0.47000000000000003
            c = float(cap[j])
            self._publish(t, robot, "battery", BatteryState(
                header=Header(0, Time.from_seconds(t), ""), voltage=self.voltage[j], charge=round(pct * c, 9), capacity=c,
                design_capacity=c, percentage=pct, power_supply_status=int(status[j]), present=True,
            ))
        self.last = key
        for j in np.flatnonzero((levels < self.low) & ~b.low_warned[idx] & (kinds != CHARGE)):
            i = int(idx[j])
            b.low_warned[i] = True
            robot = self.robots[i]
            level, pct = float(levels[j]), float(levels[j] / cap[j])
            robot.log_incident(BatteryLow(level, pct))
            robot.report("battery_low", f"battery at {pct:.1%} ({level:.3f} Ah), below its low level [§4]")
        soon = (kinds == REST) & (levels - b.idle[idx] * 2.0 * self.period <= 0.0)
        for j in np.flatnonzero(soon):
            self.robots[int(idx[j])].watch_idle()
