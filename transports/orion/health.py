"""How live mode reports and paces faults: one log line per distinct cause, capped exponential backoff.

docs/contract.md §7: a fault is logged when it starts and once per distinct cause while it lasts (an Orion that
alternates 404 and dropped connections is two lines, not two a second), and once when Orion is back;
retries back off, and a ``Retry-After`` from Orion or a proxy in front of it is honoured.
"""

from __future__ import annotations

import logging
from time import monotonic

log = logging.getLogger("vcran.orion")

#: Longest ``Retry-After`` obeyed, in seconds: a proxy asking for an hour must not silence a live fleet
#: for an hour (its state is coalesced meanwhile, so waiting less costs Orion one request).
RETRY_AFTER_CAP = 60.0


class Health:
    """The state of one direction (``outbound``, ``inbound``): ok, or down since when and why."""

    def __init__(self, what: str) -> None:
        self.what = what
        self.fault: str | None = None
        self.since = 0.0
        self._causes: set[str] = set()

    def failed(self, message: str, cause: str | None = None) -> None:
        """Record a failure; ``cause`` (default: the message) decides what counts as already said."""
        cause = message if cause is None else cause
        if self.fault is None:
            self.since = monotonic()
        if cause not in self._causes:
            self._causes.add(cause)
            log.warning("%s: %s", self.what, message)
        self.fault = message

    def ok(self, detail: str = "") -> bool:
        """Record a success; True when it ends a fault (Orion is back)."""
        if self.fault is None:
            return False
        log.warning("%s: Orion is back after %.1f s%s", self.what, monotonic() - self.since,
                    f", {detail}" if detail else "")
        self.fault = None
        self._causes.clear()
        return True

    def describe(self) -> str:
        return "ok" if self.fault is None else f"down {monotonic() - self.since:.0f}s"


class Backoff:
    """Delays between retries: ``start``, doubling up to ``cap``; never shorter than a Retry-After."""

    def __init__(self, start: float, cap: float) -> None:
        self.start, self.cap = start, cap
        self.current = start

    def reset(self) -> None:
        self.current = self.start

    def next(self, retry_after: float | None = None) -> float:
        delay = self.current
        self.current = min(self.current * 2, self.cap)
        if retry_after is not None:
            delay = max(delay, min(retry_after, RETRY_AFTER_CAP))
        return delay
