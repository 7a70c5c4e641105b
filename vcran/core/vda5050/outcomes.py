"""How each order of a VDA 5050 run ended, read from its event log, order by order: what `vcran report` and
`vcran sweep` count (docs/report.md "VDA 5050 runs").

A vehicle holds one order at a time (§6.6.2, Figure 8): an order is open from the ``order_accepted`` that
opened it (an update of an order that had ended opens it again) to its ``order_ended``. What each event says
about how an order ended is :func:`vcran.core.jobs.order_end`'s, the one definition the loop properties
read too (:func:`vcran.core.jobs.order_unsuccessful`): ``completed``, ``cancelled`` (§6.6.3) or given up by
a halt (``battery_empty``, ``motion_failed``, ``collision``, ``deadlock``); one that ended completed while
one of its own actions FAILED is ``action_failed``; ``order_rejected`` events are the orders and updates
the vehicle refused (§6.6.4).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from vcran.core.jobs import ACTION_FAILED, COMPLETED, REJECTED, order_end

__all__ = ["ACTION_FAILED", "Ended", "Opened", "OrderLog", "order_logs"]


@dataclass(frozen=True, slots=True)
class Opened:
    """An order became current at ``t``."""

    order_id: str
    t: float


@dataclass(frozen=True, slots=True)
class Ended:
    """The current order ended at ``t``: ``outcome`` is ``completed``, ``action_failed`` or how it ended."""

    order_id: str
    t: float
    outcome: str


@dataclass(slots=True)
class OrderLog:
    """One vehicle's orders, fed its events in order (:meth:`feed`)."""

    current: str | None = None
    failed: bool = False
    rejected: int = 0
    ended: list[Ended] = field(default_factory=list)

    def feed(self, event: dict[str, Any]) -> Opened | Ended | None:
        """Take one of the vehicle's events; what it did to the vehicle's orders, if anything."""
        kind, t = event["event"], float(event["t"])
        if kind == "order_accepted" and self.current is None:
            self.current, self.failed = str(event["order_id"]), False
            return Opened(self.current, t)
        end = order_end(event)
        if end is None:
            return None
        if end.how == REJECTED:
            self.rejected += 1
        elif end.how == ACTION_FAILED:
            if end.order_id == self.current:
                self.failed = True
        elif self.current is not None:  # its order_ended: the current order's, whatever id it names
            done = Ended(self.current, t, ACTION_FAILED if end.how == COMPLETED and self.failed else end.how)
            self.current = None
            self.ended.append(done)
            return done
        return None


def order_logs(events: list[dict[str, Any]]) -> dict[str, OrderLog]:
    """Every vehicle's :class:`OrderLog` after the whole run, by robot id (vehicles that logged anything)."""
    logs: dict[str, OrderLog] = {}
    for event in events:
        logs.setdefault(event["robot"], OrderLog()).feed(event)
    return logs
