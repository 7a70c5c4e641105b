"""Real time for live mode: SimPy's RealtimeEnvironment that other threads can wake (docs/contract.md §7).

``simpy.rt.RealtimeEnvironment`` sleeps in the calling thread until the next event is due. In live mode,
inbound messages arrive on HTTP threads (the notification listener, the poller) at any moment; waiting
for the next scheduled event to notice them would add up to a telemetry period of latency. This
environment replaces the sleep with a wait on a ``threading.Event``: a worker thread hands over a
callable with :meth:`call_soon`, which wakes the loop at once; the loop schedules an event at the
simulated time that corresponds to that wall-clock instant, and the callable runs inside the simulation
thread when that event is processed. So:

* HTTP never runs in the simulation thread, and the simulation thread never blocks on HTTP;
* every inbound message is stamped with the simulated time at which it entered, which is what the trace
  records and what a replay reproduces;
* the only cross-thread state is a lock-free queue and an event.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from queue import Empty, SimpleQueue
from time import monotonic
from typing import Any

import simpy.core
import simpy.events
from simpy.rt import RealtimeEnvironment

from vcran.sim.timing import INBOUND, at

#: Longest uninterrupted wait; bounds how late a stop request from a signal handler is noticed.
MAX_WAIT = 0.25


class LiveEnvironment(RealtimeEnvironment):
    """``speed`` simulated seconds pass per wall second (``vcran live --factor``)."""

    def __init__(self, speed: float = 1.0) -> None:
        if not speed > 0:
            raise ValueError(f"speed factor must be positive, got {speed}")
        super().__init__(0.0, factor=1.0 / speed, strict=False)
        self.speed = speed
        self._calls: SimpleQueue[Callable[[], Any]] = SimpleQueue()
        self._wake = threading.Event()

    def call_soon(self, fn: Callable[[], Any]) -> None:
        """Run ``fn()`` in the simulation thread at the simulated time of this wall-clock instant.

        Thread-safe; calls keep their order. From a signal handler use :meth:`call_from_signal`.
        """
        self._calls.put(fn)
        self._wake.set()

    def call_from_signal(self, fn: Callable[[], Any]) -> None:
        """Like :meth:`call_soon`, for signal handlers: only the reentrant ``SimpleQueue.put``, no lock
        (an Event's lock could be held by the interrupted thread); the loop notices within ``MAX_WAIT``."""
        self._calls.put(fn)

    def wall_now(self) -> float:
        """The simulated time that corresponds to the wall clock now (never before ``self.now``)."""
        return max(self.now, self.env_start + (monotonic() - self.real_start) / self.factor)

    def run(self, until: Any = None) -> Any:
        self.sync()  # building a large fleet takes time; simulated time 0 is "now"
        return super().run(until)

    def step(self) -> None:
        while True:
            self._drain()
            evt_time = self.peek()
            if evt_time == simpy.core.Infinity:
                raise simpy.core.EmptySchedule
            delta = self.real_start + (evt_time - self.env_start) * self.factor - monotonic()
            if delta <= 0:
                break
            if self._wake.wait(min(delta, MAX_WAIT)):
                self._wake.clear()
        simpy.core.Environment.step(self)

    def _drain(self) -> None:
        while True:
            try:
                fn = self._calls.get_nowait()
            except Empty:
                return
            at(self, self.wall_now(), INBOUND).callbacks.append(_runner(fn))


def _runner(fn: Callable[[], Any]) -> Callable[[simpy.events.Event], None]:
    """An event callback that calls ``fn`` (a closure per call: a lambda in a loop would share ``fn``)."""
    return lambda _event: fn()
