"""A VDA 5050 run in a report (docs/report.md "VDA 5050 runs"): orders as the unit of work.

The figures and the KPI table are the same code for both protocols; this module is the part that reads
what is VDA 5050's. How each order ended is :mod:`vcran.core.vda5050.outcomes`' (shared with `vcran sweep`):
an order is current from its acceptance to its end, and one that ended ``completed`` while one of its own
actions FAILED is reported as ``action_failed``, OPIL's name for a task lost to a failed action: a failed
pick completes a VDA 5050 order (the vehicle drives on, §6.11), it moves no part.

The state lane comes from two sources at once: the events say whether an order is open, the trace's
``state`` messages (published on every change of ``driving`` and ``actionStates``, §6.10) whether the
vehicle drives (DRIVING, whatever runs meanwhile: a NONE action, a cancelOrder waiting for the next node)
or stands performing an action (ACTION), or stands with an order (ORDER). Without an open order the vehicle is IDLE whatever it does (an
instant startCharging is not work), so busy time is the glue's: order accepted to order ended.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from vcran.core.vda5050.outcomes import Ended, Opened, OrderLog
from vcran.io.trace import records
from vcran.report.spans import Band, History, TaskSpan

if TYPE_CHECKING:
    from vcran.report.spans import Happenings

PROTOCOL = "vda5050"
IDLE, ORDER, DRIVING, ACTION = "IDLE", "ORDER", "DRIVING", "ACTION"
#: The state lane's states, least busy first (the timeline's greys).
STATES = (IDLE, ORDER, DRIVING, ACTION)
#: actionStates statuses in which the vehicle performs an action (§6.11).
ACTING = ("INITIALIZING", "RUNNING")


@dataclass
class VdaTrace:
    """What a report needs of a VDA 5050 run's trace, read in one pass; robots by id."""

    #: (t, x, y) of every published state's ``agvPosition``: points the vehicle was exactly at.
    points: dict[str, list[tuple[float, float, float]]] = field(default_factory=dict)
    #: (t, driving, acting) of every published state.
    motion: dict[str, list[tuple[float, bool, bool]]] = field(default_factory=dict)
    #: (t, ``batteryState.batteryCharge``) for the robots that have a battery (docs/contract.md §4).
    batteries: dict[str, list[tuple[float, float]]] = field(default_factory=dict)


def read_trace(path: Path, with_battery: set[str]) -> VdaTrace:
    """The trace's published ``state`` records; KeyError/TypeError on a record that is none."""
    out = VdaTrace()
    for _, record in records(path, dirs=("out",), attrs=("state",)):
        robot, message, t = record["robot"], record.get("raw"), float(record["t"])
        if isinstance(message, dict):
            position = message.get("agvPosition")
            if position is not None:
                out.points.setdefault(robot, []).append((t, float(position["x"]), float(position["y"])))
            acting = any(a["actionStatus"] in ACTING for a in message["actionStates"])
            out.motion.setdefault(robot, []).append((t, bool(message["driving"]), acting))
            if robot in with_battery:
                out.batteries.setdefault(robot, []).append((t, float(message["batteryState"]["batteryCharge"])))
    return out


def order_histories(run: Happenings) -> dict[str, History]:
    """Every vehicle's state bands and orders (module docstring), robots in fleet order. Without a trace (a
    ``vcran manage --mqtt`` folder: the orders the master heard, :mod:`vcran.report.managed`) a vehicle with
    an order is in ORDER, neither DRIVING nor ACTION: its busy time is the same."""
    builders = {rid: _Orders(rid) for rid in run.robot_ids}
    for t, robot, kind, item in _merged(run):
        builder = builders.get(robot)
        if builder is not None:
            builder.feed(t, kind, item)
    return {rid: b.finish(run.sim_time) for rid, b in builders.items()}


def _merged(run: Happenings) -> Iterator[tuple[float, str, str, Any]]:
    """The events and the published states' (driving, acting), in time order, events first at a tie."""
    vda: VdaTrace | None = getattr(run, "vda", None)  # a run folder's; a managed folder has no trace
    items: list[tuple[float, int, str, str, Any]] = [
        (float(e["t"]), 0, e["robot"], e["event"], e) for e in run.events]
    items += [(t, 1, robot, "state", (driving, acting))
              for robot, seen in (vda.motion if vda is not None else {}).items() for t, driving, acting in seen]
    items.sort(key=lambda item: (item[0], item[1]))
    for t, _, robot, kind, item in items:
        yield t, robot, kind, item


class _Orders:
    def __init__(self, robot: str) -> None:
        self.history = History(robot, idle=IDLE)
        self.orders = OrderLog()
        self.current: TaskSpan | None = None
        self.driving = self.acting = False
        self.state, self.since = IDLE, 0.0

    def feed(self, t: float, kind: str, item: Any) -> None:
        if kind == "state":
            self.driving, self.acting = item
        else:
            change = self.orders.feed(item)
            if isinstance(change, Opened):
                self.current = TaskSpan(self.history.robot, change.order_id, t, t)
                self.history.tasks.append(self.current)
            elif isinstance(change, Ended) and self.current is not None:
                self.current.end, self.current.outcome = t, change.outcome
                self.current = None
            self.history.rejected = self.orders.rejected
        self._to(t, self._now())

    def _now(self) -> str:
        if self.current is None:
            return IDLE
        return DRIVING if self.driving else ACTION if self.acting else ORDER

    def _to(self, t: float, state: str) -> None:
        if state != self.state:
            self._band_until(t)
            self.state, self.since = state, t

    def _band_until(self, t: float) -> None:
        """Close the running band at ``t``; a state left and entered again at one instant goes on."""
        bands = self.history.bands
        if t <= self.since:
            return
        if bands and bands[-1].state == self.state and bands[-1].end == self.since:
            bands[-1] = Band(self.state, bands[-1].start, t)
        else:
            bands.append(Band(self.state, self.since, t))

    def finish(self, end: float) -> History:
        self._band_until(end)
        if self.current is not None:
            self.current.end = end
        return self.history
