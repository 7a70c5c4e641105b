"""A fleet manager in the loop, in simulated time (SPEC §9): the transport the RAN sees is Orion, and
behind it runs a :class:`~vcran.core.manager.FleetManager`.

:class:`ClosedLoop` implements the transport interface (:class:`vcran.core.wire.Transport`), so the RAN
and the model are the same as under a script or a replay. It starts the manager, hands it the
scenario's jobs at their times, turns what reaches it over the :class:`~vcran.sim.link.Link` into its
updates, and gives it a :class:`SimHandle` whose writes go back over the link and whose timers are
SimPy events. Every callback runs at a simulated instant with its own priority (vcran/sim/timing.py:
updates, then jobs, then timers), so the whole loop is deterministic (SPEC §5).

A closed-loop run is over (``until_idle``) only when nothing is left to do on the manager's side either:
no job still to come or still open, no timer pending, nothing the manager wrote still on its way, and
no update other than periodic telemetry still on its way to the manager (:attr:`ClosedLoop.exhausted`).
"""

from __future__ import annotations

import inspect
import math
import random
from collections.abc import Callable, Iterator
from typing import Any, Protocol

import simpy

from vcran.core.build import motion_message
from vcran.core.jobs import JobBook, Log
from vcran.core.manager import Fleet, FleetManager, Handle, Timer
from vcran.core.messages import FORCED_UPDATES, OUTBOUND, Message, Time
from vcran.core.scenario import Job, Scenario
from vcran.core.wire import Deliver, Frame, Outbound, Transport
from vcran.sim.link import Link
from vcran.sim.timing import JOB, TIMER, at

#: How the note on an exception a fleet manager raised begins (``in fleet manager Mine: on_job at t=1.0``).
MANAGER_NOTE = "in fleet manager "


def manager_note(exc: BaseException) -> str | None:
    """The note saying which hook of the fleet manager raised ``exc`` and when, or None: not the manager's."""
    return next((n for n in getattr(exc, "__notes__", ()) if n.startswith(MANAGER_NOTE)), None)


class ManagerLink(Protocol):
    """What a closed loop needs of the link between its manager and the robots (:class:`Link`, or Orion)."""

    def write(self, robot: str, attribute: str, message: Message | None, raw: Any = None) -> None: ...

    @property
    def inbound_idle(self) -> bool: ...

    @property
    def outbound_idle(self) -> bool: ...


class ClosedLoop(Transport):
    """The RAN's transport in a closed loop. ``log`` receives the ``job_*`` events (events.jsonl)."""

    def __init__(self, scenario: Scenario, manager: FleetManager, log: Log) -> None:
        self.scenario, self.manager = scenario, manager
        self.fleet = Fleet.of(scenario)
        self.jobs = JobBook(log)
        self.link: ManagerLink | None = None
        self.handle: SimHandle | None = None
        self.timers = 0
        self._workload: Iterator[Job] = scenario.workload()
        self._jobs_to_come = True
        self._subscribed = manager.attributes
        self._latest: dict[tuple[str, str], Message] = {}
        self._frame: Frame | None = None
        self._index = {r: i for i, r in enumerate(self.fleet.robot_ids)}
        self._stale: dict[str, Frame] = {}  # robots missing from the latest frame (link down): their last one

    def attach(self, env: simpy.Environment, deliver: Deliver) -> None:
        seed = self.scenario.settings.seed
        self.link = self.make_link(env, deliver)
        self.handle = SimHandle(env, self, random.Random(f"manager:{seed}"))
        self.manager._bind(self.fleet, self.handle)
        self._next_job(env)
        self._call("on_start")

    def make_link(self, env: simpy.Environment, deliver: Deliver) -> ManagerLink:
        """The link between manager and RAN: Orion in simulated time. ``vcran manage`` puts a real Orion
        here (:class:`transports.orion.manage.OrionManagerLink`): anything with :meth:`Link.write`,
        ``inbound_idle`` and ``outbound_idle`` that calls :meth:`notified` with what reaches the manager."""
        return Link(env, self.fleet.robot_ids, self.scenario.link, random.Random(f"link:{self.scenario.settings.seed}"),
                    deliver, self.notified)

    def send(self, out: Outbound) -> None:
        assert isinstance(self.link, Link)
        self.link.publish(out)

    def outage(self, robot: str, until: float) -> bool:
        """``link_down`` (SPEC §4) is the link's: Orion between manager and RAN holds what was written, and
        what the robot publishes (its rows of the fleet's frames too) waits (:meth:`Link.outage`)."""
        if not isinstance(self.link, Link):
            return False
        self.link.outage(robot, until)
        return True

    @property
    def exhausted(self) -> bool:
        link = self.link
        return (not self._jobs_to_come and self.jobs.open == 0 and self.timers == 0
                and link is not None and link.inbound_idle and link.outbound_idle)

    # --- what reaches the manager -----------------------------------------------------------------------

    def _next_job(self, env: simpy.Environment) -> None:
        """Schedule the next job's arrival. Hooks run from event callbacks, never inside a SimPy process,
        so an exception the manager raises reaches the caller as raised (a process would wrap it)."""
        job = next(self._workload, None)
        if job is None:
            self._jobs_to_come = False
            return
        at(env, job.t, JOB).callbacks.append(lambda _: self._arrive(env, job))

    def _arrive(self, env: simpy.Environment, job: Job) -> None:
        self.jobs.arrived(env.now, job)
        self._call("on_job", job)
        self._next_job(env)

    def notified(self, batch: list[Outbound], forced: frozenset[str] = FORCED_UPDATES) -> None:
        """One batch of the RAN's publications reaches the manager: Orion's view changes, and the
        manager is notified of each actual change of an attribute it subscribed to, and of every write
        of an attribute in ``forced``, changed or not: the periodic ``robot_description``, which live
        mode writes with Orion's forcedUpdate so that it reaches every subscriber (SPEC §2). The link of
        ``vcran manage`` passes an empty ``forced`` for what a notification of the whole entity carries
        (there an unchanged value is no write of it)."""
        assert self.handle is not None
        now = self.handle.now
        wants = self._subscribed
        for out in batch:
            if isinstance(out, Frame):
                self._take_frame(out)
                if wants is None or "current_motion" in wants:
                    for robot in out.robots:
                        message = self.motion(robot)
                        assert message is not None
                        self._call("on_update", robot, "current_motion", message, now)
                continue
            key = (out.robot, out.attribute)
            if self._latest.get(key) == out.message and out.attribute not in forced:
                continue  # no actual change: Orion notifies nobody
            self._latest[key] = out.message
            if wants is None or out.attribute in wants:
                self._call("on_update", out.robot, out.attribute, out.message, now)

    def _take_frame(self, frame: Frame) -> None:
        """Keep the latest frame; a robot missing from it (its link is down) keeps its last known row."""
        previous = self._frame
        if previous is not None and len(frame.robots) < len(self._index):
            present = set(frame.robots)
            for robot in previous.robots:
                if robot not in present and robot not in self._stale:
                    self._stale[robot] = previous
        if self._stale:
            for robot in frame.robots:
                self._stale.pop(robot, None)
        self._frame = frame

    def latest(self, robot: str, attribute: str) -> Message | None:
        if attribute == "current_motion" and self._frame is not None:
            return self.motion(robot)
        return self._latest.get((robot, attribute))

    def motion(self, robot: str) -> Message | None:
        """``current_motion`` of ``robot`` as Orion holds it, built (like live mode) from the frame row."""
        frame = self._stale.get(robot, self._frame)
        if frame is None:
            return None
        if len(frame.robots) == len(self._index):
            i = self._index[robot]
        elif robot in frame.robots:
            i = frame.robots.index(robot)
        else:
            return None
        x, y, theta, v, w = (float(c) for c in frame.columns[i])
        return motion_message(Time.from_seconds(frame.t), x, y, theta, v, w)

    def _call(self, hook: str, *args: Any) -> None:
        """Run one of the manager's hooks; an exception says where and when it happened, and ends the run."""
        self._run(getattr(self.manager, hook), args, {}, hook)

    def _run(self, fn: Callable[..., Any], args: tuple[Any, ...], kwargs: dict[str, Any], what: str) -> None:
        try:
            returned = fn(*args, **kwargs)
            if returned is not None and (inspect.isgenerator(returned) or inspect.isawaitable(returned)):
                _refuse_waiting(returned, what)
        except (Exception, SystemExit) as exc:
            assert self.handle is not None
            note = f"{MANAGER_NOTE}{type(self.manager).__name__}: {what} at t={self.handle.now!r}"
            if isinstance(exc, SystemExit):
                # The manager's bug like any other: it ends the run, not the process hosting it (vcran run,
                # which exited with the manager's code and left its folder incomplete without a word; a
                # sweep's worker; a test calling vcran.simulate)
                error = RuntimeError(f"{what} called sys.exit({exc.code!r})")
                error.add_note(note)
                raise error from exc
            exc.add_note(note)
            raise


def _refuse_waiting(returned: Any, what: str) -> None:
    """A hook or timer that returned a generator (a SimPy habit: ``yield`` to wait) or a coroutine
    (``async def``) did nothing at all; say so instead of silently dropping its work."""
    kind = "generator" if inspect.isgenerator(returned) else "coroutine" if inspect.iscoroutine(returned) else "awaitable"
    close = getattr(returned, "close", None)
    if close is not None:
        close()  # no "never awaited" warning on top of the error
    name = what.removeprefix("timer ")
    raise TypeError(f"{name} returned a {kind}: hooks and timers run to the end at one simulated instant; to wait, "
                    "schedule a callback (self.handle.call_later) instead of yield or await")


class SimHandle(Handle):
    """The handle of a manager in simulated time: writes go over the link, timers are SimPy events."""

    def __init__(self, env: simpy.Environment, loop: ClosedLoop, rng: random.Random) -> None:
        super().__init__(loop.fleet, loop.jobs, rng)
        self.env, self._loop = env, loop

    @property
    def now(self) -> float:
        return self.env.now

    def _write(self, robot: str, attribute: str, message: Message | None, raw: Any = None) -> None:
        assert self._loop.link is not None
        self._loop.link.write(robot, attribute, message, raw)

    def call_at(self, when: float, fn: Callable[..., Any], *args: Any, **kwargs: Any) -> Timer:
        if not math.isfinite(when):  # a NaN breaks the order of SimPy's event heap; inf never comes
            raise ValueError(f"call_at({when}): not a finite time")
        if when < self.env.now:
            raise ValueError(f"call_at({when}): that is in the past (now {self.env.now})")
        timer = _SimTimer(when, self._loop)
        self._loop.timers += 1
        at(self.env, when, TIMER).callbacks.append(lambda _: timer.fire(fn, args, kwargs))
        return timer

    def latest(self, robot: str, attribute: str) -> Message | None:
        if attribute not in OUTBOUND:  # what the manager writes is not kept: None for ever, say so instead
            raise ValueError(f"latest: {attribute!r} is not an attribute robots publish; known: {', '.join(OUTBOUND)}")
        return self._loop.latest(self._robot(robot), attribute)


class _SimTimer(Timer):
    __slots__ = ("_loop", "_pending")

    def __init__(self, when: float, loop: ClosedLoop) -> None:
        super().__init__(when)
        self._loop, self._pending = loop, True

    def cancel(self) -> None:
        super().cancel()
        self._settle()

    def fire(self, fn: Callable[..., Any], args: tuple[Any, ...], kwargs: dict[str, Any]) -> None:
        if not self.cancelled:
            self._settle()
            self._loop._run(fn, args, kwargs, f"timer {getattr(fn, '__name__', fn)!s}")

    def _settle(self) -> None:
        if self._pending:
            self._pending = False
            self._loop.timers -= 1
