"""AgvAction: the actions a robot's body performs at stations and chargers (docs/contract.md §1, docs/contract.md §4).

Two ways to have an action performed, both reporting :class:`Acted` with the action's tag when it ends:

* ``act((token, kind, tag))`` queues it: AgvAction performs queued actions one at a time, in order, as the
  robot's work (OPIL's DispatchAction). A hold pauses it, a halt or :meth:`~vcran.sim.holds.Holds.abandon`
  ends it, an empty battery cuts it short; it draws the battery's action power (a charge: charges it);
* :meth:`AgvAction.perform` starts it at once in a process of its own, beside the queued work and the legs
  (VDA 5050's actions that block nothing: several at once, also while driving). Holds pause it, a halt ends
  it (without a report of its own: the halt is reported once), :meth:`AgvAction.interrupt` stops it (nothing
  of it happens, no report). It draws no power of its own (the battery's segment is the body's work's), so a
  charge is only performed through ``act``; :meth:`AgvAction.stop_charging` ends a running charge where the
  battery stands (VDA 5050's stopCharging), without a report.

A failed action moves nothing (an injected action failure included). A mixin of :class:`vcran.sim.body.Body`.
"""

from __future__ import annotations

from collections.abc import Callable, Generator
from dataclasses import dataclass
from typing import Any

import simpy

from vcran.core.actions import ActionKind
from vcran.core.battery import ACT, CHARGE, REST, charge_refusal, linear_empty_after
from vcran.core.scenario import RobotConfig
from vcran.core.stations import Outcome, StationMap, attempt, transfer
from vcran.sim.holds import ABANDON, HOLD, RELEASE, STOP, Cause, Halted
from vcran.sim.timing import COMPLETION, after, at

Process = Generator[simpy.events.Event, Any, None]


@dataclass(slots=True)
class Acted:
    """Body -> logic: the action ``tag`` finished, well or not (not frozen: one a task, issue 14)."""

    tag: Any
    ok: bool
    code: str = ""
    message: str = ""


class AgvAction:
    """The body's actions (module docstring). Expects the body's state, holds and battery."""

    env: simpy.Environment
    config: RobotConfig
    stations: StationMap
    durations: dict[str, float]
    pose: tuple[float, float, float]
    battery: Any
    empty: bool
    carrying: int
    parts_moved: int
    fail_next_action: bool
    tell: Callable[[object], None]
    current: Callable[[], Any]
    _capable: frozenset[ActionKind]
    _worker: Any
    _holds: list[str]
    _orders: Any
    _work: Callable[[simpy.events.Event], Generator[simpy.events.Event, Any, Cause]]
    _held: Callable[[], Generator[simpy.events.Event, Any, Cause]]
    _stopped: Callable[[Halted | str], None]
    _segment: Callable[[int], float | None]
    _level: Callable[[], float]
    _rate: Callable[[], float]
    _charge_time: Callable[[], float]
    _charged: Callable[[], None]
    _battery_empty_halt: Callable[[], Halted]
    watch_idle: Callable[[], None]

    def _init_actions(self) -> None:
        #: The actions performed beside the work (:meth:`perform`), by tag.
        self.beside: dict[Any, simpy.Process] = {}
        #: A charge is the work under way (held ones included): :meth:`stop_charging` may end it.
        self.charging = False

    def _agv_action(self) -> Process:
        while True:
            token, kind, tag = yield self._orders.get()
            if token != self.current():
                continue  # its work ended while it waited (the robot stopped on its own)
            if self._holds:
                halt = yield from self._held()
                if halt is not None:
                    self._stopped(halt)
                    continue
            outcome = self._precheck(kind)
            if outcome is not None:
                # R14: it fails at once, yet as a completion of this instant like any action's end
                # (docs/determinism.md), so that a cancel of the same instant finds it running and abandons
                # it; reported straight away, the failure would reach the logic after that cancel had ended
                # the task. (No hold can come first: faults follow completions.)
                halt = yield from self._work(after(self.env, 0.0, COMPLETION))
                if halt is not None:
                    assert halt is ABANDON or isinstance(halt, Halted)
                    self._stopped(halt)
                    continue
                self.watch_idle()  # a resting battery that ran out meanwhile found the robot working
            else:
                duration = self._charge_time() if kind is ActionKind.CHARGE else self.durations[kind.value]
                self.charging = kind is ActionKind.CHARGE
                halt = yield from self._act(kind, duration)
                self.charging = False
                if halt is not None:
                    self._stopped(halt)
                    continue
                outcome = self._finish(kind)
            self.tell(Acted(tag, outcome.ok, outcome.code, outcome.message))

    def _finish(self, kind: ActionKind) -> Outcome:
        """An action's duration has passed: its outcome, and its effect on parts and battery. An armed
        action failure fails an action that would have succeeded, and then moves nothing (docs/contract.md §4): the
        part stays where it was, the robot carries what it carried before."""
        x, y, _ = self.pose
        outcome, station = attempt(kind, x, y, self.carrying, self.config.capacity, self.stations, self._capable)
        if outcome.ok and kind is ActionKind.CHARGE:
            self._charged()  # the energy went in during the action (its battery segment), whatever it reports
        if outcome.ok:
            failed = self._injected_failure(kind.value)
            if failed is not None:
                return failed
        if station is not None:
            self.carrying = transfer(kind, station, self.carrying)
            if kind is ActionKind.UNLOAD:
                self.parts_moved += 1
        return outcome

    def charge_refused(self) -> Outcome | None:
        """Why a charge would fail if it started now (no battery, no charger in reach, too slow), or None."""
        return self._precheck(ActionKind.CHARGE)

    def stop_charging(self) -> bool:
        """End the running charge now, the battery keeping what went in (VDA 5050's stopCharging, §6.8.1): the
        logic asked, so no report follows. False when no charge runs."""
        if not self.charging or self._worker is None:
            return False
        self._worker.interrupt(STOP)
        return True

    def _precheck(self, kind: ActionKind) -> Outcome | None:
        """An action that cannot start fails at once, not after its duration (R14): one this robot is not
        capable of, a charge the battery rules refuse (:func:`vcran.core.battery.charge_refusal`); else None."""
        if kind is not ActionKind.CHARGE:
            return None if kind in self._capable else Outcome(False, "action_not_capable", f"this robot is not configured to {kind.value}")
        x, y, _ = self.pose
        if self.battery is None:
            refusal = charge_refusal(False, False, 0.0, x, y)
        else:
            charger = self.stations.nearest_in_reach(x, y, chargers=True) is not None
            refusal = charge_refusal(True, charger, self._charge_time() if charger else 0.0, x, y)
        return Outcome(False, *refusal) if refusal is not None else None

    def _act(self, kind: ActionKind, duration: float) -> Generator[simpy.events.Event, Any, Cause]:
        """Wait out an action of ``duration``: held by pause/breakdown, cut short by an empty battery, or
        :data:`ABANDON` as it begins (R14: nothing is performed), or :data:`STOP` (a charge stopped)."""
        env = self.env
        end = env.now + duration
        segment = CHARGE if kind is ActionKind.CHARGE else ACT
        self._segment(segment)
        while True:
            cut = linear_empty_after(self._level(), self._rate()) if self.battery is not None and not self.empty else float("inf")
            finishes = cut >= end - env.now
            cause = yield from self._work(at(env, end, COMPLETION) if finishes else after(env, cut, COMPLETION))
            if cause is RELEASE:
                continue
            if cause is None:
                if finishes:
                    self._segment(REST)
                    return None
                cause = self._battery_empty_halt()
            elif cause is HOLD:
                t_hold = env.now
                self._segment(REST)
                cause = yield from self._held()
                if cause is None:
                    end += env.now - t_hold
                    self._segment(segment)
                    continue
            assert cause is ABANDON or cause is STOP or isinstance(cause, Halted)
            self._segment(REST)
            return cause

    # --- actions beside the work ------------------------------------------------------------------------

    def perform(self, kind: ActionKind, tag: Any) -> None:
        """Start action ``tag`` now, beside whatever else the body does (module docstring)."""
        if kind is ActionKind.CHARGE:
            raise ValueError("a charge is the body's work: act, not perform (it sets the battery's segment)")
        if tag in self.beside:
            raise ValueError(f"action {tag!r} is already being performed")
        self.beside[tag] = self.env.process(self._beside(kind, tag))

    def perform_for(self, seconds: float, tag: Any) -> None:
        """Start ``tag``, an action of no station that takes ``seconds`` of work (VDA 5050's finePositioning),
        beside the rest as :meth:`perform` does; it succeeds unless an action failure is armed."""
        if tag in self.beside:
            raise ValueError(f"action {tag!r} is already being performed")
        self.beside[tag] = self.env.process(self._beside(None, tag, seconds))

    def interrupt(self, tag: Any) -> bool:
        """Stop action ``tag`` (one :meth:`perform` started) now: nothing of it happens, no report follows.
        False when no such action runs."""
        process = self.beside.pop(tag, None)
        if process is None:
            return False
        process.interrupt(ABANDON)
        return True

    def _beside(self, kind: ActionKind | None, tag: Any, seconds: float = 0.0) -> Process:
        env = self.env
        outcome = self._precheck(kind) if kind is not None else None
        end = env.now + (0.0 if outcome is not None else seconds if kind is None else self.durations[kind.value])
        held_since: float | None = env.now if self._holds else None
        while True:
            try:
                # Held: wait for the release (an event nobody triggers; the release interrupts).
                yield env.event() if held_since is not None else at(env, end, COMPLETION)
                break
            except simpy.Interrupt as irq:
                cause = irq.cause
            if cause is HOLD and held_since is None:
                held_since = env.now
            elif cause is RELEASE and held_since is not None:
                end += env.now - held_since
                held_since = None
            elif cause is ABANDON or isinstance(cause, Halted):
                self.beside.pop(tag, None)
                return  # interrupted, or the body halted: nothing of it happens
        del self.beside[tag]
        if outcome is None:
            outcome = self._finish(kind) if kind is not None else self._aligned(tag)
        self.tell(Acted(tag, outcome.ok, outcome.code, outcome.message))

    def _aligned(self, tag: Any) -> Outcome:
        """An action of no station ended: done, or failed by an armed action failure (docs/contract.md §4)."""
        return self._injected_failure(str(tag)) or Outcome(True)

    def _injected_failure(self, what: str) -> Outcome | None:
        """The armed action failure (docs/contract.md §4), used up by the action ``what`` that would have succeeded;
        None when none is armed."""
        if not self.fail_next_action:
            return None
        self.fail_next_action = False
        return Outcome(False, "action_fault", f"{what}: injected action failure (§4)")

    def _beside_all(self, cause: object) -> None:
        """Pass a hold, release or halt on to every action performed beside the work."""
        for process in list(self.beside.values()):
            process.interrupt(cause)
