"""A minimal body for :class:`vcran.core.traffic.control.Traffic` in the tests: what the SimPy integration
will do, in a plain event loop (a heap of instants), so that the pure traffic logic is tested end to end.

Each robot drives the legs it is given; a ``Brake`` ends the running leg (its arrival is dropped) and a
``DriveOn`` gives the leg whose end completes the motion. The log holds ``(t, what, robot, detail)``.
"""

from __future__ import annotations

import heapq
import itertools
from collections.abc import Callable
from typing import Any

from vcran.core.motion import Leg
from vcran.core.traffic.control import (
    BRAKED,
    BlockedBy,
    Brake,
    Deadlocked,
    DriveOn,
    Effect,
    Predicted,
    Traffic,
    Unblocked,
    Wake,
)


class Body:
    def __init__(self, traffic: Traffic) -> None:
        self.traffic = traffic
        self.heap: list[tuple[float, int, Callable[[float], None]]] = []
        self.order = itertools.count()
        self.leg: dict[int, Leg] = {}
        self.token: dict[int, int] = {}
        self.log: list[tuple[float, str, int, Any]] = []
        #: called with (robot, now) when a robot has arrived at the end of a leg (a fleet manager's hook)
        self.arrived: Callable[[int, float], None] | None = None

    def at(self, t: float, call: Callable[[float], None]) -> None:
        heapq.heappush(self.heap, (t, next(self.order), call))

    def send(self, i: int, leg: Leg) -> None:
        """Robot ``i`` starts ``leg`` at its ``t0``."""
        self.at(leg.t0, lambda now: self._start(i, leg, now, self.traffic.drive(i, leg, now)))

    def run(self, until: float, limit: int = 100_000) -> list[tuple[float, str, int, Any]]:
        """Play events up to ``until``; more than ``limit`` of them is a runaway (an assertion fails)."""
        played = 0
        while self.heap and self.heap[0][0] <= until:
            t, _, call = heapq.heappop(self.heap)
            call(t)
            played += 1
            assert played <= limit, f"more than {limit} events by t = {t}: {self.log[-6:]}"
        return self.log

    def _start(self, i: int, leg: Leg, now: float, effects: list[Effect]) -> None:
        self.leg[i] = leg
        token = self.token[i] = self.token.get(i, 0) + 1
        self.at(leg.t_end, lambda t: self._arrive(i, token, t))
        self.apply(effects, now)

    def _arrive(self, i: int, token: int, now: float) -> None:
        if self.token.get(i) != token:
            return
        leg = self.leg[i]
        self.log.append((now, "arrived", i, (leg.x1, leg.y1)))
        self.apply(self.traffic.rest(i, (leg.x1, leg.y1, leg.end_theta), now), now)
        if self.arrived is not None:
            self.arrived(i, now)

    def apply(self, effects: list[Effect], now: float) -> None:
        for e in effects:
            if isinstance(e, Predicted):
                change = e.change
                self.at(change.t, lambda t, c=change: self.apply(self.traffic.due(c, t), t))
            elif isinstance(e, Wake):
                if e.kind == BRAKED:
                    self.at(e.t, lambda t, w=e: self.apply(self.traffic.braked(w.robot, w.spell, t), t))
                else:
                    self.at(e.t, lambda t, w=e: self.apply(self.traffic.overdue(w.robot, t), t))
            elif isinstance(e, Brake):
                self.token[e.robot] = self.token.get(e.robot, 0) + 1  # the running leg will not arrive
                self.log.append((now, "brake", e.robot, (e.braking.t_stop, e.braking.pose)))
            elif isinstance(e, DriveOn):
                assert not self.traffic.watch.holding(e.robot), "drives on with a robot in its field"
                self.log.append((now, "drive_on", e.robot, None))
                self._start(e.robot, e.leg, now, [])
            elif isinstance(e, BlockedBy):
                self.log.append((now, "blocked", e.robot, e.other))
            elif isinstance(e, Unblocked):
                self.log.append((now, "unblocked", e.robot, None))
            elif isinstance(e, Deadlocked):
                self.log.append((now, "deadlock", -1, e.deadlock))
