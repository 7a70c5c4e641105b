"""The loops of live mode's worker threads: reading Orion at a period, and a worker that outlives a bug.

The threads of the Orion link (:mod:`transports.orion.link`), which ``vcran live`` and ``vcran manage``
share, so both pace their reads and ride out an Orion that is down the same way (docs/contract.md §7; docs/live.md,
"Faults").
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable
from time import monotonic

from transports.orion.client import OrionError
from transports.orion.health import Backoff, Health

log = logging.getLogger("vcran.orion")

#: Longest single wait: ``Event.wait`` overflows past ``threading.TIMEOUT_MAX`` (about 292 years here, but
#: a --poll-interval of 1e12 simulated seconds, or a --factor of 1e-12, asks for more).
LONGEST_WAIT = 3600.0


def poll(read: Callable[[], None], period: float, health: Health, stop: threading.Event, backoff_start: float,
         backoff_cap: float, on_back: Callable[[], None] = lambda: None, *, first: float = 0.0) -> None:
    """Call ``read()`` every ``period`` wall seconds (the first time after ``first``) until ``stop`` is set.

    A read that takes longer than the period delays the next one, with no burst to catch up. A read
    that raises :class:`OrionError` is logged once per fault (``health``) and retried with capped
    backoff, never sooner than the period nor than a ``Retry-After``; ``on_back()`` runs when a read
    succeeds after a fault (Orion is back)."""
    backoff = Backoff(max(period, backoff_start), max(period, backoff_cap))
    next_poll = monotonic() + first
    while True:
        due = next_poll - monotonic()
        if stop.wait(min(max(0.0, due), LONGEST_WAIT)):
            return
        if due > LONGEST_WAIT:
            continue  # not due yet: waited in pieces (a poll period of 1e12 s is valid, and no wait can be that long)
        try:
            read()
        except OrionError as exc:
            health.failed(f"{exc}; retrying with backoff")
            next_poll = monotonic() + backoff.next(exc.retry_after)
        else:
            backoff.reset()
            if health.ok():
                on_back()
            next_poll = max(next_poll + period, monotonic())


def resilient(name: str, loop: Callable[[], None], stop: threading.Event) -> Callable[[], None]:
    """Run a worker loop; an unexpected error is logged and the loop restarted, never silently lost."""

    def run() -> None:
        while not stop.is_set():
            try:
                loop()
                return
            except Exception:  # noqa: BLE001 - a worker must outlive a bug in one iteration
                log.exception("%s: unexpected error; restarting the loop", name)
                stop.wait(1.0)

    return run
