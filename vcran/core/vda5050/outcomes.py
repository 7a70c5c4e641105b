"""How each order of a VDA 5050 run ended, read from its event log: the one definition `vcran report` and
`vcran sweep` share (docs/report.md "VDA 5050 runs").

A vehicle holds one order at a time (§6.6.2, Figure 8): an order is open from the ``order_accepted`` that
opened it (an update of an order that had ended opens it again) to its ``order_ended``. It ended
``completed``, ``cancelled`` (§6.6.3) or given up by a halt (``battery_empty``, ``motion_failed``,
``collision``, ``deadlock``); one that ended completed while one of its own actions FAILED is
``action_failed``: the vehicle raised an ``actionFailed`` error naming the order (its ``orderId`` reference,
which only an order's action has; an instant action's failure names none). ``order_rejected`` events are
the orders and updates the vehicle refused (§6.6.4).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

ACTION_FAILED = "action_failed"


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
        if kind == "order_ended" and self.current is not None:
            how = str(event["how"])
            done = Ended(self.current, t, ACTION_FAILED if how == "completed" and self.failed else how)
            self.current = None
            self.ended.append(done)
            return done
        if kind == "error_raised" and self.current is not None and _names_failed_action(event.get("error"), self.current):
            self.failed = True
        elif kind == "order_rejected":
            self.rejected += 1
        return None


def _names_failed_action(error: Any, order_id: str) -> bool:
    if not isinstance(error, dict) or error.get("errorType") != "actionFailed":
        return False
    return any(r.get("referenceKey") == "orderId" and r.get("referenceValue") == order_id
               for r in error.get("errorReferences") or () if isinstance(r, dict))


def order_logs(events: list[dict[str, Any]]) -> dict[str, OrderLog]:
    """Every vehicle's :class:`OrderLog` after the whole run, by robot id (vehicles that logged anything)."""
    logs: dict[str, OrderLog] = {}
    for event in events:
        logs.setdefault(event["robot"], OrderLog()).feed(event)
    return logs
