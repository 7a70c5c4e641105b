"""A mailbox: SimPy's ``Store`` for the one case the model needs, one reader and puts that never wait.

``simpy.Store`` supports capacities, many readers and blocking puts, and pays for it with a put event and
queue scans on every hand-off. Between vcran's processes every store is unbounded and has exactly one
reader, so a put needs no event: it hands the item to the waiting reader (one scheduled event, exactly
as ``Store`` does) or appends it. Same ``put``/``get``/``items`` interface, same FIFO order, half the
events per signal.

A hand-off schedules its event as ``Event.succeed`` does, written out (the same heap entry as
``Environment.schedule`` makes, like :func:`vcran.sim.timing.at`): eight hand-offs a task, and
``succeed`` and ``schedule`` were two Python calls each (issue 30).
"""

from __future__ import annotations

from collections import deque
from heapq import heappush
from typing import Any

import simpy
from simpy.events import NORMAL, Event

from vcran.sim.timing import triggered


class Mailbox:
    __slots__ = ("env", "items", "_reader")

    def __init__(self, env: simpy.Environment) -> None:
        self.env = env
        self.items: deque[Any] = deque()
        self._reader: Event | None = None

    def put(self, item: Any) -> None:
        reader = self._reader
        if reader is not None:
            self._reader = None
            reader._ok = True  # reader.succeed(item), written out (module docstring)
            reader._value = item
            env = self.env
            heappush(env._queue, (env._now, NORMAL, next(env._eid), reader))  # type: ignore[attr-defined]
        else:
            self.items.append(item)

    def get(self) -> Event:
        if self.items:  # an event succeeded with the first item, scheduled now (module docstring)
            env = self.env
            event = triggered(env, self.items.popleft())
            heappush(env._queue, (env._now, NORMAL, next(env._eid), event))  # type: ignore[attr-defined]
            return event
        if self._reader is not None:
            raise RuntimeError("a Mailbox has one reader; a second get() is waiting already")
        event = self._reader = Event(self.env)
        return event
