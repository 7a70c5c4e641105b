"""A VDA 5050 run in a report (docs/report.md "VDA 5050 runs"): orders as the unit of work.

The figures and the KPI table are the same code for both protocols; this module is the part that reads
what is VDA 5050's. A vehicle holds one order at a time (§6.6.2, Figure 8), so an order's life is simple:
it is *current* from the ``order_accepted`` that opened it (not an update) to its ``order_ended``, which says
how it ended (``completed``, ``cancelled``, or the docs/contract.md §4/§12 halt that gave it up). An order
that ended ``completed`` but one of whose own actions (sent in an ``order``, not an instant action)
ended FAILED is reported as ``action_failed``, OPIL's name for a task lost to a failed action: a failed
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

from vcran.io.trace import records
from vcran.report.spans import Band, History, TaskSpan

if TYPE_CHECKING:
    from vcran.report.folder import Run

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
    #: The actionIds the vehicle was sent in orders (an order's actions, as against instant actions).
    order_actions: dict[str, set[str]] = field(default_factory=dict)
    #: (t, ``batteryState.batteryCharge``) for the robots that have a battery (docs/contract.md §4).
    batteries: dict[str, list[tuple[float, float]]] = field(default_factory=dict)


def read_trace(path: Path, with_battery: set[str]) -> VdaTrace:
    """The trace's ``state`` and inbound ``order`` records; KeyError/TypeError on a record that is none."""
    out = VdaTrace()
    for _, record in records(path, attrs=("state", "order")):
        robot, message, t = record["robot"], record.get("raw"), float(record["t"])
        if not isinstance(message, dict):
            continue
        if record["attr"] == "order" and record.get("dir") == "in":
            ids = out.order_actions.setdefault(robot, set())
            for element in (*message.get("nodes", ()), *message.get("edges", ())):
                ids.update(a["actionId"] for a in element.get("actions", ()) if isinstance(a, dict) and "actionId" in a)
        elif record["attr"] == "state" and record.get("dir") == "out":
            position = message.get("agvPosition")
            if position is not None:
                out.points.setdefault(robot, []).append((t, float(position["x"]), float(position["y"])))
            acting = any(a["actionStatus"] in ACTING for a in message["actionStates"])
            out.motion.setdefault(robot, []).append((t, bool(message["driving"]), acting))
            if robot in with_battery:
                out.batteries.setdefault(robot, []).append((t, float(message["batteryState"]["batteryCharge"])))
    return out


def order_histories(run: Run) -> dict[str, History]:
    """Every vehicle's state bands and orders (module docstring), robots in fleet order."""
    assert run.vda is not None
    builders = {rid: _Orders(rid, run.vda.order_actions.get(rid, set())) for rid in run.robot_ids}
    for t, robot, kind, item in _merged(run):
        builder = builders.get(robot)
        if builder is not None:
            builder.feed(t, kind, item)
    return {rid: b.finish(run.sim_time) for rid, b in builders.items()}


def _merged(run: Run) -> Iterator[tuple[float, str, str, Any]]:
    """The events and the published states' (driving, acting), in time order, events first at a tie."""
    assert run.vda is not None
    items: list[tuple[float, int, str, str, Any]] = [
        (float(e["t"]), 0, e["robot"], e["event"], e) for e in run.events]
    items += [(t, 1, robot, "state", (driving, acting))
              for robot, seen in run.vda.motion.items() for t, driving, acting in seen]
    items.sort(key=lambda item: (item[0], item[1]))
    for t, _, robot, kind, item in items:
        yield t, robot, kind, item


class _Orders:
    def __init__(self, robot: str, order_actions: set[str]) -> None:
        self.history = History(robot, idle=IDLE)
        self.order_actions = order_actions
        self.current: TaskSpan | None = None
        self.failed = False
        self.driving = self.acting = False
        self.state, self.since = IDLE, 0.0

    def feed(self, t: float, kind: str, item: Any) -> None:
        if kind == "state":
            self.driving, self.acting = item
        elif kind == "order_accepted":
            if self.current is None:  # a new order, or an update of one that had ended (§6.6.2)
                self.current = TaskSpan(self.history.robot, str(item["order_id"]), t, t)
                self.failed = False
                self.history.tasks.append(self.current)
        elif kind == "order_ended" and self.current is not None:
            how = str(item["how"])
            self.current.end = t
            self.current.outcome = "action_failed" if how == "completed" and self.failed else how
            self.current = None
        elif kind == "action_changed" and self.current is not None:
            if item.get("status") == "FAILED" and item.get("action_id") in self.order_actions:
                self.failed = True
        elif kind == "order_rejected":
            self.history.rejected += 1
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
