"""Working, holding and stopping: how a robot's body waits out a work and what may cut it short (docs/contract.md §4).

A *work* is a leg the AGV drives or an action AgvAction performs (:mod:`vcran.sim.body`). While it runs, its
process waits in :meth:`Holds._work` and is the body's *worker*; SimPy's ``Process.interrupt`` (which costs
nothing until used) cuts the wait short with a cause:

* :data:`HOLD` / :data:`RELEASE`: a pause or a breakdown stops the robot where it is; released, the work
  resumes exactly where it stopped, its remaining time unchanged (:meth:`Holds.hold`, :meth:`Holds.release`);
* a :class:`Halted`: the robot stops for good (battery empty, motion failure, collision; :meth:`Holds.halt`),
  and the protocol's logic is told through the body's ``tell`` hook;
* :data:`ABANDON`: the work that began at this very instant does not happen (R14); :data:`STOP`: the leg ends
  where the robot is (VDA 5050's StopNow). The logic asked for either, so nothing is reported.

A mixin of :class:`vcran.sim.body.Body` (one concept per module; a method of a mixin costs what a method of the
class does, and the AGV's hot path calls these once a leg).
"""

from __future__ import annotations

from collections.abc import Callable, Generator
from dataclasses import dataclass
from typing import Any

import simpy
from simpy.events import Process as SimProcess

from vcran.core.battery import linear_empty_after
from vcran.sim.timing import COMPLETION, after

#: Interrupt causes for a working process (besides a :class:`Halted`): stop in place / go on / the work
#: that began at this instant does not happen (R14: a cancel or timeout at the instant the previous ended) /
#: the leg ends where the robot is (:meth:`vcran.sim.body.Body.stop_now`).
HOLD, RELEASE, ABANDON, STOP = "hold", "release", "abandon", "stop"

#: Why a body stops for good (:attr:`Halted.why`; docs/contract.md §4). A protocol maps them onto its own words (OPIL: the
#: cancel reason and ran_error code of the same name; VDA 5050: the vehicle's ``on_halted``).
BATTERY_EMPTY, MOTION_FAILED, COLLISION = "battery_empty", "motion_failed", "collision"
#: docs/contract.md §12: the robot was deadlocked and the scenario cancels its work (``on_deadlock = "cancel"``).
DEADLOCK = "deadlock"


@dataclass(frozen=True, slots=True)
class Halted:
    """Body -> logic: the robot stopped where it is, for good (one of the ``why`` above); ``out_of_service``:
    it takes no work until an :class:`InService` (an empty battery, until its swap)."""

    why: str
    message: str
    out_of_service: bool = False


@dataclass(frozen=True, slots=True)
class InService:
    """Body -> logic: a fresh battery; the robot can work again (docs/contract.md §4)."""


Cause = Halted | str | None


class Holds:
    """The body's holds and halts (module docstring). Expects the body's ``env``, ``tell`` and battery
    methods ``_level``, ``_rate`` and ``_battery_empty_halt`` (:mod:`vcran.sim.energy`)."""

    env: simpy.Environment
    tell: Callable[[object], None]
    route: Any
    battery: Any
    _level: Callable[[], float]
    _rate: Callable[[], float]
    _battery_empty_halt: Callable[[], Halted]
    beside: dict[Any, Any]
    _beside_all: Callable[[object], None]

    def _init_holds(self) -> None:
        self._worker: SimProcess | None = None
        self._holds: list[str] = []

    def _work(self, event: simpy.events.Event) -> Generator[simpy.events.Event, Any, Cause]:
        """Wait for ``event`` (the end of a work); an interrupt returns its cause (HOLD, RELEASE, ABANDON or
        a Halted)."""
        self._worker = self.env.active_process
        try:
            yield event
            return None
        except simpy.Interrupt as irq:
            return irq.cause  # type: ignore[no-any-return]
        finally:
            self._worker = None

    def _held(self) -> Generator[simpy.events.Event, Any, Cause]:
        """Stay where the robot is until every hold is released (None), or it stops for good (a
        :class:`Halted`, or :data:`ABANDON`: the work it held does not happen, R14)."""
        while self._holds:
            cut = linear_empty_after(self._level(), self._rate()) if self.battery is not None else float("inf")
            event = after(self.env, cut, COMPLETION) if cut != float("inf") else self.env.event()
            cause = yield from self._work(event)
            if cause is None:
                return self._battery_empty_halt()
            if cause is ABANDON or cause is STOP or isinstance(cause, Halted):
                return cause
        return None

    def hold(self, kind: str) -> None:
        """Stop in place until :meth:`release` of the same kind (pause, breakdown; VDA 5050's pause or a
        blocking instant action)."""
        self._holds.append(kind)
        if len(self._holds) == 1:
            if self._worker is not None:
                self._worker.interrupt(HOLD)
            if self.beside:
                self._beside_all(HOLD)

    def release(self, kind: str) -> bool:
        """End a hold of ``kind``; False when none was in force (a resume without a pause)."""
        if kind not in self._holds:
            return False
        self._holds.remove(kind)
        if not self._holds:
            if self._worker is not None:
                self._worker.interrupt(RELEASE)
            if self.beside:
                self._beside_all(RELEASE)
        return True

    @property
    def holds(self) -> tuple[str, ...]:
        return tuple(self._holds)

    @property
    def working(self) -> bool:
        """Whether a leg or an action is under way (held ones included)."""
        return self._worker is not None

    def halt(self, halted: Halted) -> None:
        """Stop for good now: the running work ends where it is (actions beside it too), and the logic is told
        once."""
        if self.beside:
            self._beside_all(halted)
        if self._worker is not None:
            self._worker.interrupt(halted)
        else:
            self.tell(halted)

    def abandon(self) -> None:
        """R14: the leg or action that began at this instant does not happen (its work has ended; an action
        not begun yet is skipped as its token is no longer current). The route is dropped."""
        self.route.clear()
        if self._worker is not None:
            self._worker.interrupt(ABANDON)

    def _stopped(self, cause: Halted | str) -> None:
        """A work ended early: tell the logic when the robot stopped on its own; an abandoned (R14) or
        stopped one was the logic's own doing."""
        if isinstance(cause, Halted):
            self.tell(cause)
